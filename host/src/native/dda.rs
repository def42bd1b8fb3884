//! The firmware's 3D-DDA walk (`gridrt_firmware::dda::Traversal`), restated for speed: the
//! same floating-point operations in the same order, so the same voxels and the same exit
//! distances, but with per-grid constants (plane positions, strides) hoisted out of the walk
//! and the list fused away: each non-empty voxel is handed to the caller as it is reached,
//! and the caller may stop the walk.
//!
//! What is copied from the firmware and `gridrt_shared::math` (keep in step; the tests in
//! `host/tests/native_path.rs` pin the result word for word against the original):
//! - `Aabb::clip` (slab test with pbrt-v4's `1 + 2γ(3)` widening of the far distance);
//! - `Traversal::new`: entry point `o + d·t0`, start cell `floor((entry − min) / extent · n)`
//!   clamped into the grid, `1 / d` per axis, step 0 for a zero component;
//! - `Traversal::plane` / `update_next`: `t_next = (plane(k) − o) · (1 / d)` with
//!   `plane(k) = min + k·size` (k < n) or `max` (k = n), `size = extent / n`;
//! - `Traversal::next`: lowest axis wins ties, `t_exit = min(t_cross, t_end).max(t)`, stop when
//!   `t_cross` is NaN or `≥ t_end` or the next cell leaves the grid, at most `nx + ny + nz`
//!   voxels.

use core::ops::ControlFlow;

use gridrt_firmware::dda::GridDesc;
use gridrt_shared::math::{gamma, Ray};

/// `cell_span` value of a voxel the firmware never lists (empty, or no owner).
pub(crate) const NO_SPAN: u32 = u32::MAX;

/// A walk's start: the ray, its start cell and first boundary distances, its clip.
struct Start {
    o: [f32; 3],
    inv: [f32; 3],
    cell: [i32; 3],
    step: [i32; 3],
    t_next: [f32; 3],
    voxel: u32,
    t0: f32,
    t_end: f32,
}

/// Per-grid constants of the walk.
#[derive(Debug, Clone)]
pub(crate) struct GridWalk {
    /// False for a grid the firmware's `GridDesc::is_valid` refuses (walks are then empty).
    valid: bool,
    min: [f32; 3],
    max: [f32; 3],
    dims: [i32; 3],
    extent: [f32; 3],
    /// Linear-id stride of a step along each axis: 1, nx, nx·ny.
    stride: [u32; 3],
    /// Boundary planes per axis: `planes[a][k]` for k in 0..=n (the last one is `max`).
    planes: [Vec<f32>; 3],
    steps: u32,
}

impl GridWalk {
    /// The constants of `grid` (computed exactly as the firmware computes them per ray).
    pub(crate) fn new(grid: &GridDesc) -> Self {
        let valid = grid.is_valid();
        let min = grid.min.to_array();
        let max = grid.max.to_array();
        let dims = grid.dims.map(|d| if valid { d as i32 } else { 0 });
        let extent = [0, 1, 2].map(|a| max[a] - min[a]);
        let planes = [0, 1, 2].map(|a| {
            let n = dims[a];
            let size = extent[a] / n as f32;
            (0..=n).map(|k| if k >= n { max[a] } else { min[a] + k as f32 * size }).collect::<Vec<f32>>()
        });
        let nx = dims[0].max(0) as u32;
        let ny = dims[1].max(0) as u32;
        Self {
            valid,
            min,
            max,
            dims,
            extent,
            stride: [1, nx, nx.wrapping_mul(ny)],
            planes,
            steps: dims.iter().map(|&d| d.max(0) as u32).sum(),
        }
    }

    /// Number of voxels.
    pub(crate) fn voxel_count(&self) -> usize {
        self.dims.iter().map(|&d| d.max(0) as usize).product()
    }

    /// `Aabb::clip` of the grid box (copied: see the module doc).
    #[inline(always)]
    fn clip(&self, o: &[f32; 3], inv: &[f32; 3], t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for a in 0..3 {
            let mut t_near = (self.min[a] - o[a]) * inv[a];
            let mut t_far = (self.max[a] - o[a]) * inv[a];
            if t_near > t_far {
                core::mem::swap(&mut t_near, &mut t_far);
            }
            t_far *= 1.0 + 2.0 * gamma(3);
            if t_near > t0 {
                t0 = t_near;
            }
            if t_far < t1 {
                t1 = t_far;
            }
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// Walks `ray` over `[t_min, t_max]` like `Traversal`, calling `visit(span, t_exit)` for
    /// every voxel whose `cell_span` entry is not [`NO_SPAN`], in order, until it breaks.
    /// Returns the number of voxels walked (empty ones included).
    #[inline(always)]
    pub(crate) fn walk<B>(
        &self,
        cell_span: &[u32],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        visit: impl FnMut(u32, f32) -> ControlFlow<B>,
    ) -> (u32, Option<B>) {
        if !self.valid || !ray.is_valid() || t_min.is_nan() || t_max.is_nan() {
            return (0, None);
        }
        let o = ray.origin.to_array();
        let d = ray.dir.to_array();
        // `1 / d` is also what the clip computes (±∞ for a zero component).
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let Some((t0, t1)) = self.clip(&o, &inv, t_min, t_max) else { return (0, None) };
        if t1.is_nan() || t1 <= t0 || !t0.is_finite() {
            return (0, None);
        }
        let entry = ray.at(t0).to_array();
        let mut cell = [0i32; 3];
        let mut step = [0i32; 3];
        let mut t_next = [f32::INFINITY; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let rel = (entry[a] - self.min[a]) / self.extent[a] * n as f32;
            let c = (rel.floor() as i32).max(0).min(n - 1);
            cell[a] = c;
            if d[a] > 0.0 {
                step[a] = 1;
                t_next[a] = (self.plane(a, c + 1) - o[a]) * inv[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                t_next[a] = (self.plane(a, c) - o[a]) * inv[a];
            }
        }
        let voxel = (cell[0] as u32)
            .wrapping_add(self.stride[1].wrapping_mul(cell[1] as u32))
            .wrapping_add(self.stride[2].wrapping_mul(cell[2] as u32));
        let start = Start { o, inv, cell, step, t_next, voxel, t0, t_end: t1 };
        // A finite 1/d on every stepped axis keeps every boundary distance free of NaN
        // (finite plane − finite origin, times a finite factor), which the fast loop needs.
        if (0..3).all(|a| step[a] == 0 || inv[a].is_finite()) {
            self.walk_finite(cell_span, &start, visit)
        } else {
            self.walk_exact(cell_span, &start, visit)
        }
    }

    /// The walk with the three axes in registers. Valid when no boundary distance can be NaN:
    /// then `Traversal::next`'s `t_cross.is_nan() || t_cross ≥ t_end` is `!(t_cross < t_end)`,
    /// an axis that does not step keeps `t_next = +∞` and is never stepped (an infinite
    /// `t_cross` always ends the walk), and the `nx + ny + nz` bound cannot bind (each step
    /// moves one cell along an axis in a fixed direction, so a walk is at most
    /// `Σ(n − 1) + 1` voxels) — it is kept anyway.
    #[inline(always)]
    fn walk_finite<B>(
        &self,
        cell_span: &[u32],
        st: &Start,
        mut visit: impl FnMut(u32, f32) -> ControlFlow<B>,
    ) -> (u32, Option<B>) {
        let [mut tx, mut ty, mut tz] = st.t_next;
        let [mut cx, mut cy, mut cz] = st.cell;
        let [sx, sy, sz] = st.step;
        let [nx, ny, nz] = self.dims;
        let [ox, oy, oz] = st.o;
        let [ix, iy, iz] = st.inv;
        let [px, py, pz] = [&self.planes[0][..], &self.planes[1][..], &self.planes[2][..]];
        // Voxel id deltas of a step on each axis.
        let dvx = (sx as u32).wrapping_mul(self.stride[0]);
        let dvy = (sy as u32).wrapping_mul(self.stride[1]);
        let dvz = (sz as u32).wrapping_mul(self.stride[2]);
        // Plane index of each axis' next boundary: c + 1 going up, c going down.
        let next_plane = |c: i32, s: i32| (c + (s > 0) as i32) as usize;
        let mut voxel = st.voxel;
        let mut t = st.t0;
        let t_end = st.t_end;
        let mut walked = 0u32;
        while walked < self.steps {
            walked += 1;
            let (axis, t_cross) = if tx <= ty && tx <= tz {
                (0, tx)
            } else if ty <= tz {
                (1, ty)
            } else {
                (2, tz)
            };
            let t_exit = t_cross.min(t_end).max(t);
            let span = cell_span.get(voxel as usize).copied().unwrap_or(NO_SPAN);
            if span != NO_SPAN {
                if let ControlFlow::Break(b) = visit(span, t_exit) {
                    return (walked, Some(b));
                }
            }
            if !(t_cross < t_end) {
                break;
            }
            match axis {
                0 => {
                    cx += sx;
                    if cx < 0 || cx >= nx {
                        break;
                    }
                    voxel = voxel.wrapping_add(dvx);
                    tx = (px.get(next_plane(cx, sx)).copied().unwrap_or(self.max[0]) - ox) * ix;
                }
                1 => {
                    cy += sy;
                    if cy < 0 || cy >= ny {
                        break;
                    }
                    voxel = voxel.wrapping_add(dvy);
                    ty = (py.get(next_plane(cy, sy)).copied().unwrap_or(self.max[1]) - oy) * iy;
                }
                _ => {
                    cz += sz;
                    if cz < 0 || cz >= nz {
                        break;
                    }
                    voxel = voxel.wrapping_add(dvz);
                    tz = (pz.get(next_plane(cz, sz)).copied().unwrap_or(self.max[2]) - oz) * iz;
                }
            }
            t = t_exit;
        }
        (walked, None)
    }

    /// The walk exactly as `Traversal::next` writes it (NaN boundary distances included).
    #[inline(never)]
    fn walk_exact<B>(
        &self,
        cell_span: &[u32],
        st: &Start,
        mut visit: impl FnMut(u32, f32) -> ControlFlow<B>,
    ) -> (u32, Option<B>) {
        let (o, inv, step) = (st.o, st.inv, st.step);
        let mut cell = st.cell;
        let mut t_next = st.t_next;
        let mut voxel = st.voxel;
        let mut t = st.t0;
        let t_end = st.t_end;
        let mut walked = 0u32;
        while walked < self.steps {
            walked += 1;
            let [tx, ty, tz] = t_next;
            // Lowest axis wins ties.
            let axis = if tx <= ty && tx <= tz {
                0
            } else if ty <= tz {
                1
            } else {
                2
            };
            let t_cross = t_next[axis];
            // min/max ignore NaN, so a NaN boundary ends the voxel at t_end.
            let t_exit = t_cross.min(t_end).max(t);
            // Ids are in range: cells stay inside the grid (checked before every step).
            let span = cell_span.get(voxel as usize).copied().unwrap_or(NO_SPAN);
            if span != NO_SPAN {
                if let ControlFlow::Break(b) = visit(span, t_exit) {
                    return (walked, Some(b));
                }
            }
            if t_cross.is_nan() || t_cross >= t_end {
                break;
            }
            let c = cell[axis] + step[axis];
            if c < 0 || c >= self.dims[axis] {
                break;
            }
            cell[axis] = c;
            voxel = if step[axis] > 0 {
                voxel.wrapping_add(self.stride[axis])
            } else {
                voxel.wrapping_sub(self.stride[axis])
            };
            let k = if step[axis] > 0 { c + 1 } else { c };
            t_next[axis] = (self.plane(axis, k) - o[axis]) * inv[axis];
            t = t_exit;
        }
        (walked, None)
    }

    /// Boundary plane `k` of axis `a` (`Traversal::plane`).
    #[inline(always)]
    fn plane(&self, a: usize, k: i32) -> f32 {
        // k is in 0..=n: cells are clamped into the grid before a plane is looked up.
        self.planes[a].get(k.max(0) as usize).copied().unwrap_or(self.max[a])
    }
}
