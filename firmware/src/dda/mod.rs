//! 3D-DDA uniform-grid traversal and the traversal list of non-empty voxels.
//!
//! Source: J. Amanatides and A. Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing",
//! Eurographics 1987 — the algorithm GridRT's MicroBlaze runs (GridRT, Nery 2010, via Suffern).
//! Two number formats walk the same way and yield the same [`VoxelStep`]s up to rounding:
//! f32 ([`Traversal`], the default) and fixed point ([`FixedTraversal`], for soft-cores
//! without an FPU; cargo feature `fixed-raygen` makes [`build_list`] use it).
//!
//! Ties (the ray crosses an edge or corner exactly) step the lowest axis first; the voxel
//! visited in between is touched in a single point and has a zero-length interval.
//! A ray lying in a grid plane takes the voxel on the + side of it (floor), the last voxel at
//! the box's max face.
//!
//! Accuracy (pinned by the tests, against an exact f64 per-voxel slab test): every voxel the
//! ray crosses more than δ = 2^-20·S inside is visited, none it misses by more than δ is, with
//! S the largest coordinate magnitude; only voxels touched within δ of their boundary (point,
//! edge, face) may differ. Enter/exit distances are right to within δ along each axis.
//!
//! | module | concern | uses |
//! | --- | --- | --- |
//! | `grid` | [`GridDesc`], [`VoxelStep`], [`MAX_GRID_DIM`] | — |
//! | `walk` | the voxel step both formats share (axis choice, ties, the hard bound) | `grid` |
//! | `float` | [`Traversal`]: clip and setup in f32, boundaries recomputed per step | `grid`, `walk` |
//! | `fixed` | [`FixedTraversal`]: exact setup in integers, `t_delta` steps, [`DdaOverflow`] | `grid`, `walk` |
//! | `list` | [`build_list`]: the non-empty voxels with their PE for the FSL request | all of the above |
//! | `ahead` | [`fill_ahead`]: per voxel and octant, a non-empty voxel ahead (walks stop where none is); [`VoxelMap`] | — |
//! | `light_cells` | [`LightCells`]: shadow-ray lists from the non-empty voxels binned by direction from the light, no walk | `request`, `ahead` |
//! | `request` | [`WalkGrid`]: the f32 walk and the list fused, written as FSL request words (what the device runs); [`OriginPlanes`]: the camera rays' per-origin subtractions | `grid`, `ahead` |

mod ahead;
mod fixed;
mod float;
mod grid;
mod light_cells;
mod list;
mod request;
mod walk;

pub use ahead::{fill_ahead, VoxelMap};
pub use fixed::{DdaOverflow, FixedTraversal};
pub use float::Traversal;
pub use grid::{GridDesc, VoxelStep, MAX_GRID_DIM};
pub use light_cells::{LightCells, T_EXIT_ALL};
pub use list::{build_list, build_list_in, TraversalList, MAX_LIST};
pub use request::{OriginPlanes, Resume, WalkGrid};

#[cfg(test)]
mod tests;
