//! `gridrt-rtl`: the Rust side of the co-processor RTL (`rtl/hdl/`, spec in `rtl/README.md`).
//!
//! - [`twin`]: the RTL's arithmetic, bit for bit (the executable spec of the datapath).
#![warn(missing_docs)]

pub mod twin;
