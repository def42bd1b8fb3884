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
use crate::fixed::RayFormat;
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::EMPTY_VOXEL;
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

/// `pe` over grid `g` with its occupancy-ahead table ([`fill_ahead`]) in `ahead`.
fn with_ahead<'a>(g: &GridDesc, pe: &'a [u8], ahead: &'a mut Vec<u8>) -> VoxelMap<'a> {
    ahead.clear();
    ahead.resize(g.voxel_count() as usize, 0);
    assert!(fill_ahead(g.dims, pe, ahead));
    VoxelMap { pe, ahead }
}

/// The entries of a walk written in parts of `parts[0]`, `parts[1]`, … entries (then
/// [`MAX_LIST`]), `cap` in all: `start` writes the first part, [`WalkGrid::resume_entries`]
/// each next one. A resumed walk always writes an entry where it has room (it stopped at a
/// non-empty voxel).
fn in_parts(
    walk: &WalkGrid,
    table: &OriginPlanes,
    map: VoxelMap<'_>,
    parts: &[usize],
    cap: usize,
    start: impl FnOnce(&mut [u32], &mut Option<Resume>) -> usize,
) -> Vec<[u32; 2]> {
    let mut words = vec![0u32; 2 * MAX_LIST];
    let mut resume = None;
    let first = parts[0].min(cap);
    let n = start(&mut words[..2 * first], &mut resume);
    let mut got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], c[1]]).collect();
    for i in 1.. {
        if resume.is_none() {
            break;
        }
        let left = cap - got.len();
        let room = parts.get(i).copied().unwrap_or(MAX_LIST).min(left);
        let n = walk.resume_entries(table, map, &mut resume, &mut words[..2 * room]);
        assert!(n > 0 || room == 0, "a resumed walk with room wrote nothing");
        got.extend(words[..2 * n].chunks(2).map(|c| [c[0], c[1]]));
        if left == 0 {
            break;
        }
    }
    got
}

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
        assert!(general_ambiguous * 1000 < general, "{fmt:?}: {general_ambiguous} of {general} general rays ambiguous");
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

/// The fused walk of the device writes exactly the entries of `build_list` (f32): same
/// voxels, PEs and `t_exit` bits (±0 alike), with f32 and with integer-key comparisons, over
/// the awkward rays of `random_case` (planes, zero components, origins inside and on faces,
/// limited t ranges), with random empty voxels, maps shorter than the grid, and a full output
/// buffer.
#[test]
fn request_words_equal_build_list() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5EED_0A11);
    let mut list = TraversalList::new();
    let mut words = vec![0u32; 2 * MAX_LIST];
    let mut nonempty = 0;
    for i in 0..40_000 {
        let case = random_case(&mut rng, if i % 10 == 0 { 40 } else { 8 });
        let g = &case.grid;
        let voxels = g.voxel_count() as usize;
        let fill = rng.gen_range(0.0..1.0f64);
        let mut map: Vec<u8> =
            (0..voxels).map(|_| if rng.gen_bool(fill) { rng.gen_range(0..4) } else { EMPTY_VOXEL }).collect();
        if i % 7 == 0 {
            map.truncate(rng.gen_range(0..=voxels));
        }
        let walk = WalkGrid::new(g);
        build_list_in(RayFormat::F32, g, &map, &case.ray, 0.0, case.tmax, &mut list);
        // Every other case walks with the occupancy-ahead table (stopping early).
        let mut ahead = Vec::new();
        let vm = if i % 2 == 0 { with_ahead(g, &map, &mut ahead) } else { VoxelMap::plain(&map) };
        let cap = if i % 13 == 0 { rng.gen_range(0..4) } else { MAX_LIST };
        // ±0 exit distances are one value here (the integer-key comparisons may return either
        // zero; both accept the same hits).
        let zero = |w: u32| if w == 0x8000_0000 { 0 } else { w };
        let want: Vec<[u32; 2]> =
            list.iter().take(cap).map(|e| gridrt_shared::fsl::entry_words(*e)).map(|[a, b]| [a, zero(b)]).collect();
        // The origin's subtractions from an `OriginPlanes` give the same words.
        let mut table = OriginPlanes::default();
        walk.fill_origin_planes(case.ray.origin.to_array(), &mut table);
        for keys in [false, true] {
            let n = walk.write_entries_in(keys, vm, &case.ray, case.tmax, &mut words[..2 * cap]);
            let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
            assert_eq!(got, want, "keys {keys}: {:?} {:?} t_max {}", g, case.ray, case.tmax);
            nonempty += (n > 0) as u32;
            let n = walk.write_entries_with(
                keys,
                Some(&table),
                None,
                vm,
                &case.ray,
                case.tmax,
                &mut words[..2 * cap],
                &mut None,
            );
            let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
            assert_eq!(got, want, "table, keys {keys}: {:?} {:?} t_max {}", g, case.ray, case.tmax);
            // In parts, resumed where the buffer filled up: the same entries.
            let parts = [rng.gen_range(0..4), rng.gen_range(0..3), rng.gen_range(1..3)];
            let got = in_parts(&walk, &table, vm, &parts, cap, |w, r| {
                walk.write_entries_with(keys, None, None, vm, &case.ray, case.tmax, w, r)
            });
            let got: Vec<[u32; 2]> = got.into_iter().map(|[a, b]| [a, zero(b)]).collect();
            assert_eq!(got, want, "parts {parts:?}, keys {keys}: {:?} {:?} t_max {}", g, case.ray, case.tmax);
            let got = in_parts(&walk, &table, vm, &parts, cap, |w, r| {
                walk.write_entries_with(keys, Some(&table), None, vm, &case.ray, case.tmax, w, r)
            });
            let got: Vec<[u32; 2]> = got.into_iter().map(|[a, b]| [a, zero(b)]).collect();
            assert_eq!(got, want, "parts {parts:?}, table, keys {keys}: {:?} {:?} t_max {}", g, case.ray, case.tmax);
        }
        // A table of another origin or grid is not used.
        let other = Ray { origin: case.ray.origin + Vec3::X, dir: case.ray.dir };
        let mut stale = OriginPlanes::default();
        walk.fill_origin_planes(other.origin.to_array(), &mut stale);
        for _ in 0..2 {
            let n = walk.write_entries_from(&mut stale, vm, &case.ray, case.tmax, &mut words[..2 * cap], &mut None);
            let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
            assert_eq!(got, want, "stale table: {:?} {:?}", g, case.ray);
        }
        // ... nor is one of another grid.
        let mut other_grid = OriginPlanes::default();
        let shifted = GridDesc { min: g.min - Vec3::ONE, ..*g };
        WalkGrid::new(&shifted).fill_origin_planes(case.ray.origin.to_array(), &mut other_grid);
        let n = walk.write_entries_from(&mut other_grid, vm, &case.ray, case.tmax, &mut words[..2 * cap], &mut None);
        let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
        assert_eq!(got, want, "table of another grid: {:?} {:?}", g, case.ray);
    }
    assert!(nonempty > 20_000, "{nonempty}");
    // An invalid grid, ray or t_max walks nothing (as `build_list`).
    let bad = GridDesc { min: Vec3::ONE, max: Vec3::ZERO, dims: [2, 2, 2] };
    let r = Ray { origin: Vec3::splat(-1.0), dir: Vec3::ONE };
    assert_eq!(WalkGrid::new(&bad).write_entries(VoxelMap::plain(&[0; 8]), &r, f32::INFINITY, &mut words), 0);
    let good = WalkGrid::new(&GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [2, 2, 2] });
    // The diagonal through the corners: ties step x, then y, then z (zero-length voxels included).
    assert_eq!(good.write_entries(VoxelMap::plain(&[0; 8]), &r, f32::INFINITY, &mut words), 4);
    for (o, d, t_max) in [
        (Vec3::new(f32::NAN, -1.0, -1.0), Vec3::ONE, f32::INFINITY),
        (Vec3::splat(-1.0), Vec3::new(1.0, f32::INFINITY, 1.0), f32::INFINITY),
        (Vec3::splat(-1.0), Vec3::new(-0.0, 0.0, -0.0), f32::INFINITY),
        (Vec3::splat(-1.0), Vec3::ONE, f32::NAN),
    ] {
        assert_eq!(
            good.write_entries(VoxelMap::plain(&[0; 8]), &Ray { origin: o, dir: d }, t_max, &mut words),
            0,
            "{o} {d} {t_max}"
        );
    }
}

/// Camera-like rays (one eye per grid, 1 to 8 box sizes away, aimed at points in the box and
/// at points on its cell boundaries) give the same words with the eye's table — whose start
/// cells come from `WalkGrid::integer_start` where its bound holds — as `build_list`; and with
/// the table's reciprocals too (`write_entries_table`), the rays sharing one or two direction
/// components with the ray before them now and then, as a camera's rows do.
#[test]
fn camera_rays_from_one_table_equal_build_list() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x0E7E_CE11);
    let mut list = TraversalList::new();
    let mut words = vec![0u32; 2 * MAX_LIST];
    let mut checked = 0;
    for _ in 0..300 {
        let g = random_grid(&mut rng, 64);
        let ext = g.max - g.min;
        let centre = g.min + ext * 0.5;
        let away = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        let eye = centre + away.normalize_or(Vec3::X) * ext.length() * rng.gen_range(1.0..8.0f32);
        // Full maps, and sparse ones walked with their occupancy-ahead table.
        let fill = if rng.gen_bool(0.5) { 1.0 } else { rng.gen_range(0.0..0.3f64) };
        let map: Vec<u8> =
            (0..g.voxel_count()).map(|_| if rng.gen_bool(fill) { rng.gen_range(0..4) } else { EMPTY_VOXEL }).collect();
        let mut ahead = Vec::new();
        let vm = with_ahead(&g, &map, &mut ahead);
        let walk = WalkGrid::new(&g);
        let mut table = OriginPlanes::default();
        walk.fill_origin_planes(eye.to_array(), &mut table);
        let mut memo_table = OriginPlanes::default();
        let mut before = Vec3::X;
        for _ in 0..1000 {
            let mut target = g.min + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen());
            // On a cell boundary of one or two axes: entries exactly between two cells.
            for _ in 0..rng.gen_range(0..3) {
                let a = rng.gen_range(0..3);
                target[a] = plane_coord(&mut rng, &g, a);
            }
            let mut dir = target - eye;
            for a in 1..3 {
                if rng.gen_bool(0.5) {
                    dir[a] = before[a];
                }
            }
            before = dir;
            let ray = Ray { origin: eye, dir };
            build_list_in(RayFormat::F32, &g, &map, &ray, 0.0, f32::INFINITY, &mut list);
            let zero = |w: u32| if w == 0x8000_0000 { 0 } else { w };
            let want: Vec<[u32; 2]> =
                list.iter().map(|e| gridrt_shared::fsl::entry_words(*e)).map(|[a, b]| [a, zero(b)]).collect();
            for keys in [false, true] {
                let n =
                    walk.write_entries_with(keys, Some(&table), None, vm, &ray, f32::INFINITY, &mut words, &mut None);
                let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
                assert_eq!(got, want, "keys {keys}: {g:?} {ray:?}");
                checked += usize::from(n > 0);
                let n = walk.write_entries_table(keys, &mut memo_table, vm, &ray, f32::INFINITY, &mut words, &mut None);
                let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
                assert_eq!(got, want, "keys {keys}, reciprocals from the table: {g:?} {ray:?}");
                // A few entries, then the rest (the device's camera rays).
                let parts = [rng.gen_range(1..4)];
                // (The table the call just above built for this ray: the one `start` uses.)
                let got = in_parts(&walk, &memo_table.clone(), vm, &parts, MAX_LIST, |w, r| {
                    walk.write_entries_table(keys, &mut memo_table, vm, &ray, f32::INFINITY, w, r)
                });
                let got: Vec<[u32; 2]> = got.into_iter().map(|[a, b]| [a, zero(b)]).collect();
                assert_eq!(got, want, "keys {keys}, in parts {parts:?}: {g:?} {ray:?}");
            }
        }
    }
    assert!(checked > 400_000, "{checked}");
}

/// Origins inside the box, where the walk on integer keys skips the clip
/// (`WalkGrid::inside_far`): the same words as `build_list` at the edges of that shortcut —
/// origins on a face or a few ulps from one (going out or in), directions from 2^-60 to
/// 2^60 (first boundaries below the normal range), and `t_max` of ±0, negative, subnormal,
/// the least normal, finite and infinite.
#[test]
fn inside_origins_walk_without_the_clip_as_build_list() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x1A51DE);
    let mut list = TraversalList::new();
    let mut words = vec![0u32; 2 * MAX_LIST];
    let t_maxes = [0.0, -0.0, -1.0, f32::from_bits(1), f32::MIN_POSITIVE, 0.75, 1.0 - 1.0 / 1024.0, f32::INFINITY];
    let (mut nonempty, mut edges) = (0, 0);
    for i in 0..60_000 {
        let g = random_grid(&mut rng, 12);
        let mut o = g.min + (g.max - g.min) * Vec3::new(rng.gen(), rng.gen(), rng.gen());
        for a in 0..3 {
            match rng.gen_range(0..4) {
                0 => o[a] = if rng.gen() { g.min[a] } else { g.max[a] },
                1 => {
                    // A few ulps inside a face.
                    let (face, inward) = if rng.gen() { (g.min[a], 1i32) } else { (g.max[a], -1) };
                    let ulps = rng.gen_range(0..4i32) * inward;
                    let step = if face >= 0.0 { ulps } else { -ulps };
                    o[a] = f32::from_bits((face.to_bits() as i32 + step) as u32);
                    o[a] = o[a].clamp(g.min[a], g.max[a]);
                }
                _ => {}
            }
        }
        let scale = 2f32.powi(rng.gen_range(-60..=60));
        let dir = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * scale;
        let ray = Ray { origin: o, dir };
        let t_max = t_maxes[i % t_maxes.len()];
        let fill = if i % 2 == 0 { 1.0 } else { rng.gen_range(0.0..0.3f64) };
        let map: Vec<u8> =
            (0..g.voxel_count()).map(|_| if rng.gen_bool(fill) { rng.gen_range(0..4) } else { EMPTY_VOXEL }).collect();
        let mut ahead = Vec::new();
        let vm = with_ahead(&g, &map, &mut ahead);
        build_list_in(RayFormat::F32, &g, &map, &ray, 0.0, t_max, &mut list);
        let zero = |w: u32| if w == 0x8000_0000 { 0 } else { w };
        let want: Vec<[u32; 2]> =
            list.iter().map(|e| gridrt_shared::fsl::entry_words(*e)).map(|[a, b]| [a, zero(b)]).collect();
        let walk = WalkGrid::new(&g);
        let n = walk.write_entries_in(true, vm, &ray, t_max, &mut words);
        let got: Vec<[u32; 2]> = words[..2 * n].chunks(2).map(|c| [c[0], zero(c[1])]).collect();
        assert_eq!(got, want, "{g:?} {ray:?} t_max {t_max:e}");
        nonempty += usize::from(n > 0);
        edges += usize::from(n == 0 && t_max > 0.0 && fill == 1.0);
    }
    // Both kinds occur: walks, and clips that are empty although t_max > 0.
    assert!(nonempty > 10_000 && edges > 500, "{nonempty} {edges}");
}

/// Bit `o` of voxel `v` in [`fill_ahead`]'s table is set exactly when a non-empty voxel lies
/// in the box from `v` toward octant `o`'s corner (`v` included; octant bit `a` = going down
/// on axis `a`): brute force over random grids and maps, maps shorter than the grid
/// included. A table shorter than the grid says "never stop" everywhere.
#[test]
fn ahead_bits_say_a_non_empty_voxel_lies_in_the_octant_box() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xA4EAD);
    let (mut set, mut clear) = (0u32, 0u32);
    for _ in 0..300 {
        let dims = [rng.gen_range(1..7u32), rng.gen_range(1..7), rng.gen_range(1..7)];
        let g = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims };
        let voxels = g.voxel_count() as usize;
        let fill = rng.gen_range(0.0..0.3f64);
        let mut pe: Vec<u8> =
            (0..voxels).map(|_| if rng.gen_bool(fill) { rng.gen_range(0..4) } else { EMPTY_VOXEL }).collect();
        if rng.gen_bool(0.2) {
            pe.truncate(rng.gen_range(0..=voxels));
        }
        let mut ahead = Vec::new();
        let map = with_ahead(&g, &pe, &mut ahead);
        let filled = |c: [u32; 3]| pe.get(g.voxel_id(c) as usize).is_some_and(|&p| p != EMPTY_VOXEL);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let v = g.voxel_id([x, y, z]);
                    for o in 0..8u8 {
                        let range = |a: usize, c: u32| if o >> a & 1 == 1 { 0..=c } else { c..=dims[a] - 1 };
                        let any = range(2, z)
                            .flat_map(|k| range(1, y).flat_map(move |j| range(0, x).map(move |i| [i, j, k])))
                            .any(filled);
                        assert_eq!(map.any_ahead(v, 1 << o), any, "{dims:?} {pe:?} voxel {v} octant {o}");
                        set += u32::from(any);
                        clear += u32::from(!any);
                    }
                }
            }
        }
        // Direction signs pick the octant: bit a of the octant is the sign bit of d[a].
        assert_eq!(VoxelMap::octant_bit([1.0, -0.0, -2.0]), 1 << 0b110);
        assert_eq!(VoxelMap::octant_bit([-1.0, 0.0, 0.0]), 1 << 0b001);
    }
    assert!(set > 10_000 && clear > 10_000, "{set} {clear}");
    let mut short = [0u8; 7];
    assert!(!fill_ahead([2, 2, 2], &[0; 8], &mut short));
    assert_eq!(short, [0xFF; 7]);
}

/// Shadow rays toward a point light, from origins in the box (on cell planes too) and lights
/// inside, beside and far from it: the list [`LightCells`] gives holds every voxel of the
/// walk's list (`WalkGrid::write_entries`, the device's shadow walk), with `t_exit` 1. Most
/// rays are answered by the cells, not sent back to the walk.
#[test]
fn a_light_cell_list_holds_every_voxel_of_the_shadow_walk() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5AAD_0CE1);
    let mut cells = Box::new(LightCells::<16, 24>::new());
    let mut words = vec![0u32; 2 * MAX_LIST];
    let mut listed = vec![0u32; 2 * MAX_LIST];
    let (mut rays, mut answered, mut walked_entries) = (0usize, 0usize, 0usize);
    for _ in 0..200 {
        let g = random_grid(&mut rng, 24);
        let ext = g.max - g.min;
        let fill = rng.gen_range(0.02..0.4f64);
        let map: Vec<u8> =
            (0..g.voxel_count()).map(|_| if rng.gen_bool(fill) { rng.gen_range(0..4) } else { EMPTY_VOXEL }).collect();
        let mut ahead = Vec::new();
        let vm = with_ahead(&g, &map, &mut ahead);
        let walk = WalkGrid::new(&g);
        let centre = g.min + ext * 0.5;
        let light = match rng.gen_range(0..3) {
            0 => g.min + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen()),
            1 => centre + Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * ext,
            _ => {
                centre
                    + Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
                        * ext.length()
                        * 20.0
            }
        };
        cells.build(&walk, vm, light);
        assert!(cells.is_built_for(light));
        for _ in 0..300 {
            let mut o = g.min + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen());
            for _ in 0..rng.gen_range(0..3) {
                let a = rng.gen_range(0..3);
                o[a] = plane_coord(&mut rng, &g, a);
            }
            let ray = Ray { origin: o, dir: light - o };
            let want = walk.write_entries(vm, &ray, crate::shade::SHADOW_T_MAX, &mut words);
            rays += 1;
            let Some(n) = cells.write_entries(&ray, crate::shade::SHADOW_T_MAX, &mut listed) else { continue };
            answered += 1;
            walked_entries += want;
            let got: std::collections::HashSet<u32> = listed[..2 * n].chunks(2).map(|c| c[0]).collect();
            assert!(listed[..2 * n].chunks(2).all(|c| c[1] == T_EXIT_ALL.to_bits()));
            for e in words[..2 * want].chunks(2) {
                assert!(got.contains(&e[0]), "voxel {:#x} of the walk not listed: {g:?} light {light:?} {ray:?}", e[0]);
            }
        }
    }
    assert!(answered * 2 > rays, "{answered} of {rays} rays answered by the cells");
    assert!(walked_entries > 20_000, "{walked_entries}");
}
