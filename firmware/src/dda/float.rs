//! The 3D-DDA in f32 (the default build).
//!
//! Differences from the paper, for robustness in f32:
//! - the ray is first clipped to the grid box with the robust slab test
//!   ([`Aabb::clip`](gridrt_shared::math::Aabb::clip)); an empty or zero-length clip yields
//!   nothing (and costs no FSL words);
//! - the start cell is `floor` of the entry point, clamped into the grid, so entry points that
//!   rounding puts a hair outside the box still start in a boundary cell;
//! - the next-boundary distances are recomputed from the plane index at each step instead of
//!   accumulating `t_delta`, so the error does not grow with the path length;
//! - zero direction components get an infinite boundary distance (never stepped) instead of
//!   the `0 · ∞ = NaN` the textbook formula gives for origins on a plane;
//! - the walk is hard-bounded to `nx + ny + nz` voxels whatever the floats do.

use super::grid::{GridDesc, VoxelStep};
use super::walk::{Stepper, Walk};
use gridrt_shared::math::Ray;

/// Iterator over the voxels a ray crosses, in order (Amanatides & Woo 1987).
#[derive(Debug, Clone)]
pub struct Traversal {
    walk: Walk<f32>,
    planes: Planes,
}

/// The grid planes and the ray, for the boundary distances.
#[derive(Debug, Clone)]
struct Planes {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    grid_min: [f32; 3],
    grid_max: [f32; 3],
    cell_size: [f32; 3],
}

impl Traversal {
    /// Starts a walk of `ray` restricted to `[t_min, t_max]`. An invalid ray or grid, or a
    /// clip of zero length, gives an empty walk.
    pub fn new(grid: &GridDesc, ray: &Ray, t_min: f32, t_max: f32) -> Self {
        let mut tr = Self {
            walk: Walk::on_grid(grid.dims, 0.0, f32::INFINITY),
            planes: Planes {
                origin: ray.origin.to_array(),
                inv_dir: [0.0; 3],
                grid_min: grid.min.to_array(),
                grid_max: grid.max.to_array(),
                cell_size: [0.0; 3],
            },
        };
        if !grid.is_valid() || !ray.is_valid() || t_min.is_nan() || t_max.is_nan() {
            return tr;
        }
        let Some((t0, t1)) = grid.aabb().clip(ray, t_min, t_max) else { return tr };
        // Positive length only: a ray that only touches the box (or starts on a face going
        // out) visits nothing. Infinite ends cannot happen for a valid ray unless t_min is.
        if t1.is_nan() || t1 <= t0 || !t0.is_finite() {
            return tr;
        }
        let entry = ray.at(t0);
        for a in 0..3 {
            let n = grid.dims[a] as i32;
            tr.walk.dims[a] = n;
            let extent = grid.max[a] - grid.min[a];
            let size = extent / n as f32;
            tr.planes.cell_size[a] = size;
            // floor + clamp: rounding may put the entry point just outside the box.
            let rel = (entry[a] - grid.min[a]) / extent * n as f32;
            // max/min, not clamp: n ≥ 1 (is_valid), and clamp's min ≤ max assert would link
            // a formatted panic into the soft-core image.
            let c = (libm::floorf(rel) as i32).max(0).min(n - 1);
            tr.walk.cell[a] = c;
            let d = ray.dir[a];
            if d > 0.0 {
                tr.walk.step[a] = 1;
                tr.planes.inv_dir[a] = 1.0 / d;
            } else if d < 0.0 {
                tr.walk.step[a] = -1;
                tr.planes.inv_dir[a] = 1.0 / d;
            }
            // d == 0: step 0, t_next stays +∞, the axis is never stepped.
            tr.walk.t_next[a] = tr.planes.next_crossing(&tr.walk, a);
        }
        tr.walk.start(t0, t1, grid.dims);
        tr
    }
}

impl Planes {
    /// Position of boundary plane `k` (0..=n) on axis `a` of a grid with `n` voxels on it; the
    /// last plane is exactly `max`.
    #[inline]
    fn plane(&self, a: usize, k: i32, n: i32) -> f32 {
        if k >= n {
            self.grid_max[a]
        } else {
            self.grid_min[a] + k as f32 * self.cell_size[a]
        }
    }
}

impl Stepper for Planes {
    type T = f32;

    #[inline]
    fn min(a: f32, b: f32) -> f32 {
        a.min(b)
    }

    #[inline]
    fn max(a: f32, b: f32) -> f32 {
        a.max(b)
    }

    /// Recomputed from the plane index (no accumulated `t_delta`); an axis that is never
    /// stepped keeps its +∞.
    #[inline]
    fn next_crossing(&self, walk: &Walk<f32>, a: usize) -> f32 {
        let s = walk.step[a];
        if s == 0 {
            return walk.t_next[a];
        }
        let k = if s > 0 { walk.cell[a] + 1 } else { walk.cell[a] };
        (self.plane(a, k, walk.dims[a]) - self.origin[a]) * self.inv_dir[a]
    }

    #[inline]
    fn world(&self, t: f32) -> f32 {
        t
    }
}

impl Iterator for Traversal {
    type Item = VoxelStep;

    #[inline]
    fn next(&mut self) -> Option<VoxelStep> {
        self.walk.next(&self.planes)
    }
}
