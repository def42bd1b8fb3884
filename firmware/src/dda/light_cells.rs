//! Shadow-ray lists without a walk: the grid's non-empty voxels binned by their direction
//! from the point light, once per light, so that a shadow ray's list is a lookup and a copy.
//!
//! Why a list from bins answers as the walk's list does. A shadow ray is an any-hit query
//! over `0 < t < t_max ≤ 1` (SPEC.md §4.3). With every entry's `t_exit` at 1
//! ([`T_EXIT_ALL`]) the acceptance rule reduces to that range, so the answer is "some
//! primitive of a listed voxel is hit on the segment". A primitive hit on the segment is hit
//! at a point of a voxel the segment crosses, and that voxel holds it; so any list that
//! contains the crossed non-empty voxels gives the answer of the walk's list, whatever else
//! it holds (the walk's own rounding included: below).
//!
//! The bins are a cube map around the light (as shadow cube maps are, Gerasimov, "Omnidirectional
//! Shadow Mapping", GPU Gems 2004): six faces, one per axis `a` and side, `K × K` cells
//! each, over the direction `w = p − L` by `(w_b / |w_a|, w_c / |w_a|)` for the face of the
//! largest `|w_a|`. Every point of a segment from an origin `o` toward `L` has the direction
//! of `o − L`, so the segment lies in the cone of one cell, and a voxel it crosses overlaps
//! that cone. A cell holds every non-empty voxel whose box, grown by `δ = 2^-19·S` (S the
//! largest coordinate magnitude; the walk visits only voxels within `2^-20·S` of the ray,
//! `dda` module doc), projects onto it with a margin of 1/64 cell, in order of the box's
//! near distance along `a` (its key). A ray takes the cell's entries whose key is at most its
//! origin's distance `|w_a|` (plus 2^-9 of it): a voxel farther along `a` than the origin
//! lies beyond the segment's end.
//!
//! A cell holds at most `C` voxels; the key of the first one left out bounds what it can
//! answer (a ray whose limit reaches it walks, as does every ray before the first build, with
//! a degenerate direction or a list longer than its buffer). Pinned by the property test
//! `dda::tests::a_light_cell_list_holds_every_voxel_of_the_shadow_walk`.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use super::ahead::VoxelMap;
use super::request::WalkGrid;
use gridrt_shared::fsl::VOXEL_MASK;
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::EMPTY_VOXEL;

/// The `t_exit` of every entry of a list from the cells: 1, at or above any shadow ray's
/// `t_max`, so that only `0 < t < t_max` decides (SPEC.md §4.3).
pub const T_EXIT_ALL: f32 = 1.0;

/// The cells' margin, in cells: the lookup's integer quotient is within 2^-10 cell of the
/// f32 one (below), the build's products within a few ulps.
const MARGIN: f32 = 1.0 / 64.0;

/// The two other axes of a face's axis, in the order of the cell's coordinates.
const OTHER: [(usize, usize); 3] = [(1, 2), (2, 0), (0, 1)];

/// One cell: its voxels' entry words and keys, in key order.
#[derive(Debug, Clone, Copy)]
struct Cell<const C: usize> {
    len: u16,
    /// The key of the first voxel that did not fit; `u32::MAX` when none.
    full_at: u32,
    word: [u32; C],
    key: [u32; C],
}

impl<const C: usize> Cell<C> {
    const EMPTY: Self = Self { len: 0, full_at: u32::MAX, word: [0; C], key: [0; C] };

    /// Appends a voxel (keys arrive in non-decreasing order).
    #[inline(always)]
    fn push(&mut self, word: u32, key: u32) {
        let i = self.len as usize;
        if let (Some(w), Some(k)) = (self.word.get_mut(i), self.key.get_mut(i)) {
            (*w, *k) = (word, key);
            self.len = self.len.wrapping_add(1);
        } else if self.full_at == u32::MAX {
            self.full_at = key;
        }
    }
}

/// The non-empty voxels of a grid binned by direction from one point light: `K × K` cells on
/// each of six cube faces, `C` voxels per cell at most. `K = 0` holds nothing (every lookup
/// says walk): the build for boards without the memory.
#[derive(Debug, Clone)]
pub struct LightCells<const K: usize, const C: usize> {
    /// Built for the light `light` (its bits); else every lookup says walk.
    built: bool,
    light: [u32; 3],
    faces: [[[Cell<C>; K]; K]; 6],
}

impl<const K: usize, const C: usize> Default for LightCells<K, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const K: usize, const C: usize> LightCells<K, C> {
    /// Empty: every lookup says walk until [`build`](Self::build).
    #[inline(always)]
    pub const fn new() -> Self {
        Self { built: false, light: [0; 3], faces: [[[Cell::EMPTY; K]; K]; 6] }
    }

    /// Forgets the bins (a new scene).
    pub fn clear(&mut self) {
        self.built = false;
    }

    /// True when the bins are those of the light at `light`.
    pub fn is_built_for(&self, light: Vec3) -> bool {
        self.built && self.light == light.to_array().map(f32::to_bits)
    }

    /// Bins the non-empty voxels of `map` on `walk`'s grid by direction from `light`. Leaves
    /// the cells empty (lookups walk) for an invalid grid, a light that is not finite, or
    /// `K = 0`.
    #[allow(clippy::arithmetic_side_effects, clippy::indexing_slicing)] // f32 geometry; axis indices < 3 into [_; 3], counts below 256 per axis
    pub fn build(&mut self, walk: &WalkGrid, map: VoxelMap<'_>, light: Vec3) {
        self.built = false;
        for c in self.faces.iter_mut().flatten().flatten() {
            c.len = 0;
            c.full_at = u32::MAX;
        }
        let l = light.to_array();
        if K == 0 || !walk.is_valid() || !light.is_finite() {
            return;
        }
        let dims = walk.dims();
        let stride = walk.strides();
        // δ: the walk's reach beyond the exact ray, doubled (module doc).
        let mut s = 0f32;
        for (a, la) in l.iter().enumerate() {
            let p = walk.planes(a);
            let (lo, hi) = (p.first().copied().unwrap_or(0.0), p.last().copied().unwrap_or(0.0));
            s = s.max(lo.abs()).max(hi.abs()).max(la.abs());
        }
        let delta = s * (1.0 / (1u32 << 19) as f32);
        let half = (K / 2) as f32;
        let top = K.saturating_sub(1);
        // Per face, each column's grown bounds on the two other axes relative to the light, in
        // half-face units (`(q − L_b ∓ δ)·K/2`); per slab, their cells.
        let mut bounds = [[(0f32, 0f32); 256]; 2];
        let mut ranges = [[(0usize, 0usize); 256]; 2];
        for face in 0..6 {
            let (a, down) = (face / 2, face % 2 == 1);
            let Some(&(b, c)) = OTHER.get(a) else { continue };
            for (axis, out) in [b, c].into_iter().zip(bounds.iter_mut()) {
                let planes = walk.planes(axis);
                for (q, r) in planes.windows(2).zip(out.iter_mut()) {
                    if let [q0, q1] = *q {
                        *r = ((q0 - l[axis] - delta) * half, (q1 - l[axis] + delta) * half);
                    }
                }
            }
            let pa = walk.planes(a);
            let n = dims[a] as usize;
            for step in 0..n {
                let i = if down { n - 1 - step } else { step };
                let (Some(&p0), Some(&p1)) = (pa.get(i), pa.get(i + 1)) else { continue };
                // Distances along a from the light's plane to the grown slab's near and far
                // faces, on this face's side; a slab wholly on the other side is skipped.
                let (near, far) = if down { (l[a] - p1, l[a] - p0) } else { (p0 - l[a], p1 - l[a]) };
                let far = far + delta;
                if far.is_nan() || far <= 0.0 {
                    continue;
                }
                let near = near - delta;
                let near = if near > 0.0 { near } else { 0.0 };
                let (rn, rf) = (1.0 / near, 1.0 / far);
                let key = near.to_bits();
                for ((bound, range), cols) in bounds.iter().zip(ranges.iter_mut()).zip([dims[b], dims[c]]) {
                    for (&(b0, b1), r) in bound.iter().zip(range.iter_mut()).take(cols as usize) {
                        let lo = if b0 >= 0.0 { b0 * rf } else { b0 * rn };
                        let hi = if b1 > 0.0 { b1 * rn } else { b1 * rf };
                        *r = (cell_floor(lo + half - MARGIN, top), cell_floor(hi + half + MARGIN, top));
                    }
                }
                let [range_b, range_c] = &ranges;
                let slab = (i as u32).wrapping_mul(stride[a]);
                for (k, &(c0, c1)) in range_c.iter().enumerate().take(dims[c] as usize) {
                    let row = slab.wrapping_add((k as u32).wrapping_mul(stride[c]));
                    for (j, &(b0, b1)) in range_b.iter().enumerate().take(dims[b] as usize) {
                        let voxel = row.wrapping_add((j as u32).wrapping_mul(stride[b]));
                        let pe = map.pe.get(voxel as usize).copied().unwrap_or(EMPTY_VOXEL);
                        if pe == EMPTY_VOXEL {
                            continue;
                        }
                        let word = (voxel & VOXEL_MASK) | (u32::from(pe) << 24);
                        let Some(f) = self.faces.get_mut(face) else { continue };
                        for column in f.iter_mut().take(b1 + 1).skip(b0) {
                            for cell in column.iter_mut().take(c1 + 1).skip(c0) {
                                cell.push(word, key);
                            }
                        }
                    }
                }
            }
        }
        self.light = l.map(f32::to_bits);
        self.built = true;
    }

    /// Writes the list of a shadow ray toward the light of the last build (`ray.dir =
    /// light − origin`) into `words` as request entries (`pe << 24 | voxel`, [`T_EXIT_ALL`]),
    /// and returns their number; `None` when the ray is to be walked instead: no build,
    /// `t_max` above [`T_EXIT_ALL`], a direction not finite or too small for the integer
    /// quotient, a cell that dropped a voxel within reach, or more entries than `words` holds.
    #[inline]
    pub fn write_entries(&self, ray: &Ray, t_max: f32, words: &mut [u32]) -> Option<usize> {
        if !self.built || t_max.is_nan() || t_max > T_EXIT_ALL {
            return None;
        }
        // w = o − L = −dir: the face of its largest component, the cell of the other two.
        let w = ray.dir.to_array().map(|d| d.to_bits() ^ 0x8000_0000);
        let m = w.map(|b| b & 0x7FFF_FFFF);
        let a = if m[0] >= m[1] && m[0] >= m[2] {
            0
        } else if m[1] >= m[2] {
            1
        } else {
            2
        };
        let (ma, wa) = (m.get(a).copied()?, w.get(a).copied()?);
        // Finite, and 2^-100 or more so that a subnormal other component counts as 0 within
        // 2^-26 of the quotient.
        if !(27 << 23..0x7F80_0000).contains(&ma) {
            return None;
        }
        let face = a.wrapping_mul(2).wrapping_add((wa >> 31) as usize);
        let (b, c) = OTHER.get(a).copied()?;
        let (ub, uc) = (cell_index::<K>(w.get(b).copied()?, ma), cell_index::<K>(w.get(c).copied()?, ma));
        let cell = self.faces.get(face)?.get(ub)?.get(uc)?;
        // The origin's distance along a, plus 2^-9 of it (its rounding and the keys').
        let limit = ma.saturating_add(1 << 14);
        if limit >= cell.full_at {
            return None;
        }
        let mut n = 0usize;
        let mut out = words.chunks_exact_mut(2);
        for (&word, &key) in cell.word.iter().zip(&cell.key).take(cell.len as usize) {
            if key > limit {
                break;
            }
            let [w0, w1] = out.next()? else { return None };
            (*w0, *w1) = (word, T_EXIT_ALL.to_bits());
            n = n.wrapping_add(1);
        }
        Some(n)
    }
}

/// `⌊x⌋` as a cell index in `0..=top` (below 0 and NaN → 0).
#[inline(always)]
fn cell_floor(x: f32, top: usize) -> usize {
    if x.is_nan() || x <= 0.0 {
        0
    } else if x >= top as f32 {
        top
    } else {
        x as usize
    }
}

/// The cell `⌊(u + 1)·K/2⌋` of `u = num / den` (f32 bits; `den` positive, normal, at least
/// 2^-100 and at least `|num|`), in integers: the quotient of the aligned mantissas, with
/// `den`'s cut to 16 bits, is `u·2^15` to within 2^-14 of u (2^-10 of a cell at K = 32, inside
/// [`MARGIN`]).
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // shifts below 32, a quotient of nonzero divisor
fn cell_index<const K: usize>(num: u32, den: u32) -> usize {
    let nm = num & 0x7FFF_FFFF;
    let (en, ed) = (nm >> 23, den >> 23);
    let mn = if en == 0 { 0 } else { (nm & 0x7F_FFFF) | 0x80_0000 };
    let shift = ed.saturating_sub(en);
    let aligned = if shift > 24 { 0 } else { mn >> shift };
    let md = ((den & 0x7F_FFFF) | 0x80_0000) >> 8;
    let q = ((aligned << 7) / md).min(1 << 15);
    let x = if num >> 31 != 0 { (1 << 15) - q } else { (1 << 15) + q };
    ((x as usize * K) >> 16).min(K.saturating_sub(1))
}
