//! Soft-core firmware library: everything the device does between its UART and its
//! co-processor link, written once and compiled both for the RISC-V image and for host tests
//! and the loopback simulator.
//!
//! | module | what |
//! |---|---|
//! | [`camera`] | pinhole camera (CONTRACTS.md) |
//! | [`dda`] | 3D-DDA grid traversal and traversal lists (Amanatides & Woo 1987) |
//! | [`dda_fixed`] | the same DDA in fixed point (used with feature `fixed-raygen`) |
//! | [`fixed`] | exact f32 ↔ fixed-point conversions, the ray-generation/DDA format switch |
//! | [`fmath`] | `f32` polynomial sin/cos/tan/atan2/acos/pow (no libm trigonometry, no `f64`) |
//! | [`shade`] | shading of a hit: GridRT's matte surface, ViRAY's Lambert/Oren–Nayar/Blinn–Phong/Torrance–Sparrow, Fresnel, spotlight, shadow rays (CONTRACTS.md) |
//! | [`texture`](mod@texture) | procedural textures, mappings, bilinear filtering (feature `textures`) |
//! | [`interp`] | row interpolation (seed 003) |
//! | [`pixels`] | frame encoder, pixel spans, running image CRC |
//! | [`text`] | text output without `core::fmt` (error texts, banner, reports) |
//! | [`device`] | the device state machine (UART frames ↔ FSL link) |
//! | [`fsl`] | the co-processor link trait |
//! | [`boot`] | the flash bootloader's protocol (SPEC.md §3.11) |
//! | [`bsp`] | board drivers |
#![cfg_attr(not(test), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod boot;
pub mod bsp;
pub mod camera;
pub mod dda;
pub mod dda_fixed;
pub mod device;
pub mod fixed;
pub mod fmath;
pub mod fsl;
pub mod interp;
pub mod pixels;
pub mod shade;
pub mod text;
#[cfg(feature = "textures")]
pub mod texture;
