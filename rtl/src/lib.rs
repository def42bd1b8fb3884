//! `gridrt-rtl`: the Rust side of the co-processor RTL (`rtl/hdl/`, spec in `rtl/README.md`).
//!
//! - [`sim`]: building the Verilated programs (`cargo xtask rtl sim`) and driving them.
//!
//! The RTL's bit-exact twin is the model itself: `gridrt_coproc` with kernel `watertight`,
//! format `fixed64-q23` (arithmetic in `gridrt_coproc::isect::watertight_q23`) and the
//! `TimingProfile::RTL` timeline.
#![warn(missing_docs)]

pub mod sim;
