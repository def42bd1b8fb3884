//! The fast native ray path: the firmware's primary rays and 3D-DDA plus the
//! co-processor's watertight f32 search, reorganised for a desktop CPU — with the same answer,
//! word for word.
//!
//! [`NativeScene`] is built from what the firmware uploads and walks with: the grid box and
//! resolution ([`GridDesc`]), the voxel→PE map and the PE memory images. It keeps the PE
//! images' order of references inside each voxel, and re-lays the triangles out for the
//! CPU:
//! - a dense voxel → span table instead of the PEs' binary-searched voxel tables;
//! - each voxel's triangles copied into groups of eight in structure-of-arrays layout
//!   ([`filter::Group`]), so one AVX2 pass (runtime-detected; a portable loop otherwise)
//!   computes the watertight test's edge functions of eight triangles and drops those the ray
//!   does not pierce ([`filter`]);
//! - the survivors go through the co-processor's own kernel
//!   (`gridrt_coproc::isect::watertight::Watertight`), in reference order, with the same
//!   early-out bound, under the same acceptance and arbitration rules (`trace`);
//! - no traversal list: the DDA ([`dda`]) hands each non-empty voxel to the search as it
//!   reaches it and stops at the first voxel with an accepted hit.
//!
//! Result words are those of `Coprocessor::trace_untimed` (`cycles` = 0, `tests` = the tests
//! the PEs perform); `host/tests/native_path.rs` pins them on every pixel of several scenes
//! and on seeded random rays aimed at edges and vertices. Voxels holding analytic primitives
//! (scene image v2) take an ordered scalar path that mirrors the model's loop.
//!
//! What the module assumes of the co-processor (read-only knowledge, copied; keep in step with
//! `coproc/src/coproc.rs`): the interval-checked arbitration rule with
//! [`gridrt_coproc::T_EXIT_REL_TOL`], `accept` (`0 < t < t_max`, `t ≤ hi`), the early-out
//! bound `inflate(x) = x + |x|·2⁻¹⁶`, "first entry in list order with an accepted hit wins;
//! inside it the nearest (ties: lowest prim id; Any: the first in reference order)".

pub mod dda;
#[cfg(feature = "embree")]
pub mod embree;
pub mod filter;
mod frame;
mod scene;
mod trace;

pub use frame::PrimaryFrame;
pub use scene::{grid_desc, NativeError, NativeScene};
pub use trace::{Hits, Trace};
