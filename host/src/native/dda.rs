//! The firmware's 3D-DDA walk (`gridrt_firmware::dda::Traversal`), restated for speed: the
//! same floating-point operations in the same order, so the same voxels and the same exit
//! distances, but with per-grid constants (plane positions, strides) hoisted out of the walk
//! and the list fused away: [`Walk::next_entry`] returns the next non-empty voxel as it is
//! reached, and the caller stops when it has its answer. Per axis the walk keeps an iterator
//! over the boundary planes still ahead in its direction of travel, so "the next cell leaves
//! the grid" is "no plane left", and the loop's state fits in registers.
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

use gridrt_firmware::dda::GridDesc;
use gridrt_shared::math::gamma;

/// `cell_span` value of a voxel the firmware never lists (empty, or no owner).
pub(crate) const NO_SPAN: u32 = u32::MAX;

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
    /// Boundary planes per axis: `up[a][k]` = plane k for k in 0..=n (the last one is
    /// `max`), and the same reversed, `down[a][i]` = plane n − i.
    up: [Vec<f32>; 3],
    down: [Vec<f32>; 3],
    steps: u32,
}

/// One ray's walk in progress.
#[derive(Debug, Clone)]
pub(crate) struct Walk<'g> {
    /// Boundary planes still ahead on each axis, in the order they are crossed (empty for an
    /// axis the ray does not move along).
    ahead: [core::slice::Iter<'g, f32>; 3],
    o: [f32; 3],
    inv: [f32; 3],
    t_next: [f32; 3],
    /// Voxel id change of a step on each axis.
    dv: [u32; 3],
    voxel: u32,
    t: f32,
    t_end: f32,
    steps_left: u32,
    done: bool,
    /// Some boundary distance may be NaN: take the firmware's literal loop.
    exact: bool,
    cell: [i32; 3],
    step: [i32; 3],
}

impl GridWalk {
    /// The constants of `grid` (computed exactly as the firmware computes them per ray).
    pub(crate) fn new(grid: &GridDesc) -> Self {
        let valid = grid.is_valid();
        let min = grid.min.to_array();
        let max = grid.max.to_array();
        let dims = grid.dims.map(|d| if valid { d as i32 } else { 0 });
        let extent = [0, 1, 2].map(|a| max[a] - min[a]);
        let up = [0, 1, 2].map(|a| {
            let n = dims[a];
            let size = extent[a] / n as f32;
            (0..=n).map(|k| if k >= n { max[a] } else { min[a] + k as f32 * size }).collect::<Vec<f32>>()
        });
        let down = up.clone().map(|mut v| {
            v.reverse();
            v
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
            up,
            down,
            steps: dims.iter().map(|&d| d.max(0) as u32).sum(),
        }
    }

    /// The grid box, if the grid is valid.
    pub(crate) fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        self.valid.then_some((self.min, self.max))
    }

    /// Number of voxels.
    pub(crate) fn voxel_count(&self) -> usize {
        self.dims.iter().map(|&d| d.max(0) as usize).product()
    }

    /// `Aabb::clip` of the grid box (copied: see the module doc), without branches: its
    /// early `t0 > t1` exit changes nothing (t0 only grows and t1 only shrinks, so the last
    /// check sees any crossing), and `if x > t0 { t0 = x }` keeps ignoring a NaN `x`.
    #[inline(always)]
    fn clip(&self, o: &[f32; 3], inv: &[f32; 3], t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for a in 0..3 {
            let t_a = (self.min[a] - o[a]) * inv[a];
            let t_b = (self.max[a] - o[a]) * inv[a];
            let (t_near, t_far) = if t_a > t_b { (t_b, t_a) } else { (t_a, t_b) };
            let t_far = t_far * (1.0 + 2.0 * gamma(3));
            t0 = if t_near > t0 { t_near } else { t0 };
            t1 = if t_far < t1 { t_far } else { t1 };
        }
        if t0 > t1 {
            None
        } else {
            Some((t0, t1))
        }
    }

    /// Boundary plane `k` of axis `a` (`Traversal::plane`; k is in 0..=n).
    #[inline(always)]
    fn plane(&self, a: usize, k: i32) -> f32 {
        self.up[a].get(k.max(0) as usize).copied().unwrap_or(self.max[a])
    }

    /// Starts the walk of the ray `o + t·d` over `[t_min, t_max]` (`Traversal::new`);
    /// `None` when it visits nothing (invalid ray or grid, clip empty or of zero length).
    #[inline(always)]
    pub(crate) fn start_at(&self, o: [f32; 3], d: [f32; 3], t_min: f32, t_max: f32) -> Option<Walk<'_>> {
        // `Ray::is_valid`: finite origin and direction, direction not zero.
        let valid_ray = o.iter().chain(&d).all(|c| c.is_finite()) && d != [0.0; 3];
        if !self.valid || !valid_ray || t_min.is_nan() || t_max.is_nan() {
            return None;
        }
        // `1 / d` is also what the clip computes (±∞ for a zero component).
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let (t0, t1) = self.clip(&o, &inv, t_min, t_max)?;
        if t1.is_nan() || t1 <= t0 || !t0.is_finite() {
            return None;
        }
        // `Ray::at`: o + d·t0.
        let entry = [o[0] + d[0] * t0, o[1] + d[1] * t0, o[2] + d[2] * t0];
        let mut cell = [0i32; 3];
        let mut step = [0i32; 3];
        let mut t_next = [f32::INFINITY; 3];
        let mut ahead = [[].iter(), [].iter(), [].iter()];
        let mut dv = [0u32; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let rel = (entry[a] - self.min[a]) / self.extent[a] * n as f32;
            let c = floor_i32(rel).max(0).min(n - 1);
            cell[a] = c;
            // Planes ahead after the first crossing: c+2..=n going up, c−1..=0 going down
            // (one per step that stays inside the grid).
            if d[a] > 0.0 {
                step[a] = 1;
                t_next[a] = (self.plane(a, c + 1) - o[a]) * inv[a];
                ahead[a] = self.up[a].get((c + 2) as usize..).unwrap_or(&[]).iter();
                dv[a] = self.stride[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                t_next[a] = (self.plane(a, c) - o[a]) * inv[a];
                ahead[a] = self.down[a].get((n - c + 1) as usize..).unwrap_or(&[]).iter();
                dv[a] = self.stride[a].wrapping_neg();
            }
        }
        let voxel = (cell[0] as u32)
            .wrapping_add(self.stride[1].wrapping_mul(cell[1] as u32))
            .wrapping_add(self.stride[2].wrapping_mul(cell[2] as u32));
        // A finite 1/d on every stepped axis keeps every boundary distance free of NaN
        // (finite plane − finite origin, times a finite factor): the fast loop needs that.
        let exact = !(0..3).all(|a| step[a] == 0 || inv[a].is_finite());
        Some(Walk {
            ahead,
            o,
            inv,
            t_next,
            dv,
            voxel,
            t: t0,
            t_end: t1,
            steps_left: self.steps,
            done: false,
            exact,
            cell,
            step,
        })
    }

    /// The next non-empty voxel of the walk (its `cell_span` entry, not [`NO_SPAN`]) and its
    /// exit distance, or `None` when the walk is over.
    #[inline(always)]
    pub(crate) fn next_entry(&self, w: &mut Walk<'_>, cell_span: &[u32]) -> Option<(u32, f32)> {
        if w.done {
            None
        } else if w.exact {
            self.next_exact(w, cell_span)
        } else {
            next_finite(w, cell_span)
        }
    }

    /// The firmware's loop as written (`Traversal::next`, NaN boundary distances included).
    #[inline(never)]
    fn next_exact(&self, w: &mut Walk<'_>, cell_span: &[u32]) -> Option<(u32, f32)> {
        while w.steps_left > 0 {
            w.steps_left -= 1;
            let [tx, ty, tz] = w.t_next;
            // Lowest axis wins ties.
            let axis = if tx <= ty && tx <= tz {
                0
            } else if ty <= tz {
                1
            } else {
                2
            };
            let t_cross = w.t_next[axis];
            // min/max ignore NaN, so a NaN boundary ends the voxel at t_end.
            let t_exit = t_cross.min(w.t_end).max(w.t);
            let span = cell_span.get(w.voxel as usize).copied().unwrap_or(NO_SPAN);
            let c = w.cell[axis] + w.step[axis];
            if t_cross.is_nan() || t_cross >= w.t_end || c < 0 || c >= self.dims[axis] {
                w.done = true;
            } else {
                w.cell[axis] = c;
                w.voxel = w.voxel.wrapping_add(w.dv[axis]);
                // `update_next`: an axis that does not move keeps its distance.
                if w.step[axis] != 0 {
                    let k = if w.step[axis] > 0 { c + 1 } else { c };
                    w.t_next[axis] = (self.plane(axis, k) - w.o[axis]) * w.inv[axis];
                }
                w.t = t_exit;
            }
            if span != NO_SPAN {
                return Some((span, t_exit));
            }
            if w.done {
                return None;
            }
        }
        w.done = true;
        None
    }
}

/// `x.floor() as i32` (saturating, NaN → 0) without a library call: the truncation is
/// exact, and one less where it rounded up (|x| < 2^31 has no fraction to lose beyond that).
#[inline(always)]
fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// The walk with the three axes in locals. Valid when no boundary distance can be NaN: then
/// `Traversal::next`'s `t_cross.is_nan() || t_cross ≥ t_end` is `!(t_cross < t_end)`, and an
/// axis that does not move keeps `t_next = +∞` and is never stepped (an infinite `t_cross`
/// always ends the walk). The `nx + ny + nz` bound cannot bind (a step moves one cell along
/// an axis in a fixed direction, so a walk is at most `Σ(n − 1) + 1` voxels); it is kept.
#[inline(never)]
fn next_finite(w: &mut Walk<'_>, cell_span: &[u32]) -> Option<(u32, f32)> {
    let [mut ax, mut ay, mut az] = w.ahead.clone();
    let [mut tx, mut ty, mut tz] = w.t_next;
    let [ox, oy, oz] = w.o;
    let [ix, iy, iz] = w.inv;
    let [dvx, dvy, dvz] = w.dv;
    let (mut voxel, mut t, t_end, mut steps_left) = (w.voxel, w.t, w.t_end, w.steps_left);
    let mut found = None;
    let mut done = false;
    while steps_left > 0 {
        steps_left -= 1;
        // Lowest axis wins ties.
        let (axis, t_cross) = if tx <= ty && tx <= tz {
            (0, tx)
        } else if ty <= tz {
            (1, ty)
        } else {
            (2, tz)
        };
        let t_exit = t_cross.min(t_end).max(t);
        let span = cell_span.get(voxel as usize).copied().unwrap_or(NO_SPAN);
        let plane = if t_cross < t_end {
            match axis {
                0 => ax.next(),
                1 => ay.next(),
                _ => az.next(),
            }
        } else {
            None
        };
        match (axis, plane) {
            (_, None) => done = true,
            (0, Some(&p)) => {
                tx = (p - ox) * ix;
                voxel = voxel.wrapping_add(dvx);
            }
            (1, Some(&p)) => {
                ty = (p - oy) * iy;
                voxel = voxel.wrapping_add(dvy);
            }
            (_, Some(&p)) => {
                tz = (p - oz) * iz;
                voxel = voxel.wrapping_add(dvz);
            }
        }
        t = t_exit;
        if span != NO_SPAN {
            found = Some((span, t_exit));
            break;
        }
        if done {
            break;
        }
    }
    w.ahead = [ax, ay, az];
    w.t_next = [tx, ty, tz];
    w.voxel = voxel;
    w.t = t;
    w.steps_left = steps_left;
    w.done = done || steps_left == 0;
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_firmware::dda::Traversal;
    use gridrt_shared::math::Ray;
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The firmware's walk restricted to occupied voxels: (voxel id, t_exit) in order.
    fn firmware(grid: &GridDesc, occupied: &[u32], ray: &Ray, t_min: f32, t_max: f32) -> Vec<(u32, u32)> {
        Traversal::new(grid, ray, t_min, t_max)
            .filter(|v| occupied.get(v.voxel as usize).is_some_and(|&s| s != NO_SPAN))
            .map(|v| (v.voxel, v.t_exit.to_bits()))
            .collect()
    }

    fn ours(walk: &GridWalk, occupied: &[u32], ray: &Ray, t_min: f32, t_max: f32) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if let Some(mut w) = walk.start_at(ray.origin.to_array(), ray.dir.to_array(), t_min, t_max) {
            while let Some((span, t_exit)) = walk.next_entry(&mut w, occupied) {
                out.push((span, t_exit.to_bits()));
            }
        }
        out
    }

    /// Same voxels, same exit distance bits, in the same order as `Traversal`: random grids and
    /// rays, and rays built to tie (through grid edges and corners of a grid with exact
    /// planes, diagonal directions), axis-aligned, lying in grid planes, with tiny or zero
    /// direction components (the exact loop), bounded ranges.
    #[test]
    fn floor_i32_is_floor_then_saturating_cast() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xF1);
        let special = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            8388607.5,
            -8388607.5,
            16777217.0,
            2147483520.0,
            2147483648.0,
            -2147483648.0,
            -2147483904.0,
            3e9,
            -3e9,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::from_bits(1),
            -f32::from_bits(1),
        ];
        for x in special.into_iter().chain((0..100_000).map(|_| f32::from_bits(rng.gen()))) {
            assert_eq!(floor_i32(x), x.floor() as i32, "{x:e}");
        }
    }

    #[test]
    fn walk_equals_firmware_traversal_voxel_for_voxel() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xDDA0);
        let mut ties = 0;
        for case in 0..3000 {
            let exact_planes = case % 2 == 0;
            let grid = if exact_planes {
                let n = rng.gen_range(1..=16);
                GridDesc { min: Vec3::ZERO, max: Vec3::splat(n as f32), dims: [n, n, n] }
            } else {
                let min = Vec3::new(rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0));
                let ext = Vec3::new(rng.gen_range(0.5..6.0), rng.gen_range(0.5..6.0), rng.gen_range(0.5..6.0));
                GridDesc {
                    min,
                    max: min + ext,
                    dims: [rng.gen_range(1..40), rng.gen_range(1..40), rng.gen_range(1..40)],
                }
            };
            let walk = GridWalk::new(&grid);
            // Occupancy: the span index is the voxel id itself for occupied voxels.
            let density: f64 = rng.gen_range(0.05..0.9);
            let occupied: Vec<u32> =
                (0..grid.voxel_count()).map(|v| if rng.gen_bool(density) { v } else { NO_SPAN }).collect();
            let ext = grid.max - grid.min;
            for _ in 0..20 {
                let ray = if exact_planes && rng.gen_bool(0.6) {
                    // Lattice origin outside or inside, direction with equal magnitudes on
                    // two or three axes: crossings tie exactly.
                    let n = grid.dims[0] as i32;
                    let o = Vec3::new(
                        rng.gen_range(-3..n + 3) as f32,
                        rng.gen_range(-3..n + 3) as f32,
                        rng.gen_range(-3..n + 3) as f32,
                    );
                    let s = |rng: &mut ChaCha8Rng| if rng.gen() { 1.0 } else { -1.0 };
                    let mut d = Vec3::new(s(&mut rng), s(&mut rng), s(&mut rng));
                    if rng.gen_bool(0.3) {
                        d[rng.gen_range(0..3)] = rng.gen_range(-0.5..0.5);
                    }
                    ties += 1;
                    Ray { origin: o, dir: d }
                } else {
                    let o = grid.min - ext * 0.5 + ext * 2.0 * Vec3::new(rng.gen(), rng.gen(), rng.gen());
                    let target = grid.min + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen());
                    let mut d = target - o;
                    match rng.gen_range(0..6) {
                        0 => d[rng.gen_range(0..3)] = 0.0,
                        1 => d[rng.gen_range(0..3)] = f32::from_bits(rng.gen_range(1..4000)),
                        2 => {
                            let a = rng.gen_range(0..3);
                            d = Vec3::ZERO;
                            d[a] = if rng.gen() { 1.0 } else { -1.0 };
                        }
                        _ => {}
                    }
                    Ray { origin: o, dir: d }
                };
                let (t_min, t_max) = if rng.gen_bool(0.3) {
                    (rng.gen_range(0.0..0.5), rng.gen_range(0.5..2.0))
                } else {
                    (0.0, f32::INFINITY)
                };
                assert_eq!(
                    ours(&walk, &occupied, &ray, t_min, t_max),
                    firmware(&grid, &occupied, &ray, t_min, t_max),
                    "{grid:?} {ray:?} [{t_min}, {t_max}]"
                );
            }
        }
        assert!(ties > 10_000, "{ties}");
    }
}
