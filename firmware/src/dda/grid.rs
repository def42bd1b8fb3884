//! The uniform grid and the voxel steps a walk yields: the types both DDAs and the list
//! builder share.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use gridrt_shared::math::{Aabb, Vec3};

/// Largest grid resolution per axis the firmware accepts (scenes with more are rejected at
/// load). Keeps voxel ids below 2^24 (255³ < 2^24) and bounds the list length.
pub const MAX_GRID_DIM: u32 = 255;

/// The uniform grid: its box and its resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridDesc {
    /// Minimum corner of the grid box.
    pub min: Vec3,
    /// Maximum corner of the grid box.
    pub max: Vec3,
    /// Voxels along x, y, z.
    pub dims: [u32; 3],
}

impl GridDesc {
    /// True when the box is finite and non-empty on every axis and every dimension is in
    /// `1..=MAX_GRID_DIM`. Traversal of an invalid grid yields nothing.
    pub fn is_valid(&self) -> bool {
        self.min.is_finite()
            && self.max.is_finite()
            && (0..3).all(|a| self.min[a] < self.max[a])
            && self.dims.iter().all(|&d| (1..=MAX_GRID_DIM).contains(&d))
    }

    /// Number of voxels `nx·ny·nz`.
    pub fn voxel_count(&self) -> u32 {
        self.dims.iter().product()
    }

    /// Linear voxel id `ix + nx·(iy + ny·iz)` (below 2^24 for cells inside a valid grid;
    /// wrapping, not panicking, for cells outside it).
    #[inline]
    pub fn voxel_id(&self, cell: [u32; 3]) -> u32 {
        cell[2].wrapping_mul(self.dims[1]).wrapping_add(cell[1]).wrapping_mul(self.dims[0]).wrapping_add(cell[0])
    }

    /// The grid box.
    pub fn aabb(&self) -> Aabb {
        Aabb { min: self.min, max: self.max }
    }
}

/// One voxel on the ray's path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelStep {
    /// Linear id `ix + nx·(iy + ny·iz)`.
    pub voxel: u32,
    /// Cell indices (ix, iy, iz).
    pub cell: [u32; 3],
    /// Ray parameter where the ray enters the voxel (the clip entry for the first one).
    pub t_enter: f32,
    /// Ray parameter where the ray leaves the voxel (the clip exit for the last one);
    /// always `>= t_enter`, and equal to the next step's `t_enter`.
    pub t_exit: f32,
}
