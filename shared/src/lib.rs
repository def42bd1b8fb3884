//! Protocol crate shared by the firmware, the co-processor model and the host.
//!
//! It is the only crate that every side links. Everything here is `no_std`, allocation-free
//! and panic-free on data from outside: decoders return errors, never guess.
//! The wire formats are specified in `shared/SPEC.md`; each table there has a golden-byte
//! test in this crate.
//! Every module that decodes or encodes wire data (`bytes`, `crc`, `frame`, `fsl`, `msg`, `pixel`,
//! `scene`, `window`) denies `clippy::indexing_slicing` and `clippy::arithmetic_side_effects`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![warn(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod bytes;
pub mod cfu;
mod crc;
pub mod frame;
pub mod fsl;
pub mod math;
pub mod msg;
pub mod pixel;
pub mod scene;
pub mod splat;
pub mod window;

/// Version of the UART protocol (frame header byte 1). Bumped on any incompatible change.
pub const PROTOCOL_VERSION: u8 = 1;
