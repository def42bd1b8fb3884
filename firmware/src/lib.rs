//! Soft-core firmware library: everything the device does between its UART and its
//! co-processor link, written once and compiled both for the RISC-V image and for host tests
//! and the loopback simulator.
//!
//! | module | what |
//! |---|---|
//! | [`camera`] | pinhole camera (CONTRACTS.md) |
//! | [`cull`] | per-row spans of the pixels whose camera rays can enter the grid box |
//! | [`dda`] | 3D-DDA grid traversal in f32 and in fixed point (feature `fixed-raygen`), traversal lists (Amanatides & Woo 1987) |
//! | [`fixed`] | exact f32 ↔ fixed-point conversions, the ray-generation/DDA format switch |
//! | [`fmath`] | `f32` polynomial sin/cos/tan/atan2/acos/pow (no libm trigonometry, no `f64`) |
//! | [`shade`] | shading of a hit: GridRT's matte surface, ViRAY's Lambert/Oren–Nayar/Blinn–Phong/Torrance–Sparrow, Fresnel, spotlight, shadow rays (CONTRACTS.md) |
//! | [`texture`](mod@texture) | procedural textures, mappings, bilinear filtering (feature `textures`) |
//! | [`interp`] | row interpolation (Malcheva et al.) |
//! | [`splat`] | point splats: shape table, code generator (the DSP), splat stage (the FPGA) |
//! | [`pixels`] | frame encoder, pixel spans, running image CRC |
//! | [`text`] | text output without `core::fmt` (error texts, banner, reports) |
//! | [`device`] | the device state machine (UART frames ↔ FSL link) |
//! | [`fsl`] | the co-processor link trait |
//! | [`boot`] | the flash bootloader's protocol (SPEC.md §3.11) |
//! | [`bsp`] | board drivers |
//!
//! The modules that parse or index link data (UART frames and commands, FSL words, the
//! scene upload, flash images, pixel and row buffers: `boot`, `bsp`, `device`, `fsl`,
//! `pixels`, `interp`, `text`, and the grid and list of `dda`) deny
//! `clippy::indexing_slicing` and `clippy::arithmetic_side_effects`: they use `get`,
//! checked or saturating arithmetic, and wrapping arithmetic for counters (what release
//! builds always did, at no cost per word). The numeric kernels (camera, the DDA walk,
//! shading, textures, `fmath`, `fixed`) compute on values checked at load or clamped where
//! they are used, and stay free of those checks on the hot path.
//!
//! Byte output and UART I/O use the ecosystem's blocking traits, [`embedded_io`] 0.6
//! (re-exported, so dependents name the same version): the device loop and the bootloader
//! write to any `embedded_io::Write`, and the `bsp` UARTs implement `Read`/`ReadReady`/`Write`.
#![cfg_attr(not(test), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub use embedded_io;

pub mod boot;
pub mod bsp;
pub mod camera;
pub mod cull;
pub mod dda;
pub mod device;
pub mod fixed;
pub mod fmath;
pub mod fsl;
pub mod interp;
pub mod pixels;
pub mod sfloat;
pub mod shade;
pub mod splat;
pub mod text;
#[cfg(feature = "textures")]
pub mod texture;
