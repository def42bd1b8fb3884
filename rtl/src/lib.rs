//! `gridrt-rtl`: the Rust side of the co-processor RTL (`rtl/hdl/`, spec in `rtl/README.md`).
//!
//! - [`twin`]: the RTL's arithmetic, bit for bit (the executable spec of the datapath).
//! - [`sim`]: building the Verilated programs (`cargo xtask rtl sim`) and driving them.
#![warn(missing_docs)]

pub mod sim;
pub mod twin;
