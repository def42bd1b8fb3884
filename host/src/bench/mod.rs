//! Every bench of the library, one module each; the CLI's `gridrt bench …` (`cmd/bench/`)
//! runs them and only draws and writes what they return.
//!
//! | module | bench |
//! |---|---|
//! | [`accuracy`] | `gridrt bench accuracy`: every intersection kernel and number format against the f64 reference, run time and leaks |
//! | [`link`] | `gridrt bench link`: wire bytes, efficiency, compression, modelled frame time |
//! | [`link_faults`] | `gridrt bench link --faults`: goodput against the bit error rate over a faulty line ([`crate::faults`]) |
//! | [`frame`] | `gridrt bench frame`: whole-frame time on the modelled board (soft-core on QEMU, co-processor model, link), per configuration and target |
//! | [`stream`] | `gridrt bench stream`: frame rate and link goodput of a frame stream per scene × baud × encoding, on the paced loopback |
//! | [`pe_cache`] | `gridrt bench pe-cache`: hit rates and modelled cycles of a per-PE cache for PE images in SDRAM, from a frame's PE-memory reads |
//! | [`splat`] | `gridrt bench splat`: the native splat path, splats per second and image error ([`crate::points`]) |

pub mod accuracy;
pub mod frame;
mod in_process;
pub mod link;
#[cfg(unix)]
pub mod link_faults;
pub mod pe_cache;
pub mod splat;
pub mod stream;
