//! `gridrt-coproc`: a no_std model of the GridRT ray-intersection co-processor.
//!
//! Source: A. S. Nery, *GridRT: Uma Arquitetura Paralela para Ray Tracing Utilizando Volumes
//! Uniformes*, M.Sc. thesis, COPPE/UFRJ 2010, with its cross-voxel flaw fixed.
//!
//! - [`Coprocessor`]: PE memories in caller-provided backing words, the FSL word interface
//!   ([`Coprocessor::push`] / [`Coprocessor::pop`]) and a direct API for the host
//!   ([`Coprocessor::load_pe`], [`Coprocessor::trace`], [`Coprocessor::trace_untimed`]);
//!   protocol violations become ERROR words, never guesses ([`coproc`] module doc).
//! - [`timing`]: cycle accounting with the [`TimingProfile::GRIDRT`] (648 cycles/test at
//!   50 MHz), [`TimingProfile::PIPELINED`] and [`TimingProfile::RTL`] (the RTL co-processor,
//!   measured) profiles.
//! - [`isect`]: intersection kernels (watertight — default —, Möller–Trumbore, Wald,
//!   Hanika–Keller, Cramer), each in every [`NumberFormat`] of [`numeric`] (f32 and two
//!   checked fixed-point formats); [`Intersector`] selects one at run time.
//! - [`probe`]: watertightness probes (rays at shared edges and vertices, settled exactly).
//! - [`exact`]: the exact reference: f64 intersection with exact orientation predicates
//!   (Shewchuk-style expansion arithmetic) that settle hit/miss at edges and vertices.
//!
//! Links into the host and into the emulated-board firmware image: no allocation, fixed
//! capacities ([`LIST_CAPACITY`], [`OUT_QUEUE_WORDS`]), no panics on link data.
//! The code that parses or indexes link data ([`coproc`]: FSL words, PE images, PE
//! memory; [`timing`]: cycle counts from list lengths) denies `clippy::indexing_slicing`
//! and `clippy::arithmetic_side_effects`; the kernels' arithmetic is the hot path and is
//! not under that denial ([`isect`] module doc).
#![cfg_attr(not(test), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![warn(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod config;
pub mod coproc;
pub mod exact;
pub mod isect;
pub mod numeric;
pub mod probe;
pub mod timing;

#[cfg(test)]
mod tests;

pub use config::{ArbitrationRule, ConfigError, CoprocConfig, LIST_CAPACITY, OUT_QUEUE_WORDS};
pub use coproc::{
    load_ack, CoprocStats, Coprocessor, NoObserver, PeCacheConfig, PeRead, PeReadKind, PeReadObserver, RayPort,
    TraceInfo, CLEAR_ACK, FRAME_ACK, T_EXIT_REL_TOL,
};
pub use gridrt_shared::fsl::{FslError, FslWord, ListEntry, RayKind, RayResult};
pub use gridrt_shared::math::Ray;
pub use isect::{Intersector, Kernel, KernelKind, Record, RecordStatus};
pub use numeric::{FixedFrame, NumberFormat, OpCount, Overflow};
pub use timing::{test_cycles, OpCycles, TimingProfile, RTL_PES_PER_PIPELINE};
