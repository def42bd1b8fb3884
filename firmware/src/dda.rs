//! 3D-DDA uniform-grid traversal and the traversal list of non-empty voxels.
//!
//! Source: J. Amanatides and A. Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing",
//! Eurographics 1987 — the algorithm GridRT's MicroBlaze runs (seed 004 §2.3, via Suffern).
//! Differences from the paper, for robustness in f32:
//! - the ray is first clipped to the grid box with the robust slab test
//!   ([`Aabb::clip`]); an empty or zero-length clip yields nothing (and costs no FSL words);
//! - the start cell is `floor` of the entry point, clamped into the grid, so entry points that
//!   rounding puts a hair outside the box still start in a boundary cell;
//! - the next-boundary distances are recomputed from the plane index at each step instead of
//!   accumulating `t_delta`, so the error does not grow with the path length;
//! - zero direction components get an infinite boundary distance (never stepped) instead of
//!   the `0 · ∞ = NaN` the textbook formula gives for origins on a plane;
//! - the walk is hard-bounded to `nx + ny + nz` voxels whatever the floats do.
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

use crate::dda_fixed::{DdaOverflow, FixedTraversal};
use crate::fixed::RayFormat;
use gridrt_shared::fsl::ListEntry;
use gridrt_shared::math::{Aabb, Ray, Vec3};
use gridrt_shared::scene::EMPTY_VOXEL;

/// Largest grid resolution per axis the firmware accepts (scenes with more are rejected at
/// load). Keeps voxel ids below 2^24 (255³ < 2^24) and bounds the list length.
pub const MAX_GRID_DIM: u32 = 255;

/// Capacity of a traversal list: a ray visits at most `nx + ny + nz − 2` voxels.
pub const MAX_LIST: usize = 3 * MAX_GRID_DIM as usize;

/// A traversal list ready for the FSL request.
pub type TraversalList = heapless::Vec<ListEntry, MAX_LIST>;

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

    /// Linear voxel id `ix + nx·(iy + ny·iz)`.
    #[inline]
    pub fn voxel_id(&self, cell: [u32; 3]) -> u32 {
        cell[0] + self.dims[0] * (cell[1] + self.dims[1] * cell[2])
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

/// Iterator over the voxels a ray crosses, in order (Amanatides & Woo 1987).
#[derive(Debug, Clone)]
pub struct Traversal {
    dims: [i32; 3],
    cell: [i32; 3],
    step: [i32; 3],
    origin: [f32; 3],
    inv_dir: [f32; 3],
    grid_min: [f32; 3],
    grid_max: [f32; 3],
    cell_size: [f32; 3],
    t_next: [f32; 3],
    t: f32,
    t_end: f32,
    steps_left: u32,
    nx: u32,
    ny: u32,
}

impl Traversal {
    /// Starts a walk of `ray` restricted to `[t_min, t_max]`. An invalid ray or grid, or a
    /// clip of zero length, gives an empty walk.
    pub fn new(grid: &GridDesc, ray: &Ray, t_min: f32, t_max: f32) -> Self {
        let mut tr = Self {
            dims: [0; 3],
            cell: [0; 3],
            step: [0; 3],
            origin: ray.origin.to_array(),
            inv_dir: [0.0; 3],
            grid_min: grid.min.to_array(),
            grid_max: grid.max.to_array(),
            cell_size: [0.0; 3],
            t_next: [f32::INFINITY; 3],
            t: 0.0,
            t_end: 0.0,
            steps_left: 0,
            nx: grid.dims[0],
            ny: grid.dims[1],
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
            tr.dims[a] = n;
            let extent = grid.max[a] - grid.min[a];
            let size = extent / n as f32;
            tr.cell_size[a] = size;
            // floor + clamp: rounding may put the entry point just outside the box.
            let rel = (entry[a] - grid.min[a]) / extent * n as f32;
            // max/min, not clamp: n ≥ 1 (is_valid), and clamp's min ≤ max assert would link
            // a formatted panic into the soft-core image.
            let c = (libm::floorf(rel) as i32).max(0).min(n - 1);
            tr.cell[a] = c;
            let d = ray.dir[a];
            if d > 0.0 {
                tr.step[a] = 1;
                tr.inv_dir[a] = 1.0 / d;
            } else if d < 0.0 {
                tr.step[a] = -1;
                tr.inv_dir[a] = 1.0 / d;
            }
            // d == 0: step 0, t_next stays +∞, the axis is never stepped.
            tr.update_next(a);
        }
        tr.t = t0;
        tr.t_end = t1;
        tr.steps_left = grid.dims.iter().sum();
        tr
    }

    /// Position of boundary plane `k` (0..=n) on axis `a`; the last plane is exactly `max`.
    #[inline]
    fn plane(&self, a: usize, k: i32) -> f32 {
        if k >= self.dims[a] {
            self.grid_max[a]
        } else {
            self.grid_min[a] + k as f32 * self.cell_size[a]
        }
    }

    /// Recomputes the distance to the next boundary on axis `a` from the plane index.
    #[inline]
    fn update_next(&mut self, a: usize) {
        let s = self.step[a];
        if s == 0 {
            return;
        }
        let k = if s > 0 { self.cell[a] + 1 } else { self.cell[a] };
        self.t_next[a] = (self.plane(a, k) - self.origin[a]) * self.inv_dir[a];
    }
}

impl Iterator for Traversal {
    type Item = VoxelStep;

    #[inline]
    fn next(&mut self) -> Option<VoxelStep> {
        if self.steps_left == 0 {
            return None;
        }
        self.steps_left -= 1;
        let [tx, ty, tz] = self.t_next;
        // Lowest axis wins ties (documented in the module header).
        let axis = if tx <= ty && tx <= tz {
            0
        } else if ty <= tz {
            1
        } else {
            2
        };
        let t_cross = self.t_next[axis];
        // min/max ignore NaN, so a NaN boundary ends the voxel at t_end.
        let t_exit = t_cross.min(self.t_end).max(self.t);
        let cell = [self.cell[0] as u32, self.cell[1] as u32, self.cell[2] as u32];
        let item =
            VoxelStep { voxel: cell[0] + self.nx * (cell[1] + self.ny * cell[2]), cell, t_enter: self.t, t_exit };
        if t_cross.is_nan() || t_cross >= self.t_end {
            self.steps_left = 0;
            return Some(item);
        }
        let c = self.cell[axis] + self.step[axis];
        if c < 0 || c >= self.dims[axis] {
            self.steps_left = 0;
            return Some(item);
        }
        self.cell[axis] = c;
        self.update_next(axis);
        self.t = t_exit;
        Some(item)
    }
}

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
    for v in walk {
        walked += 1;
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

#[cfg(test)]
mod tests {
    //! Property rule (pinned by `traversal_visits_exactly_the_voxels_the_ray_crosses`), against
    //! an exact f64 per-voxel slab test of the same f32 ray: with δ = 2^-20 · S, S = the largest
    //! coordinate magnitude of the origin and grid corners (≈ 8 f32 ulps of S),
    //! - a voxel MUST be visited when the ray crosses its δ-shrunk box with positive length
    //!   inside `[t_min, t_max]`, and then its t_enter/t_exit lie between the crossings of the
    //!   δ-grown and δ-shrunk boxes (the boundary point is right to within δ);
    //! - a voxel MUST NOT be visited when the ray misses its δ-grown closed box;
    //! - voxels in between are touched only within δ of their boundary — at a corner, along an
    //!   edge, or on a face the ray lies in — and may go either way. (Measured: the rule still
    //!   holds at δ = 2^-23 · S; it breaks at 2^-24 · S, half an ulp.)
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The walk of the DDA in `fmt` (the fixed-point one must represent every test ray).
    fn trav(fmt: RayFormat, g: &GridDesc, r: &Ray, tmin: f32, tmax: f32) -> Vec<VoxelStep> {
        match fmt {
            RayFormat::F32 => Traversal::new(g, r, tmin, tmax).collect(),
            RayFormat::Fixed => {
                FixedTraversal::new(g, r, tmin, tmax).unwrap_or_else(|e| panic!("{e:?}: {g:?} {r:?}")).collect()
            }
        }
    }
    use rand_chacha::ChaCha8Rng;

    type V64 = [f64; 3];

    fn v64(v: Vec3) -> V64 {
        [v.x as f64, v.y as f64, v.z as f64]
    }

    /// Closed slab test in f64 against `[lo, hi]`, returning the signed interval length
    /// `t1 − t0` of the ray restricted to `[tmin, tmax]` (negative or `None` = miss).
    fn slab64(o: V64, d: V64, lo: V64, hi: V64, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (tmin, tmax);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < lo[a] || o[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (mut n, mut f) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            if n > f {
                core::mem::swap(&mut n, &mut f);
            }
            t0 = t0.max(n);
            t1 = t1.min(f);
        }
        Some((t0, t1))
    }

    struct Case {
        grid: GridDesc,
        ray: Ray,
        tmin: f32,
        tmax: f32,
        /// No origin coordinate forced onto a plane and no zero direction component.
        general: bool,
    }

    fn cell_box(g: &GridDesc, c: [u32; 3]) -> (V64, V64) {
        let (mn, mx) = (v64(g.min), v64(g.max));
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for a in 0..3 {
            let n = g.dims[a] as f64;
            lo[a] = mn[a] + (mx[a] - mn[a]) * c[a] as f64 / n;
            hi[a] = mn[a] + (mx[a] - mn[a]) * (c[a] + 1) as f64 / n;
        }
        (lo, hi)
    }

    fn delta(case: &Case) -> f64 {
        let g = &case.grid;
        let s = [g.min.abs().max_element(), g.max.abs().max_element(), case.ray.origin.abs().max_element()]
            .into_iter()
            .fold(0.0f32, f32::max) as f64;
        s * (2.0f64).powi(-20)
    }

    fn random_grid(rng: &mut ChaCha8Rng, max_dim: u32) -> GridDesc {
        let min = Vec3::new(rng.gen_range(-8.0..8.0), rng.gen_range(-8.0..8.0), rng.gen_range(-8.0..8.0));
        let ext = Vec3::new(rng.gen_range(0.2..6.0), rng.gen_range(0.2..6.0), rng.gen_range(0.2..6.0));
        let dims = [rng.gen_range(1..=max_dim), rng.gen_range(1..=max_dim), rng.gen_range(1..=max_dim)];
        GridDesc { min, max: min + ext, dims }
    }

    /// A grid plane coordinate on axis `a` (as the f32 the DDA computes, so "on the plane" is
    /// as exact as f32 allows).
    fn plane_coord(rng: &mut ChaCha8Rng, g: &GridDesc, a: usize) -> f32 {
        let k = rng.gen_range(0..=g.dims[a]);
        if k == g.dims[a] {
            g.max[a]
        } else {
            g.min[a] + k as f32 * ((g.max[a] - g.min[a]) / g.dims[a] as f32)
        }
    }

    /// Random rays of every awkward kind: general, axis-aligned (1 or 2 zero components),
    /// grazing (lying in a grid plane), origins on faces, edges and corners, inside and
    /// outside the box, limited t ranges (shadow-ray style).
    fn random_case(rng: &mut ChaCha8Rng, max_dim: u32) -> Case {
        let grid = random_grid(rng, max_dim);
        let ext = grid.max - grid.min;
        let inside = |rng: &mut ChaCha8Rng| {
            Vec3::new(
                rng.gen_range(grid.min.x..grid.max.x),
                rng.gen_range(grid.min.y..grid.max.y),
                rng.gen_range(grid.min.z..grid.max.z),
            )
        };
        let mut origin = match rng.gen_range(0..3) {
            0 => inside(rng),
            _ => grid.min - ext + Vec3::new(rng.gen::<f32>(), rng.gen::<f32>(), rng.gen::<f32>()) * ext * 3.0,
        };
        let mut dir = match rng.gen_range(0..4) {
            0 => Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)),
            _ => inside(rng) - origin,
        };
        // Put 0..3 origin coordinates exactly on grid planes (faces, edges, corners).
        let on_planes = if rng.gen_bool(0.5) { 0 } else { rng.gen_range(1..4) };
        for _ in 0..on_planes {
            let a = rng.gen_range(0..3);
            origin[a] = plane_coord(rng, &grid, a);
        }
        // Zero 0..2 direction components: axis-aligned and grazing rays.
        let kind = rng.gen_range(0..6);
        match kind {
            0 => dir[rng.gen_range(0..3)] = 0.0,
            1 => {
                let keep = rng.gen_range(0..3);
                for a in 0..3 {
                    if a != keep {
                        dir[a] = 0.0;
                    }
                }
            }
            2 => {
                // Grazing: lie in a grid plane.
                let a = rng.gen_range(0..3);
                dir[a] = 0.0;
                origin[a] = plane_coord(rng, &grid, a);
            }
            _ => {}
        }
        if dir == Vec3::ZERO {
            dir = Vec3::X;
        }
        dir *= rng.gen_range(0.01..10.0f32);
        let (tmin, tmax) = if rng.gen_bool(0.2) { (0.0, rng.gen_range(0.0..3.0f32)) } else { (0.0, f32::INFINITY) };
        let general = on_planes == 0 && kind > 2 && dir.x != 0.0 && dir.y != 0.0 && dir.z != 0.0;
        Case { grid, ray: Ray { origin, dir }, tmin, tmax, general }
    }

    /// Checks the order invariants and returns the visited voxels.
    fn walk(case: &Case, fmt: RayFormat) -> Vec<VoxelStep> {
        let g = &case.grid;
        let steps: Vec<VoxelStep> = trav(fmt, g, &case.ray, case.tmin, case.tmax);
        let bound = (g.dims[0] + g.dims[1] + g.dims[2]) as usize;
        assert!(steps.len() <= bound, "{} steps > {bound}", steps.len());
        for s in &steps {
            assert!(s.t_exit >= s.t_enter, "{s:?}");
            assert!(s.t_enter >= case.tmin && s.t_exit <= case.tmax, "{s:?}");
            assert!((0..3).all(|a| s.cell[a] < g.dims[a]));
            assert_eq!(s.voxel, g.voxel_id(s.cell));
        }
        for w in steps.windows(2) {
            assert_eq!(w[0].t_exit, w[1].t_enter);
            let moved: u32 = (0..3).map(|a| w[0].cell[a].abs_diff(w[1].cell[a])).sum();
            assert_eq!(moved, 1, "consecutive voxels must share a face: {w:?}");
        }
        steps
    }

    /// Compares a walk with the per-voxel f64 slab test (rule in the module comment).
    /// Returns the number of voxels that went either way.
    fn check_exhaustive(case: &Case, fmt: RayFormat) -> u64 {
        let mut ambiguous = 0;
        let g = &case.grid;
        let steps = walk(case, fmt);
        let dl = delta(case);
        let (o, d) = (v64(case.ray.origin), v64(case.ray.dir));
        let (tmin, tmax) = (case.tmin as f64, case.tmax as f64);
        for iz in 0..g.dims[2] {
            for iy in 0..g.dims[1] {
                for ix in 0..g.dims[0] {
                    let c = [ix, iy, iz];
                    let (lo, hi) = cell_box(g, c);
                    let shrunk = slab64(o, d, lo.map(|v| v + dl), hi.map(|v| v - dl), tmin, tmax);
                    let grown = slab64(o, d, lo.map(|v| v - dl), hi.map(|v| v + dl), tmin, tmax);
                    let must = matches!(shrunk, Some((t0, t1)) if t1 > t0);
                    let may = matches!(grown, Some((t0, t1)) if t1 >= t0);
                    let visited = steps.iter().find(|s| s.cell == c);
                    if must {
                        let s = visited.unwrap_or_else(|| {
                            panic!("missed voxel {c:?} of {:?} ray {:?} t[{tmin},{tmax}] steps {steps:?}", g, case.ray)
                        });
                        // Its entry and exit lie within δ of the voxel's boundary: between the
                        // crossings of the grown and the shrunk box (plus the relative widening
                        // of the clip's far end).
                        let (s0, s1) = shrunk.unwrap_or_default();
                        let (g0, g1) = grown.unwrap_or_default();
                        let slack = 1e-6 * g1.abs().max(g0.abs()).min(1e30);
                        let ok_enter = s.t_enter as f64 >= g0 - slack && s.t_enter as f64 <= s0 + slack;
                        let ok_exit = s.t_exit as f64 >= s1 - slack && s.t_exit as f64 <= g1 + slack;
                        assert!(
                            ok_enter && ok_exit,
                            "{s:?} vs shrunk ({s0}, {s1}) grown ({g0}, {g1}) ({g:?}, {:?})",
                            case.ray
                        );
                    } else if !may {
                        assert!(
                            visited.is_none(),
                            "visited voxel {c:?} the ray misses: {g:?} {:?} t[{tmin},{tmax}] {steps:?}",
                            case.ray
                        );
                    } else if visited.is_some() != must {
                        ambiguous += 1;
                    }
                }
            }
        }
        ambiguous
    }

    #[test]
    /// 10⁶ seeded random rays per number format (f32 and the fixed-point DDA of feature
    /// `fixed-raygen`), each checked voxel by voxel against the exact f64 slab test.
    fn traversal_visits_exactly_the_voxels_the_ray_crosses() {
        for fmt in RayFormat::ALL {
            let mut rng = ChaCha8Rng::seed_from_u64(0xDDA_0001);
            let (mut general, mut general_ambiguous) = (0u64, 0u64);
            for _ in 0..1_000_000 {
                let case = random_case(&mut rng, 7);
                let ambiguous = check_exhaustive(&case, fmt);
                if case.general {
                    general += 1;
                    general_ambiguous += (ambiguous > 0) as u64;
                }
            }
            // The δ band must stay thin: general-position rays almost never fall into it
            // (degenerate rays lying in planes or through edges are ambiguous by design).
            assert!(general > 200_000, "{fmt:?}: {general}");
            assert!(
                general_ambiguous * 1000 < general,
                "{fmt:?}: {general_ambiguous} of {general} general rays ambiguous"
            );
        }
    }

    /// Large grids (up to 255³) cannot be checked voxel by voxel: check instead that every
    /// sample point of the segment that lies δ inside a voxel is in a visited voxel, and that
    /// every visited voxel is touched (δ-grown) by the ray.
    #[test]
    fn traversal_on_large_grids_covers_the_segment_and_stays_on_it() {
        for fmt in RayFormat::ALL {
            let mut rng = ChaCha8Rng::seed_from_u64(0xDDA_0002);
            for _ in 0..3_000 {
                let case = random_case(&mut rng, MAX_GRID_DIM);
                let g = &case.grid;
                let steps = walk(&case, fmt);
                let dl = delta(&case);
                let (o, d) = (v64(case.ray.origin), v64(case.ray.dir));
                let (tmin, tmax) = (case.tmin as f64, case.tmax as f64);
                for s in &steps {
                    let (lo, hi) = cell_box(g, s.cell);
                    let grown = slab64(o, d, lo.map(|v| v - dl), hi.map(|v| v + dl), tmin, tmax);
                    assert!(matches!(grown, Some((t0, t1)) if t1 >= t0), "visited {s:?} off the ray");
                }
                let Some((t0, t1)) = slab64(o, d, v64(g.min), v64(g.max), tmin, tmax) else { continue };
                if t1 <= t0 {
                    continue;
                }
                let samples = 4 * (g.dims[0] + g.dims[1] + g.dims[2]);
                for k in 0..samples {
                    let t = t0 + (t1 - t0) * (k as f64 + 0.5) / samples as f64;
                    let p: V64 = core::array::from_fn(|a| o[a] + t * d[a]);
                    let mut c = [0u32; 3];
                    let mut clear = true;
                    for a in 0..3 {
                        let (mn, mx) = (g.min[a] as f64, g.max[a] as f64);
                        let n = g.dims[a] as f64;
                        let rel = (p[a] - mn) / (mx - mn) * n;
                        let i = rel.floor().clamp(0.0, n - 1.0);
                        c[a] = i as u32;
                        let (lo, hi) = (mn + (mx - mn) * i / n, mn + (mx - mn) * (i + 1.0) / n);
                        clear &= p[a] > lo + dl && p[a] < hi - dl;
                    }
                    if clear {
                        assert!(
                            steps.iter().any(|s| s.cell == c),
                            "sample {p:?} in {c:?} not visited: {g:?} {:?}",
                            case.ray
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn ray_missing_the_box_or_touching_it_visits_nothing() {
        for fmt in RayFormat::ALL {
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [4, 4, 4] };
            let miss = Ray { origin: Vec3::new(2.0, 0.5, -1.0), dir: Vec3::Z };
            assert_eq!(trav(fmt, &g, &miss, 0.0, f32::INFINITY).len(), 0);
            // Pointing away.
            let away = Ray { origin: Vec3::new(0.5, 0.5, -1.0), dir: -Vec3::Z };
            assert_eq!(trav(fmt, &g, &away, 0.0, f32::INFINITY).len(), 0);
            // On the z = 1 face, leaving the box.
            let leaving = Ray { origin: Vec3::new(0.5, 0.5, 1.0), dir: Vec3::Z };
            assert_eq!(trav(fmt, &g, &leaving, 0.0, f32::INFINITY).len(), 0);
            // Stops before reaching the box.
            let short = Ray { origin: Vec3::new(0.5, 0.5, -1.0), dir: Vec3::Z };
            assert_eq!(trav(fmt, &g, &short, 0.0, 0.5).len(), 0);
            // Invalid rays and grids.
            let zero = Ray { origin: Vec3::splat(0.5), dir: Vec3::ZERO };
            assert_eq!(trav(fmt, &g, &zero, 0.0, f32::INFINITY).len(), 0);
            let nan = Ray { origin: Vec3::splat(f32::NAN), dir: Vec3::Z };
            assert_eq!(trav(fmt, &g, &nan, 0.0, f32::INFINITY).len(), 0);
            let bad = GridDesc { dims: [0, 4, 4], ..g };
            assert_eq!(trav(fmt, &bad, &short, 0.0, f32::INFINITY).len(), 0);
            let big = GridDesc { dims: [256, 1, 1], ..g };
            assert_eq!(trav(fmt, &big, &short, 0.0, f32::INFINITY).len(), 0);
        }
    }

    #[test]
    fn axis_aligned_ray_through_centres_visits_a_straight_row() {
        for fmt in RayFormat::ALL {
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::new(4.0, 2.0, 2.0), dims: [4, 2, 2] };
            let r = Ray { origin: Vec3::new(-1.0, 1.5, 0.5), dir: Vec3::X };
            let s: Vec<_> = trav(fmt, &g, &r, 0.0, f32::INFINITY);
            let cells: Vec<_> = s.iter().map(|s| s.cell).collect();
            assert_eq!(cells, [[0, 1, 0], [1, 1, 0], [2, 1, 0], [3, 1, 0]]);
            let ids: Vec<_> = s.iter().map(|s| s.voxel).collect();
            assert_eq!(ids, [4, 5, 6, 7]);
            let t: Vec<_> = s.iter().map(|s| (s.t_enter, s.t_exit)).collect();
            assert_eq!(t[0], (1.0, 2.0));
            assert_eq!(t[3].0, 4.0);
            assert!(t[3].1 >= 5.0 && t[3].1 < 5.0 + 1e-5);
            // Reverse direction walks it backwards.
            let back = Ray { origin: Vec3::new(5.0, 1.5, 0.5), dir: -Vec3::X };
            let cells: Vec<_> = trav(fmt, &g, &back, 0.0, f32::INFINITY).iter().map(|s| s.voxel).collect();
            assert_eq!(cells, [7, 6, 5, 4]);
        }
    }

    #[test]
    fn ray_in_a_grid_plane_takes_the_cell_above_the_plane() {
        for fmt in RayFormat::ALL {
            // y = 1 is the plane between iy = 0 and iy = 1; floor puts the ray in iy = 1.
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::new(2.0, 2.0, 2.0), dims: [2, 2, 2] };
            let r = Ray { origin: Vec3::new(-1.0, 1.0, 0.5), dir: Vec3::X };
            let cells: Vec<_> = trav(fmt, &g, &r, 0.0, f32::INFINITY).iter().map(|s| s.cell).collect();
            assert_eq!(cells, [[0, 1, 0], [1, 1, 0]]);
            // On the top face (y = max) the clamped cell is the last one.
            let top = Ray { origin: Vec3::new(-1.0, 2.0, 0.5), dir: Vec3::X };
            let cells: Vec<_> = trav(fmt, &g, &top, 0.0, f32::INFINITY).iter().map(|s| s.cell).collect();
            assert_eq!(cells, [[0, 1, 0], [1, 1, 0]]);
        }
    }

    #[test]
    fn diagonal_through_corners_steps_lowest_axis_first() {
        for fmt in RayFormat::ALL {
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::new(2.0, 2.0, 1.0), dims: [2, 2, 1] };
            let r = Ray { origin: Vec3::new(0.0, 0.0, 0.5), dir: Vec3::new(1.0, 1.0, 0.0) };
            let s: Vec<_> = trav(fmt, &g, &r, 0.0, f32::INFINITY);
            let cells: Vec<_> = s.iter().map(|s| s.cell).collect();
            assert_eq!(cells, [[0, 0, 0], [1, 0, 0], [1, 1, 0]]);
            // The corner voxel in between is touched in one point only.
            assert_eq!(s[1].t_enter, s[1].t_exit);
        }
    }

    #[test]
    fn origin_inside_starts_in_its_own_voxel_at_t_min() {
        for fmt in RayFormat::ALL {
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::splat(3.0), dims: [3, 3, 3] };
            let r = Ray { origin: Vec3::new(1.5, 1.5, 1.5), dir: Vec3::new(0.0, 0.0, -2.0) };
            let s: Vec<_> = trav(fmt, &g, &r, 0.0, f32::INFINITY);
            assert_eq!(s.iter().map(|s| s.cell).collect::<Vec<_>>(), [[1, 1, 1], [1, 1, 0]]);
            assert_eq!((s[0].t_enter, s[0].t_exit), (0.0, 0.25));
            assert!(s[1].t_exit >= 0.75);
        }
    }

    #[test]
    fn walk_is_bounded_by_sum_of_dims_on_a_max_size_grid() {
        for fmt in RayFormat::ALL {
            let g = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [MAX_GRID_DIM; 3] };
            let r = Ray { origin: Vec3::new(-0.1, -0.2, -0.3), dir: Vec3::new(1.0, 1.01, 1.02) };
            let n = trav(fmt, &g, &r, 0.0, f32::INFINITY).len();
            assert!(n <= 3 * MAX_GRID_DIM as usize - 2 && n > 2 * MAX_GRID_DIM as usize, "{n}");
        }
    }

    #[test]
    fn build_list_keeps_only_non_empty_voxels_with_their_pe_and_exit() {
        let g = GridDesc { min: Vec3::ZERO, max: Vec3::new(4.0, 1.0, 1.0), dims: [4, 1, 1] };
        let map = [0u8, EMPTY_VOXEL, 3, EMPTY_VOXEL];
        let r = Ray { origin: Vec3::new(-1.0, 0.5, 0.5), dir: Vec3::X };
        let mut list = TraversalList::new();
        assert_eq!(build_list(&g, &map, &r, 0.0, f32::INFINITY, &mut list), 4);
        assert_eq!(list.len(), 2);
        assert_eq!((list[0].voxel, list[0].pe, list[0].t_exit), (0, 0, 2.0));
        assert_eq!((list[1].voxel, list[1].pe, list[1].t_exit), (2, 3, 4.0));
        // A map shorter than the grid: missing voxels are empty, not a panic.
        assert_eq!(build_list(&g, &map[..1], &r, 0.0, f32::INFINITY, &mut list), 4);
        assert_eq!(list.len(), 1);
        // Missing the box: nothing.
        let miss = Ray { origin: Vec3::new(-1.0, 5.0, 0.5), dir: Vec3::X };
        assert_eq!(build_list(&g, &map, &miss, 0.0, f32::INFINITY, &mut list), 0);
        assert!(list.is_empty());
    }
}
