//! The traversal list: the non-empty voxels of a walk, as the FSL request carries them.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use super::fixed::{DdaOverflow, FixedTraversal};
use super::float::Traversal;
use super::grid::{GridDesc, VoxelStep, MAX_GRID_DIM};
use crate::fixed::RayFormat;
use gridrt_shared::fsl::ListEntry;
use gridrt_shared::math::Ray;
use gridrt_shared::scene::EMPTY_VOXEL;

/// Capacity of a traversal list: a ray visits at most `nx + ny + nz − 2` voxels.
pub const MAX_LIST: usize = 3 * MAX_GRID_DIM as usize;

/// A traversal list ready for the FSL request.
pub type TraversalList = heapless::Vec<ListEntry, MAX_LIST>;

/// Fills `list` with the non-empty voxels the ray crosses in `[t_min, t_max]`, in order, each
/// with its owning PE (from `voxel_pe`, [`EMPTY_VOXEL`] = empty; ids past its end count as
/// empty) and its exit distance. Returns the number of voxels walked (empty ones included).
///
/// An empty list means the ray sends nothing to the co-processor. Uses the build's DDA
/// format ([`RayFormat::DEFAULT`]: f32, or fixed point with feature `fixed-raygen`).
#[inline]
pub fn build_list(
    grid: &GridDesc,
    voxel_pe: &[u8],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    list: &mut TraversalList,
) -> u32 {
    build_list_in(RayFormat::DEFAULT, grid, voxel_pe, ray, t_min, t_max, list).0
}

/// [`build_list`] with an explicit DDA format. Returns the voxels walked and whether the
/// fixed-point DDA could not represent the ray ([`DdaOverflow`]) and the f32 DDA walked it
/// instead (never silently: the flag is the report).
#[inline]
pub fn build_list_in(
    format: RayFormat,
    grid: &GridDesc,
    voxel_pe: &[u8],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    list: &mut TraversalList,
) -> (u32, bool) {
    match format {
        RayFormat::F32 => (fill_list(Traversal::new(grid, ray, t_min, t_max), voxel_pe, list), false),
        RayFormat::Fixed => match FixedTraversal::new(grid, ray, t_min, t_max) {
            Ok(walk) => (fill_list(walk, voxel_pe, list), false),
            Err(DdaOverflow) => (fill_list(Traversal::new(grid, ray, t_min, t_max), voxel_pe, list), true),
        },
    }
}

#[inline(always)]
fn fill_list(walk: impl Iterator<Item = VoxelStep>, voxel_pe: &[u8], list: &mut TraversalList) -> u32 {
    list.clear();
    let mut walked = 0;
    for (n, v) in (1..).zip(walk) {
        walked = n;
        let pe = voxel_pe.get(v.voxel as usize).copied().unwrap_or(EMPTY_VOXEL);
        if pe == EMPTY_VOXEL {
            continue;
        }
        // Cannot overflow: the walk is bounded by nx+ny+nz ≤ MAX_LIST; stop rather than panic.
        if list.push(ListEntry { voxel: v.voxel, pe, t_exit: v.t_exit }).is_err() {
            break;
        }
    }
    walked
}
