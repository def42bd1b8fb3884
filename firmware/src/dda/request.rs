//! The traversal list written straight into the words of an FSL ray request (SPEC.md §4.3).
//!
//! This is the f32 3D-DDA of [`Traversal`](super::Traversal) and the list builder of
//! [`build_list`](super::build_list) fused into one loop, with everything that does not depend
//! on the ray done once per scene ([`WalkGrid`]): grid validity, extents, voxel counts and
//! every boundary plane. The arithmetic is the same, operation for operation, so it yields
//! exactly the entries of [`build_list`](super::build_list) — same voxels, same PEs, same
//! `t_exit` bits (pinned by `request_words_equal_build_list` over edge-case rays) — and the
//! co-processor sees the same request.
//!
//! What it saves per ray: the grid checks, one `1/d` per axis (the clip's reciprocals are
//! the walk's), `floorf` (the start cell is truncated after the clamp, which gives the same
//! cell for every f32, NaN included), the boundary plane `min + k·size` per step (a table
//! lookup of the same f32), the float validity tests (bit tests), and the list buffer (each
//! entry is stored once, as its two request words).
//!
//! On soft-float cores also: camera rays' reciprocals from a memo in the eye's table
//! ([`OriginPlanes`]), and for origins inside the box (shadow rays) no clip
//! (`WalkGrid::inside_far` says why) and start cells from per-axis thresholds of the
//! start-cell formula (`WalkGrid::cell_of`). Each gives the same words.
//!
//! Numeric kernel: the tables are indexed by axis numbers (0..3) and plane numbers
//! (0..=n ≤ 255, `n` checked by [`WalkGrid::new`]); the voxel map and the output words, which
//! come from the scene upload and the caller, are accessed with `get`.

use super::ahead::VoxelMap;
use super::grid::{GridDesc, MAX_GRID_DIM};
use crate::sfloat::{add, mul, recip, sub, trunc_i32, Multiplier};
use gridrt_shared::fsl::VOXEL_MASK;
use gridrt_shared::math::{gamma, Ray};
use gridrt_shared::scene::EMPTY_VOXEL;

/// Widening of the clip's exit, as in [`Aabb::clip`](gridrt_shared::math::Aabb::clip).
const WIDEN: f32 = 1.0 + 2.0 * gamma(3);

/// Compare ray parameters on integer keys ([`Order`]) where that is exact: on soft-float
/// cores (`cfg(soft_float)`, see the crate's build script), where a float comparison is a
/// library call.
const INTEGER_KEYS: bool = cfg!(soft_float);

/// Unpack each reciprocal once for the inline integer product ([`Multiplier`]): on a
/// soft-float core, where `mul` is 70 instructions, and off the target (host tests cover
/// that path). Not on a hard-float image, nor with the f32 CFU (`cfu-float`), where `mul` is
/// one instruction.
const UNPACK_RECIPROCALS: bool = cfg!(all(any(soft_float, not(target_os = "none")), not(feature = "cfu-float")));

/// The key of the least positive normal f32 (`f32::MIN_POSITIVE`).
const MIN_NORMAL_KEY: i32 = 0x0080_0000;

/// Start cells of origins inside the box from thresholds (`WalkGrid::cell_of`): where the
/// formula is soft float, and off the target (host tests cover that path).
const CELL_STARTS: bool = cfg!(any(soft_float, not(target_os = "none")));

/// Planes per axis: `n + 1 ≤ MAX_GRID_DIM + 1`.
const PLANES: usize = MAX_GRID_DIM as usize + 1;
const _: () = assert!(PLANES.is_power_of_two());

/// The grid as the f32 walk uses it, computed once per scene.
#[derive(Debug, Clone)]
pub struct WalkGrid {
    /// [`GridDesc::is_valid`].
    valid: bool,
    min: [f32; 3],
    max: [f32; 3],
    /// `max − min`.
    extent: [f32; 3],
    /// Voxels per axis, as f32 and as i32.
    nf: [f32; 3],
    dims: [i32; 3],
    /// Voxel-id step per axis: 1, nx, nx·ny.
    stride: [u32; 3],
    /// `(n / extent) · 2^16` per axis: the start cell in 16.16 fixed point without a division
    /// ([`WalkGrid::start_cell`]); 0 where that is not exact.
    scale16: [f32; 3],
    /// `scale16` unpacked for the inline product (`Multiplier`), where that is used.
    by_scale16: [Option<Multiplier>; 3],
    /// The walk's hard bound `nx + ny + nz`.
    bound: u32,
    /// Boundary plane k of axis a: `min + k·(extent/n)`, and exactly `max` for k = n.
    planes: [[f32; PLANES]; 3],
    /// Per axis, for k in 1..n: the key of the least f32 whose start cell
    /// ([`WalkGrid::start_cell`] of `o − min`) is k or more (`WalkGrid::cell_of`).
    cell_starts: [[i32; PLANES]; 3],
    /// Every threshold of `cell_starts` was found.
    cell_starts_found: bool,
}

/// The walk's subtractions that depend only on the ray origin, for one origin: `plane − o` for
/// every boundary plane and the clip's `min − o`, `max − o`, built by
/// [`WalkGrid::write_entries_from`] when its ray has another origin or grid.
/// Every camera ray of a frame starts at the eye, so a walk from this table
/// ([`WalkGrid::write_entries_from`]) does one multiplication per boundary where it did a
/// subtraction and a multiplication: the same f32 operations on the same operands, the same
/// entries bit for bit.
#[derive(Debug, Clone)]
pub struct OriginPlanes {
    /// The table holds values (else it is to be built before use).
    filled: bool,
    /// The bits of the origin and of the grid (`min`, `max`, voxels per axis) the table is
    /// for.
    origin: [u32; 3],
    min: [u32; 3],
    max: [u32; 3],
    dims: [u32; 3],
    /// `min − o` and `max − o` per axis.
    clip: [[f32; 2]; 3],
    /// `plane − o` per axis and plane.
    diff: [[f32; PLANES]; 3],
    /// Per axis: `min ≤ o ≤ max` on integer keys (`WalkGrid::walk`'s one-product clip).
    in_slab: [bool; 3],
    /// Per axis: a ray from this origin that enters the box through a face of the axis
    /// starts in the cell at that face (the bound is in `WalkGrid::fill_origin_planes`).
    face_cell: [bool; 3],
    /// Per axis, when the integer start cell's bound holds ([`WalkGrid::integer_start`]):
    /// `(o − min)·(n/extent)` in 16.16 fixed point, from the f32 `−(min − o)·scale16`.
    origin_cell16: [Option<i64>; 3],
    /// Per axis, the bits of the last direction component walked from this table and its
    /// reciprocal: camera rays of a row share their vertical component, and those of a
    /// frame the forward one when the camera is axis-aligned (`ReciprocalMemo`).
    recips: ReciprocalMemo,
}

/// The last reciprocal per axis, keyed by the bits of the direction component: the same
/// bits give the same correctly rounded `1/d`, so a hit costs a comparison where a
/// reciprocal is a soft-float division.
#[derive(Debug, Clone, Copy)]
struct ReciprocalMemo {
    bits: [u32; 3],
    inv: [f32; 3],
}

impl Default for ReciprocalMemo {
    /// `1/1 = 1` on every axis: a valid entry.
    fn default() -> Self {
        Self { bits: [1.0f32.to_bits(); 3], inv: [1.0; 3] }
    }
}

impl ReciprocalMemo {
    /// `recip(d[a])` per axis, from the memo where the bits match.
    #[inline(always)]
    fn get(&mut self, d: [f32; 3]) -> [f32; 3] {
        for ((bits, inv), c) in self.bits.iter_mut().zip(&mut self.inv).zip(d) {
            if c.to_bits() != *bits {
                *bits = c.to_bits();
                *inv = recip(c);
            }
        }
        self.inv
    }
}

impl Default for OriginPlanes {
    fn default() -> Self {
        Self {
            filled: false,
            origin: [0; 3],
            min: [0; 3],
            max: [0; 3],
            dims: [0; 3],
            clip: [[0.0; 2]; 3],
            diff: [[0.0; PLANES]; 3],
            in_slab: [false; 3],
            face_cell: [false; 3],
            origin_cell16: [None; 3],
            recips: ReciprocalMemo::default(),
        }
    }
}

/// `x` is neither infinite nor NaN (a bit test: no float compare on a soft-float core).
#[inline(always)]
fn finite(x: f32) -> bool {
    x.to_bits() & 0x7F80_0000 != 0x7F80_0000
}

/// No component of `v` is infinite or NaN: three bit tests without branches. With an FPU
/// the walk's `all` over the arrays was a loop through memory (18 instructions per vector);
/// a soft-float core keeps the loop, which costs its walk less (measured: the tests written
/// out cost riscv32imac 12 instructions per primary ray, in the walk's registers).
#[inline(always)]
fn all_finite([x, y, z]: [f32; 3]) -> bool {
    finite(x) & finite(y) & finite(z)
}

impl WalkGrid {
    /// The walk constants of `grid`; an invalid grid ([`GridDesc::is_valid`]) walks nothing.
    pub fn new(grid: &GridDesc) -> Self {
        let mut w = Self {
            valid: grid.is_valid(),
            min: grid.min.to_array(),
            max: grid.max.to_array(),
            extent: [1.0; 3],
            nf: [1.0; 3],
            dims: [1; 3],
            stride: [1, 0, 0],
            scale16: [0.0; 3],
            by_scale16: [None; 3],
            bound: 0,
            planes: [[0.0; PLANES]; 3],
            cell_starts: [[i32::MAX; PLANES]; 3],
            cell_starts_found: false,
        };
        if !w.valid {
            return w;
        }
        let [nx, ny, nz] = grid.dims;
        // Valid: 1 ≤ n ≤ 255 per axis, so none of these overflows.
        w.stride = [1, nx, nx * ny];
        w.bound = nx + ny + nz;
        for a in 0..3 {
            let n = grid.dims[a] as i32;
            w.dims[a] = n;
            w.nf[a] = n as f32;
            let extent = w.max[a] - w.min[a];
            w.extent[a] = extent;
            // 0 (no fast start cell) where n/extent is not a normal number or its 16.16 form
            // overflows: there the error bound of `start_cell` does not hold.
            let s = n as f32 / extent;
            w.scale16[a] = if s.is_normal() && (s * 65536.0).is_finite() { s * 65536.0 } else { 0.0 };
            w.by_scale16[a] = if UNPACK_RECIPROCALS { Multiplier::new(w.scale16[a]) } else { None };
            // `Traversal`'s `Planes::plane`: the same f32 expression per plane.
            let size = extent / n as f32;
            for (k, p) in w.planes[a].iter_mut().enumerate().take(n as usize + 1) {
                *p = if k as i32 >= n { w.max[a] } else { w.min[a] + k as f32 * size };
            }
        }
        if CELL_STARTS {
            let mut found = true;
            for a in 0..3 {
                for k in 1..w.dims[a] {
                    let start = w.least_key_of_cell(a, k);
                    found &= start.is_some();
                    w.cell_starts[a][k as usize] = start.unwrap_or(i32::MAX);
                }
            }
            w.cell_starts_found = found;
        }
        w
    }

    /// [`GridDesc::is_valid`] of the grid.
    pub(super) fn is_valid(&self) -> bool {
        self.valid
    }

    /// Voxels per axis.
    pub(super) fn dims(&self) -> [u32; 3] {
        self.dims.map(|n| n as u32)
    }

    /// Voxel-id step per axis: 1, nx, nx·ny.
    pub(super) fn strides(&self) -> [u32; 3] {
        self.stride
    }

    /// The `n + 1` boundary planes of axis `a` (empty for an invalid grid).
    pub(super) fn planes(&self, a: usize) -> &[f32] {
        let n = if self.valid { self.dims.get(a).map_or(0, |&n| n as usize + 1) } else { 0 };
        self.planes.get(a).and_then(|p| p.get(..n)).unwrap_or(&[])
    }

    /// The start cell of an origin `o` on axis `a` ([`WalkGrid::start_cell`] of `o − min`)
    /// from [`WalkGrid::cell_starts`]: that formula is monotone in `o` (each rounding is,
    /// and the truncation and clamp), so its cell is the number of thresholds at or below
    /// `o`'s key; ±0 give the same cell. A binary search on integers where the formula is a
    /// subtraction, a division and a product in soft float.
    #[inline(always)]
    fn cell_of(&self, a: usize, o: f32) -> i32 {
        let k = key(o);
        let starts = &self.cell_starts[a];
        // Invariant: the cell is in [lo, hi): thresholds 1..lo are at or below k, hi.. above.
        let (mut lo, mut hi) = (0usize, self.dims[a] as usize);
        // Bounded: the interval halves (at most 8 rounds for 255 cells).
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if starts.get(mid).is_some_and(|&t| t <= k) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo as i32
    }

    /// The least key whose f32 has start cell `k` or more on axis `a` (1 ≤ k < n): from the
    /// key of plane k (the threshold is within a few ulps of it), a doubling search to
    /// bracket it, then bisection; 34 + 32 formula evaluations at most. `None` when no finite
    /// f32 has that cell (then [`WalkGrid::cell_of`] is not used on the grid).
    fn least_key_of_cell(&self, a: usize, k: i32) -> Option<i32> {
        const TOP: i64 = 0x7F7F_FFFF;
        let at_least = |x: i64| self.start_cell(false, a, sub(from_key(x as i32), self.min[a])) >= k;
        let guess = i64::from(key(self.planes[a][k as usize])).clamp(-TOP, TOP);
        // Bracket: `at_least(hi)`, and not `at_least(lo)` or lo = −TOP − 1 (below all).
        let (mut lo, mut hi) = (-TOP - 1, TOP);
        let up = !at_least(guess);
        if up {
            lo = guess;
        } else {
            hi = guess;
        }
        for shift in 0..34 {
            let x = if up { (guess + (1 << shift)).min(TOP) } else { (guess - (1 << shift)).max(-TOP - 1) };
            if up {
                if at_least(x) {
                    hi = x;
                    break;
                }
                lo = x;
            } else {
                if x < -TOP || !at_least(x) {
                    lo = x;
                    break;
                }
                hi = x;
            }
        }
        if !at_least(hi) {
            return None;
        }
        for _ in 0..34 {
            if hi - lo <= 1 {
                break;
            }
            let mid = lo + (hi - lo) / 2;
            if mid >= -TOP && at_least(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        i32::try_from(hi).ok().filter(|_| hi - lo == 1)
    }

    /// Walks `ray` over `[0, t_max]` and writes each non-empty voxel it crosses, in order, as
    /// the two words of a request entry (`pe << 24 | voxel`, `t_exit` bits) into `words`;
    /// returns the number of entries. `map` is the scene's voxel → PE map ([`EMPTY_VOXEL`] =
    /// empty; ids past its end count as empty) with its occupancy-ahead table, where the walk
    /// stops once no entry can follow (the same entries). Stops when `words` is full, like
    /// [`build_list`](super::build_list) at [`MAX_LIST`](super::MAX_LIST) entries.
    pub fn write_entries(&self, map: VoxelMap<'_>, ray: &Ray, t_max: f32, words: &mut [u32]) -> usize {
        self.write_entries_in(INTEGER_KEYS, map, ray, t_max, words)
    }

    /// [`write_entries_in`](Self::write_entries_in) with the origin's subtractions from
    /// `table` (the caller checked it is this ray's) and the direction's reciprocals `recips`
    /// where the caller has them (else they are computed).
    // Inline: on hard-float cores the plain walk then folds to what it was before the table;
    // on soft-float cores there are two copies, with and without a table (each folds its
    // branches on the table).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn write_entries_with(
        &self,
        keys: bool,
        table: Option<&OriginPlanes>,
        recips: Option<[f32; 3]>,
        map: VoxelMap<'_>,
        ray: &Ray,
        t_max: f32,
        words: &mut [u32],
        resume: &mut Option<Resume>,
    ) -> usize {
        let o = ray.origin.to_array();
        let d = ray.dir.to_array();
        let zero_dir = (d[0].to_bits() | d[1].to_bits() | d[2].to_bits()) & 0x7FFF_FFFF == 0;
        let valid_ray =
            if cfg!(soft_float) { o.iter().chain(d.iter()).all(|&c| finite(c)) } else { all_finite(o) & all_finite(d) }
                && !zero_dir;
        if !self.valid || !valid_ray || t_max.is_nan() {
            return 0;
        }
        let inv = match recips {
            Some(inv) => inv,
            None => [recip(d[0]), recip(d[1]), recip(d[2])],
        };
        // Without an infinite reciprocal no clip distance or boundary can be NaN (finite ·
        // finite), and the comparisons may be made on integers (module doc); a soft-float core
        // does so.
        let no_nan = if cfg!(soft_float) { inv.iter().all(|&i| finite(i)) } else { all_finite(inv) };
        self.walk(Order { keys: no_nan && keys }, keys, table, map, o, d, inv, t_max, words, resume)
    }

    /// [`write_entries`](Self::write_entries), comparing on integer keys where that is exact
    /// (`keys`) or always in f32.
    #[cfg_attr(soft_float, inline(never))]
    pub(super) fn write_entries_in(
        &self,
        keys: bool,
        map: VoxelMap<'_>,
        ray: &Ray,
        t_max: f32,
        words: &mut [u32],
    ) -> usize {
        // No resumption: the state the walk would keep is a dead store here.
        self.write_entries_with(keys, None, None, map, ray, t_max, words, &mut None)
    }

    /// `table` is the [`OriginPlanes`] of rays from `origin` on this grid (word comparisons:
    /// a derived `==` on arrays is a byte-wise `memcmp` call on a soft-core).
    #[inline(always)]
    fn origin_table_fits(&self, origin: [f32; 3], table: &OriginPlanes) -> bool {
        let mut diff = u32::from(!table.filled);
        for (a, o) in origin.iter().enumerate() {
            diff |= (table.origin[a] ^ o.to_bits())
                | (table.min[a] ^ self.min[a].to_bits())
                | (table.max[a] ^ self.max[a].to_bits())
                | (table.dims[a] ^ self.dims[a] as u32);
        }
        diff == 0
    }

    /// Makes `table` the [`OriginPlanes`] of rays from `origin` on this grid: a subtraction
    /// per plane.
    pub(super) fn fill_origin_planes(&self, origin: [f32; 3], table: &mut OriginPlanes) {
        for (a, &o) in origin.iter().enumerate() {
            table.origin[a] = o.to_bits();
            table.min[a] = self.min[a].to_bits();
            table.max[a] = self.max[a].to_bits();
            table.dims[a] = self.dims[a] as u32;
            table.clip[a] = [sub(self.min[a], o), sub(self.max[a], o)];
            table.in_slab[a] = key(self.min[a]) <= key(o) && key(o) <= key(self.max[a]);
            let n = self.dims[a].clamp(0, PLANES as i32 - 1) as usize;
            for (d, &p) in table.diff[a].iter_mut().zip(&self.planes[a]).take(n + 1) {
                *d = sub(p, o);
            }
            // A ray entering through the face `f` (min or max) of axis a at t0 = (f − o)·(1/d)
            // (each rounded) has its entry o + d·t0 within 4.1u·|f − o| + 1.01u·|f| of f, u =
            // 2^-24, and the start cell's formula (q/extent)·n is then off its exact value (0 or
            // n) by at most n·(5.3u·A/extent + 4.1u), A the largest of |min − o|, |max − o|,
            // |min|, |max|: below 1, so the cell is the face's, when A·n ≤ extent·2^19 (a
            // factor 2 to spare for the roundings of this test).
            let abs = |x: f32| f32::from_bits(x.to_bits() & !0x8000_0000);
            let largest = abs(table.clip[a][0]).max(abs(table.clip[a][1])).max(abs(self.min[a])).max(abs(self.max[a]));
            table.face_cell[a] = mul(largest, self.nf[a]) <= mul(self.extent[a], 524_288.0);
            // The integer start cell's bound (`integer_start`): A·n ≤ extent·2^9, and the
            // origin's cell coordinate in 16.16 (|·| ≤ 2^9·2^16, exact in f32 → i64).
            let scale = self.scale16[a];
            let near = mul(largest, self.nf[a]) <= mul(self.extent[a], 512.0);
            table.origin_cell16[a] =
                if near && scale.to_bits() != 0 { Some(trunc_i32(mul(-table.clip[a][0], scale)) as i64) } else { None };
        }
        table.filled = true;
    }

    /// [`write_entries`](Self::write_entries) for rays that mostly share an origin (camera
    /// rays): the subtractions that depend only on the origin come from `table`, which is
    /// rebuilt first when it is not this ray's origin's on this grid. The same entries.
    ///
    /// Where `words` fills up before the walk ends, `resume` holds where it stopped
    /// ([`resume_entries`](Self::resume_entries) goes on from there); else it is `None`.
    #[cfg_attr(soft_float, inline(never))]
    pub fn write_entries_from(
        &self,
        table: &mut OriginPlanes,
        map: VoxelMap<'_>,
        ray: &Ray,
        t_max: f32,
        words: &mut [u32],
        resume: &mut Option<Resume>,
    ) -> usize {
        if !cfg!(soft_float) {
            // With an FPU the subtraction costs less than the table's check (measured), and
            // this keeps the hard-float walk without a table.
            return self.write_entries_with(INTEGER_KEYS, None, None, map, ray, t_max, words, resume);
        }
        self.write_entries_table(INTEGER_KEYS, table, map, ray, t_max, words, resume)
    }

    /// Goes on with the walk `resume` holds, from
    /// [`write_entries_from`](Self::write_entries_from) with the same `table` (not rebuilt
    /// since) and `map`, writing its next entries into `words`; `resume` then holds where it
    /// stopped again, or `None`. The entries of both calls together are those of one walk
    /// with room for all of them.
    #[inline(never)]
    pub fn resume_entries(
        &self,
        table: &OriginPlanes,
        map: VoxelMap<'_>,
        resume: &mut Option<Resume>,
        words: &mut [u32],
    ) -> usize {
        let Some(r) = resume.take() else { return 0 };
        let planes = if r.pre { &table.diff } else { &self.planes };
        let axis = |a: usize| Axis {
            cell: r.cell[a],
            end: self.dims[a],
            step: r.step[a],
            plane: r.plane[a],
            stride: r.step[a].wrapping_mul(self.stride[a] as i32),
            o: r.o[a],
            pre: r.pre,
            inv: r.inv[a],
            by_inv: if UNPACK_RECIPROCALS { Multiplier::new(r.inv[a]) } else { None },
            t_next: r.t_next[a],
        };
        let walk = Walk { planes, map, octant: r.octant, t0: r.t, t_end: r.t_end, bound: r.bound };
        walk.run(Order { keys: r.keys }, [axis(0), axis(1), axis(2)], r.voxel, words, resume)
    }

    /// [`write_entries_from`](Self::write_entries_from) on a soft-float core: the origin's
    /// subtractions and the direction's reciprocals from `table` (rebuilt first when it is
    /// not this ray's origin's on this grid).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn write_entries_table(
        &self,
        keys: bool,
        table: &mut OriginPlanes,
        map: VoxelMap<'_>,
        ray: &Ray,
        t_max: f32,
        words: &mut [u32],
        resume: &mut Option<Resume>,
    ) -> usize {
        let origin = ray.origin.to_array();
        if !self.origin_table_fits(origin, table) {
            self.fill_origin_planes(origin, table);
        }
        let inv = table.recips.get(ray.dir.to_array());
        self.write_entries_with(keys, Some(table), Some(inv), map, ray, t_max, words, resume)
    }

    /// The start cell of `Traversal::new` on axis `a` from `q = entry − min`:
    /// `trunc(q / extent · n)` clamped to `[0, n − 1]` (truncation instead of floor gives the
    /// same cell after the clamp: below 0 both clamp to 0; NaN casts to 0).
    ///
    /// With `fast`, first without the division: `q · (n/extent)` differs from the formula's
    /// value by at most 4 roundings of 2^-24 relative, below 2^-13 absolute for cells up to
    /// 255, so it gives the same cell unless it lies within 2^-11 of a boundary 1..n−1; only
    /// then (about one ray in a thousand) the formula runs.
    #[inline(always)]
    fn start_cell(&self, fast: bool, a: usize, q: f32) -> i32 {
        let n = self.dims[a];
        if fast && self.scale16[a].to_bits() != 0 {
            // 16.16 fixed point (saturating; NaN → 0, which is cell 0 as in the formula).
            let f = trunc_i32(product(self.by_scale16[a], q, self.scale16[a]));
            let frac = f & 0xFFFF;
            let boundary = f.saturating_add(0x8000) >> 16;
            let near = !(32..=0xFFFF - 32).contains(&frac);
            if !near || boundary < 1 || boundary > n - 1 {
                return (f >> 16).max(0).min(n - 1);
            }
        }
        let rel = mul(q / self.extent[a], self.nf[a]);
        trunc_i32(rel).max(0).min(n - 1)
    }

    /// The start cell of axis `a` in integers, for a ray from an origin whose cell coordinate
    /// `(o − min)·n/extent` is `origin16`·2⁻¹⁶ ([`OriginPlanes`]): `origin16 + d·t0·scale16`
    /// with the product of the three significands in 64 bits. `None` where it may differ from
    /// [`WalkGrid::start_cell`]'s cell: within 2⁻¹⁰ of a boundary 1..n−1, or `d`, `t0`
    /// outside the normal range.
    ///
    /// Bound: the f32 `q = (o + d·t0) − min` is within 4u·A of the real one (three roundings
    /// on magnitudes up to A, the largest of |min − o|, |max − o|, |min|, |max|; u = 2⁻²⁴),
    /// 2⁻¹³ of a cell when A·n ≤ extent·2⁹ (the table's condition); `start_cell`'s value
    /// `q·n/extent` is then within 2⁻¹⁵ of `q`'s, and the estimate within 2⁻¹³ of the real
    /// one (`min − o` and `scale16` rounded, three truncations): together below 2⁻¹¹, so
    /// outside 2⁻¹⁰ of a boundary both floor to the same cell (and the clamp keeps 0 and
    /// n − 1 at the ends). Pinned by `request_words_equal_build_list`.
    // One copy (code budget: inline at the three axes it was 2 KB).
    #[inline(never)]
    fn integer_start(&self, a: usize, origin16: Option<i64>, d: f32, t0: f32) -> Option<i32> {
        let origin16 = origin16?;
        let (db, tb, sb) = (d.to_bits(), t0.to_bits(), self.scale16[a].to_bits());
        let (de, te, se) = ((db >> 23) & 0xFF, tb >> 23, sb >> 23);
        // t0 = +0 (the origin in the box): no product. Else normal, positive t0; normal d.
        let product = if tb == 0 {
            0
        } else {
            if !(1..255).contains(&de) || !(1..255).contains(&te) || tb >> 31 != 0 {
                return None;
            }
            let sig = |b: u32| u64::from((b & 0x007F_FFFF) | 0x0080_0000);
            // 48-bit product to 32 bits, times 24 bits: below 2^56, the value
            // m·2^(de + te + se − 450 + 16) in units of 2^-16 of a cell.
            let m = ((sig(db) * sig(tb)) >> 16) * sig(sb);
            let shift = (de + te + se) as i32 - 434;
            let v = if shift >= 0 {
                // |d·t0·scale| ≤ A·n/extent ≤ 2^9 (the table's bound): no overflow; guarded.
                if shift > 7 {
                    return None;
                }
                (m << shift) as i64
            } else if shift > -64 {
                (m >> -shift) as i64
            } else {
                0
            };
            if db >> 31 != 0 {
                -v
            } else {
                v
            }
        };
        let c16 = origin16 + product;
        let n = self.dims[a];
        let whole = c16 >> 16;
        let boundary = (c16 + 0x8000) >> 16;
        let frac = c16 & 0xFFFF;
        if (1..n as i64).contains(&boundary) && !(64..=0xFFFF - 64).contains(&frac) {
            return None;
        }
        Some(whole.clamp(0, i64::from(n - 1)) as i32)
    }

    /// The walk of a valid ray with reciprocals `inv`, comparing with `O`; `fast`: the start
    /// cell without a division where that is exact ([`WalkGrid::start_cell`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk(
        &self,
        ord: Order,
        fast: bool,
        table: Option<&OriginPlanes>,
        map: VoxelMap<'_>,
        o: [f32; 3],
        d: [f32; 3],
        inv: [f32; 3],
        t_max: f32,
        words: &mut [u32],
        resume: &mut Option<Resume>,
    ) -> usize {
        *resume = None;
        // The clip of `Aabb::clip` over [0, t_max]. Its exit is the least of t_max and the
        // widened far distances `RN(far·WIDEN)`; widening is monotone, so that is the least far
        // distance widened once (one multiplication where there were three: the same value,
        // and the first of equal keys as before). Its early exits (`t1 < t0` after an axis)
        // are the final `t1 ≤ t0` test's too: t1 only falls and t0 only rises.
        let mut t0 = 0.0f32;
        let mut far_least = f32::INFINITY;
        // The axis through whose face the ray enters (t0 > 0), and whether that is the max face.
        let mut face: Option<(usize, bool)> = None;
        // An origin inside the box (every slab; shadow rays) walking on integer keys with
        // t_max > 0 needs no clip: `WalkGrid::inside_far`'s bound, checked below.
        let inside = ord.keys
            && table.is_none()
            && key(t_max) > 0
            && (0..3).all(|a| key(self.min[a]) <= key(o[a]) && key(o[a]) <= key(self.max[a]));
        // An origin inside the slab of an axis (min ≤ o ≤ max) with finite reciprocals (integer
        // keys): its near distance is ≤ 0 (its two products have opposite signs), so it never
        // raises t0, and the far one is the product of the face ahead: `max − o` going up,
        // `min − o` going down — one product (and subtraction) instead of two (the same far
        // distance, bit for bit; of zeros of either sign, the same key). Shadow rays start
        // inside the box (every axis), camera rays mostly inside the slabs across the view.
        for a in 0..3 {
            if inside {
                break;
            }
            let in_slab = ord.keys
                && match table {
                    Some(t) => t.in_slab[a],
                    None => key(self.min[a]) <= key(o[a]) && key(o[a]) <= key(self.max[a]),
                };
            if in_slab {
                let up = d[a].to_bits() >> 31 == 0;
                let ahead = match table {
                    Some(t) => t.clip[a][usize::from(up)],
                    None => sub(if up { self.max[a] } else { self.min[a] }, o[a]),
                };
                let by_inv = if UNPACK_RECIPROCALS { Multiplier::new(inv[a]) } else { None };
                let far = product(by_inv, ahead, inv[a]);
                if ord.lt(far, far_least) {
                    far_least = far;
                }
                continue;
            }
            let [dn, df] = match table {
                Some(t) => t.clip[a],
                None => [sub(self.min[a], o[a]), sub(self.max[a], o[a])],
            };
            // The axis's reciprocal unpacked once for both products.
            let by_inv = if UNPACK_RECIPROCALS { Multiplier::new(inv[a]) } else { None };
            let mut near = product(by_inv, dn, inv[a]);
            let mut far = product(by_inv, df, inv[a]);
            let swapped = ord.lt(far, near);
            if swapped {
                core::mem::swap(&mut near, &mut far);
            }
            if ord.lt(t0, near) {
                t0 = near;
                if table.is_some() {
                    face = Some((a, swapped));
                }
            }
            if ord.lt(far, far_least) {
                far_least = far;
            }
        }
        let mut t1 = t_max;
        if !inside {
            let by_widen = if UNPACK_RECIPROCALS { Multiplier::new(WIDEN) } else { None };
            let widened = product(by_widen, far_least, WIDEN);
            if ord.lt(widened, t_max) {
                t1 = widened;
            }
            if t1.is_nan() || ord.le(t1, t0) || !finite(t0) {
                return 0;
            }
        }
        // `Traversal::new`: start cell, step and first boundary per axis.
        // Built axis by axis as values (constant indices, no array initialisation).
        // The planes a crossing is computed from: `plane − o` from the table, else the planes.
        let planes = match table {
            Some(t) => &t.diff,
            None => &self.planes,
        };
        let pre = table.is_some();
        // Entered through a face of axis f, and the table's bound holds: the start cell's
        // formula gives the face's cell on that axis (`OriginPlanes::face_cell`).
        let face_cell = match (face, table) {
            (Some((f, max_face)), Some(t)) if t.face_cell[f] => Some((f, if max_face { self.dims[f] - 1 } else { 0 })),
            _ => None,
        };
        // Not on a bare-metal hard-float image, which walks without a table (and must not
        // carry the code: measured 35 instructions per primary ray on riscv32imafc).
        let origin_cell16 =
            if cfg!(any(soft_float, not(target_os = "none"))) { table.map(|t| &t.origin_cell16) } else { None };
        let start = Start { fast, face_cell, o, d, inv, t0, pre };
        let axes = [
            self.start_axis(&start, origin_cell16, planes, 0),
            self.start_axis(&start, origin_cell16, planes, 1),
            self.start_axis(&start, origin_cell16, planes, 2),
        ];
        if inside && axes.iter().any(|ax| key(ax.t_next) < MIN_NORMAL_KEY) {
            // A first boundary below the normal range (the origin on or next to a face): the
            // clip decides.
            t1 = self.inside_far(ord, o, d, inv, t_max);
            if ord.le(t1, t0) {
                return 0;
            }
        }
        let voxel = axes[0].cell as u32 + self.stride[1] * axes[1].cell as u32 + self.stride[2] * axes[2].cell as u32;
        let walk = Walk { planes, map, octant: VoxelMap::octant_bit(d), t0, t_end: t1, bound: self.bound };
        walk.run(ord, axes, voxel, words, resume)
    }

    /// The clip's exit for an origin inside the box on integer keys: the least far distance
    /// (the face ahead on each axis), widened, or `t_max`.
    ///
    /// Why [`walk`](Self::walk) may skip it when every first boundary `t_a` is a normal
    /// number: the boundaries of an axis grow with the plane (each `RN((plane − o)·(1/d))`
    /// is monotone in the plane), so `0 < t_a ≤ far_a` and the clip is not empty; every
    /// crossing the walk compares is a least boundary, at most `far = min far_a`, and
    /// `RN(far·WIDEN) > far` for a normal `far` (`WIDEN − 1 > 2^-23`; a `far` of +∞ makes
    /// both ends `t_max`). So each `min(t_cross, t_end)` is `t_cross` and no
    /// `t_cross < t_end` fails with either end, unless `t_max` is the end of both: the same
    /// entries. Pinned by `inside_origins_walk_without_the_clip_as_build_list`.
    #[inline(never)]
    fn inside_far(&self, ord: Order, o: [f32; 3], d: [f32; 3], inv: [f32; 3], t_max: f32) -> f32 {
        let mut far_least = f32::INFINITY;
        for a in 0..3 {
            let up = d[a].to_bits() >> 31 == 0;
            let far = mul(sub(if up { self.max[a] } else { self.min[a] }, o[a]), inv[a]);
            if ord.lt(far, far_least) {
                far_least = far;
            }
        }
        let widened = mul(far_least, WIDEN);
        if ord.lt(widened, t_max) {
            widened
        } else {
            t_max
        }
    }

    /// Axis `a` of a walk: start cell, step and first boundary (`Traversal::new`). Inline:
    /// as a closure the compiler kept it out of line, which cost imafc 70 instructions per
    /// primary ray (measured); inline it also saves riscv32imac 44 for 600 bytes.
    #[inline(always)]
    fn start_axis(
        &self,
        s: &Start,
        origin_cell16: Option<&[Option<i64>; 3]>,
        planes: &[[f32; PLANES]; 3],
        a: usize,
    ) -> Axis {
        let n = self.dims[a];
        let cell = match s.face_cell {
            Some((f, c)) if f == a => c,
            _ => match origin_cell16.and_then(|c| self.integer_start(a, c[a], s.d[a], s.t0)) {
                Some(c) => c,
                None => {
                    // From inside the box (t0 = +0, shadow rays): o + d·(+0) is o (for o = ±0
                    // its sign may differ, and q = ±0 − min is the same then, or ±0 → cell 0).
                    // Not on a bare-metal hard-float image: its walk compiles worse with the
                    // branch (measured: riscv32imafc 586 -> 645 instructions per primary ray).
                    let inside = cfg!(any(soft_float, not(target_os = "none"))) && s.t0.to_bits() == 0;
                    if CELL_STARTS && inside && self.cell_starts_found {
                        self.cell_of(a, s.o[a])
                    } else {
                        let entry = if inside { s.o[a] } else { add(s.o[a], mul(s.d[a], s.t0)) };
                        self.start_cell(s.fast, a, sub(entry, self.min[a]))
                    }
                }
            },
        };
        // Direction 0 (either sign): never stepped, the boundary stays at +∞. The sign
        // bit of a non-zero direction is its direction.
        let bits = s.d[a].to_bits();
        let (step, plane) = if bits & 0x7FFF_FFFF == 0 {
            (0, 0)
        } else if bits & 0x8000_0000 == 0 {
            (1, cell + 1)
        } else {
            (-1, cell)
        };
        let mut ax = Axis {
            cell,
            end: n,
            step,
            plane,
            stride: step * self.stride[a] as i32,
            o: s.o[a],
            pre: s.pre,
            inv: s.inv[a],
            by_inv: if UNPACK_RECIPROCALS { Multiplier::new(s.inv[a]) } else { None },
            t_next: f32::INFINITY,
        };
        if step != 0 {
            ax.t_next = ax.crossing(&planes[a]);
        }
        ax
    }
}

/// `x · inv` correctly rounded: inline by `by_inv` (`inv` unpacked) where operands and product
/// are normal, else `sfloat::mul`.
#[inline(always)]
fn product(by_inv: Option<Multiplier>, x: f32, inv: f32) -> f32 {
    match by_inv.and_then(|m| m.times(x)) {
        Some(t) => t,
        None => mul(x, inv),
    }
}

/// What [`WalkGrid::start_axis`] needs of the ray and its clip.
struct Start {
    /// The start cell without a division where that is exact.
    fast: bool,
    /// The axis and cell of the face the ray enters through, when the table's bound holds.
    face_cell: Option<(usize, i32)>,
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    /// The clip's entry.
    t0: f32,
    /// The planes are `plane − o` already.
    pre: bool,
}

/// One axis of a walk: its cell, direction and next boundary.
#[derive(Debug, Clone, Copy)]
struct Axis {
    cell: i32,
    /// Voxels on the axis (the cell must stay below).
    end: i32,
    /// −1, 0 or +1.
    step: i32,
    /// Index of the next boundary plane (`cell + 1` going up, `cell` going down).
    plane: i32,
    /// Voxel-id change of a step.
    stride: i32,
    o: f32,
    /// The planes are `plane − o` already ([`OriginPlanes`]).
    pre: bool,
    inv: f32,
    /// `inv` unpacked for the crossings, where it is normal (`crate::sfloat::Multiplier`).
    by_inv: Option<Multiplier>,
    t_next: f32,
}

impl Axis {
    /// The parameter of boundary plane `self.plane`: `(plane − o) · (1/d)`, from the table
    /// (of planes, or of `plane − o`).
    #[inline(always)]
    fn crossing(&self, planes: &[f32; PLANES]) -> f32 {
        // The plane is in 0..=n ≤ 255: the mask changes no index and spares the bounds check.
        let p = planes[self.plane as usize & (PLANES - 1)];
        let p = if self.pre { p } else { sub(p, self.o) };
        // The same correctly rounded product, inline where operands and product are normal.
        match self.by_inv.and_then(|m| m.times(p)) {
            Some(t) => t,
            None => mul(p, self.inv),
        }
    }

    /// Steps into the next cell; false when that leaves the grid (the walk ends).
    #[inline(always)]
    fn advance(&mut self, planes: &[f32; PLANES], voxel: &mut u32) -> bool {
        let c = self.cell + self.step;
        // One unsigned comparison: a cell below 0 wraps above every `end`.
        if c as u32 >= self.end as u32 {
            return false;
        }
        self.cell = c;
        *voxel = voxel.wrapping_add(self.stride as u32);
        // Never an axis that is not stepped: its boundary stays +∞, which ends the walk
        // (`t_cross < t_end` fails) before any step on it.
        self.plane += self.step;
        self.t_next = self.crossing(planes);
        true
    }
}

/// How a walk compares ray parameters: IEEE comparisons and `f32::min`/`max` (NaN-ignoring),
/// as `Traversal`, or (`keys`) the same comparisons on integer keys of the bit patterns (±0
/// share key 0, negative values count down): exact for every f32 but NaN, and a few integer
/// instructions where a soft-float core calls a comparison routine. With keys, `min`/`max` of
/// two zeros of opposite sign may return either; as a list entry's exit distance, ±0 accept
/// the same hits (SPEC.md §4.3). A run-time choice, not a type parameter: one copy of the
/// walk (code budget); where `keys` is a constant (hard-float cores) the branches fold.
#[derive(Clone, Copy)]
struct Order {
    keys: bool,
}

/// The f32 of a key ([`key`]'s inverse; key 0 is +0).
#[inline(always)]
fn from_key(k: i32) -> f32 {
    if k < 0 {
        f32::from_bits(k.unsigned_abs() | 0x8000_0000)
    } else {
        f32::from_bits(k as u32)
    }
}

#[inline(always)]
fn key(x: f32) -> i32 {
    let b = x.to_bits() as i32;
    if b < 0 {
        -(b & 0x7FFF_FFFF)
    } else {
        b
    }
}

impl Order {
    /// `a <= b`.
    #[inline(always)]
    fn le(self, a: f32, b: f32) -> bool {
        if self.keys {
            key(a) <= key(b)
        } else {
            a <= b
        }
    }
    /// `a < b`.
    #[inline(always)]
    fn lt(self, a: f32, b: f32) -> bool {
        if self.keys {
            key(a) < key(b)
        } else {
            a < b
        }
    }
    /// `a.min(b)`.
    #[inline(always)]
    fn min(self, a: f32, b: f32) -> f32 {
        if !self.keys {
            a.min(b)
        } else if key(b) < key(a) {
            b
        } else {
            a
        }
    }
    /// `a.max(b)`.
    #[inline(always)]
    fn max(self, a: f32, b: f32) -> f32 {
        if !self.keys {
            a.max(b)
        } else if key(b) > key(a) {
            b
        } else {
            a
        }
    }
}

/// Where a walk stopped because its output was full, to go on from
/// ([`WalkGrid::resume_entries`]): per axis what changes along a walk, its reciprocal and
/// origin; the rest comes from the grid again.
#[derive(Debug, Clone, Copy)]
pub struct Resume {
    cell: [i32; 3],
    step: [i32; 3],
    plane: [i32; 3],
    t_next: [f32; 3],
    inv: [f32; 3],
    o: [f32; 3],
    voxel: u32,
    /// The entry distance of `voxel`.
    t: f32,
    t_end: f32,
    /// The walk's bound on steps (a resumed walk has it again: a walk never takes that many,
    /// it is a guard).
    bound: u32,
    octant: u8,
    keys: bool,
    /// The walk's planes are `plane − o` ([`OriginPlanes`]).
    pre: bool,
}

/// The loop of `Walk::next`, once the start cell is known.
struct Walk<'a> {
    planes: &'a [[f32; PLANES]; 3],
    map: VoxelMap<'a>,
    /// The ray's bit of the map's occupancy-ahead table.
    octant: u8,
    t0: f32,
    t_end: f32,
    bound: u32,
}

impl Walk<'_> {
    #[inline(always)]
    fn run(
        &self,
        ord: Order,
        axes: [Axis; 3],
        mut voxel: u32,
        words: &mut [u32],
        resume: &mut Option<Resume>,
    ) -> usize {
        let [mut x, mut y, mut z] = axes;
        let [px, py, pz] = self.planes;
        let (mut t, t_end) = (self.t0, self.t_end);
        let mut out = words.chunks_exact_mut(2);
        let mut entries = 0;
        let mut full = false;
        for _ in 0..self.bound {
            // Lowest axis wins ties.
            let (t_cross, axis) = if ord.le(x.t_next, y.t_next) && ord.le(x.t_next, z.t_next) {
                (x.t_next, 0)
            } else if ord.le(y.t_next, z.t_next) {
                (y.t_next, 1)
            } else {
                (z.t_next, 2)
            };
            let t_exit = ord.max(ord.min(t_cross, t_end), t);
            let pe = self.map.pe.get(voxel as usize).copied().unwrap_or(EMPTY_VOXEL);
            if pe != EMPTY_VOXEL {
                let Some(pair) = out.next() else {
                    // Full: this voxel is the first of the next call's.
                    full = true;
                    break;
                };
                pair.copy_from_slice(&[(voxel & VOXEL_MASK) | (pe as u32) << 24, t_exit.to_bits()]);
                entries += 1;
            } else if !self.map.any_ahead(voxel, self.octant) {
                // No non-empty voxel from here on (`dda::ahead`): no entry can follow.
                break;
            }
            // Ends at t_end, and at a NaN boundary (which compares neither way).
            if !ord.lt(t_cross, t_end) {
                break;
            }
            let inside = match axis {
                0 => x.advance(px, &mut voxel),
                1 => y.advance(py, &mut voxel),
                _ => z.advance(pz, &mut voxel),
            };
            if !inside {
                break;
            }
            t = t_exit;
        }
        if full {
            // Field by field, after the loop: an axis taken by reference or copied whole lived
            // in memory for the whole walk (measured: about 90 instructions more per walk on
            // riscv32imac).
            *resume = Some(Resume {
                cell: [x.cell, y.cell, z.cell],
                step: [x.step, y.step, z.step],
                plane: [x.plane, y.plane, z.plane],
                t_next: [x.t_next, y.t_next, z.t_next],
                inv: [x.inv, y.inv, z.inv],
                o: [x.o, y.o, z.o],
                voxel,
                t,
                t_end,
                bound: self.bound,
                octant: self.octant,
                keys: ord.keys,
                pre: x.pre,
            });
        }
        entries
    }
}
