//! 3D-DDA in fixed point (cargo feature `fixed-raygen` makes the device use it).
//!
//! Source: J. Amanatides and A. Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing",
//! Eurographics 1987 — the incremental form (`t_next += t_delta`), which is what a soft-core
//! without an FPU wants: after a per-ray setup of a few integer divisions, every voxel step
//! is one compare and one add on integers. Semantics, ties and the output are those of the
//! f32 [`Traversal`](super::Traversal) (same [`VoxelStep`]s up to rounding), so it is a drop-in.
//!
//! # Number format
//!
//! - *Input*: the f32 words of the grid box and of the ray, converted exactly by bit
//!   manipulation (`crate::fixed`): positions become i128 integers in units of
//!   `2^-F` with `F = 100 − ⌊log2 max|corner|⌋`, so every f32 grid corner is exact and
//!   `p − min` is an exact integer subtraction (no cancellation, whatever the translation).
//! - *Grid units*: positions relative to `min`, scaled by a power of two so that the box's
//!   largest extent spans `[256, 512)` units, held as **Q31.32 in i64** (resolution 2⁻³²
//!   units). Cell sizes are `extent / n` in the same format.
//! - *Ray parameter*: the direction is scaled by a power of two `2^-j` so that its largest
//!   grid-unit component lies in `[1, 2)`; `t' = t · 2^j` is held as Q31.32 in i64 and
//!   converted back to the f32 `t_enter`/`t_exit` exactly (one rounding).
//! - *Rounding*: `t_delta` and the first `t_next` per axis come from one division each
//!   (i128 / i64, truncated); every step adds one `t_delta`, so the error after k steps is at
//!   most k units of 2⁻³² (≤ 2⁻²² t' for the 765 steps of a 255³ grid), far inside the f32
//!   DDA's own tolerance (module doc of [`crate::dda`]). The clip against the box rounds its
//!   entry down and its exit up (conservative, like the f32 clip's `1 + 2γ(3)` widening).
//! - *Zero components*: a direction component that is 0 (or below 2⁻³² of the largest)
//!   is never stepped, as in the f32 version; such a ray moves less than 2⁻³² units per unit
//!   of t' along that axis, i.e. far less than a cell over any walk.
//!
//! # Range
//!
//! Origins more than ~2²⁶ times the grid's coordinate magnitude away, or ~2³⁰ grid units
//! away, do not fit: [`FixedTraversal::new`] returns [`DdaOverflow`] instead of a wrong
//! walk, and [`build_list`](super::build_list) then falls back to the f32 DDA (and says so).

use super::grid::{GridDesc, VoxelStep};
use super::walk::{Stepper, Walk};
use crate::fixed::{f32_to_fixed_i128, fixed_to_f32};
use gridrt_shared::math::Ray;

/// Fractional bits of grid-unit coordinates and of the ray parameter t'.
const FRAC: u32 = 32;
/// "Never": the t of an axis that is not stepped, or an unbounded end.
const NEVER: i64 = i64::MAX;

/// The ray or grid does not fit the fixed-point format (see the module doc); the caller
/// should use the f32 DDA.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DdaOverflow;

/// Unbiased binary exponent `⌊log2 |x|⌋` of a finite non-zero f32 (subnormals included).
fn exponent(x: f32) -> i32 {
    let bits = x.to_bits() & 0x7FFF_FFFF;
    let e = (bits >> 23) as i32;
    if e == 0 {
        // Subnormal: 2^-149 · mantissa.
        let m = bits & 0x7F_FFFF;
        -149 + 31 - m.leading_zeros() as i32
    } else {
        e - 127
    }
}

/// `x · 2^frac` truncated toward zero (directions: a tiny negative component becomes 0,
/// not −1).
fn to_fixed_trunc(x: f32, frac: i32) -> Option<i128> {
    let mag = if frac >= 0 {
        f32_to_fixed_i128(x.abs(), frac as u32)?
    } else {
        f32_to_fixed_i128(x.abs(), 0)? >> (-frac).min(127)
    };
    Some(if x < 0.0 { -mag } else { mag })
}

/// Floor and ceiling of `(num << FRAC) / den` for `den ≠ 0`, as i128.
fn div_q(num: i128, den: i128) -> (i128, i128) {
    let n = num << FRAC;
    let q = n / den;
    let r = n % den;
    // Truncation is toward zero: adjust to floor / ceiling.
    let exact = r == 0;
    let neg = (n < 0) != (den < 0);
    let floor = if !exact && neg { q - 1 } else { q };
    let ceil = if !exact && !neg { q + 1 } else { q };
    (floor, ceil)
}

fn fits(v: i128) -> Option<i64> {
    i64::try_from(v).ok().filter(|x| x.unsigned_abs() < 1 << 62)
}

/// A ray parameter clamped into `[−NEVER, NEVER]`: a plane further than any representable
/// t (a direction component of a few raw units) is never reached.
fn sat(v: i128) -> i64 {
    v.clamp(-(NEVER as i128), NEVER as i128) as i64
}

/// Iterator over the voxels a ray crosses, in fixed point (module doc).
#[derive(Debug, Clone)]
pub struct FixedTraversal {
    walk: Walk<i64>,
    deltas: Deltas,
}

/// The per-axis increments of the walk and the scale of its parameter.
#[derive(Debug, Clone)]
struct Deltas {
    t_delta: [i64; 3],
    /// `t_world = t' · 2^-t_exp` with t' raw (Q31.32).
    t_exp: i32,
}

impl FixedTraversal {
    /// An empty walk.
    fn empty() -> Self {
        Self { walk: Walk::empty(0, NEVER), deltas: Deltas { t_delta: [0; 3], t_exp: 0 } }
    }

    /// Starts a walk of `ray` restricted to `[t_min, t_max]` (the same contract as
    /// [`Traversal::new`](super::Traversal::new): an invalid ray or grid, or a clip of zero length,
    /// gives an empty walk). `Err` when the ray does not fit the fixed-point format.
    pub fn new(grid: &GridDesc, ray: &Ray, t_min: f32, t_max: f32) -> Result<Self, DdaOverflow> {
        if !grid.is_valid() || !ray.is_valid() || t_min.is_nan() || t_max.is_nan() {
            return Ok(Self::empty());
        }
        let (min, max) = (grid.min.to_array(), grid.max.to_array());
        // Exact integer positions: units of 2^-fw.
        let e_max = min.iter().chain(max.iter()).filter(|c| **c != 0.0).map(|&c| exponent(c)).max().unwrap_or(0);
        let fw = 100 - e_max;
        let conv = |x: f32| -> Result<i128, DdaOverflow> {
            if fw >= 0 {
                f32_to_fixed_i128(x, fw as u32).ok_or(DdaOverflow)
            } else {
                f32_to_fixed_i128(x, 0).map(|v| v >> (-fw).min(127)).ok_or(DdaOverflow)
            }
        };
        let mut lo = [0i128; 3];
        let mut ext = [0i128; 3];
        for a in 0..3 {
            lo[a] = conv(min[a])?;
            ext[a] = conv(max[a])? - lo[a];
        }
        // Grid units: the largest extent spans [2^8, 2^9) units = [2^40, 2^41) raw.
        let ext_max = ext.iter().copied().max().unwrap_or(1).max(1);
        let msb = 127 - ext_max.leading_zeros() as i32;
        let shift = msb - (8 + FRAC as i32);
        let to_grid = |v: i128| if shift >= 0 { v >> shift } else { v << (-shift) };
        let o = ray.origin.to_array();
        let mut org = [0i64; 3];
        let mut ext_g = [0i64; 3];
        for a in 0..3 {
            let rel = conv(o[a])? - lo[a];
            if rel.unsigned_abs() >> 120 != 0 {
                return Err(DdaOverflow);
            }
            org[a] = fits(to_grid(rel)).ok_or(DdaOverflow)?;
            ext_g[a] = fits(to_grid(ext[a])).ok_or(DdaOverflow)?;
        }
        // Direction: scaled so that its largest component is in [1, 2) grid units per t'.
        // Grid units per world unit are 2^(fw − shift) raw, and d·2^(32 − L) with
        // L = ⌊log2 max|d|⌋ has its largest raw component in [2^32, 2^33): so
        // t' = t_world · 2^(fw − shift − 32 + L)... expressed through t_exp below.
        let d = ray.dir.to_array();
        let l = d.iter().filter(|c| **c != 0.0).map(|&c| exponent(c)).max().unwrap_or(0);
        let mut dir = [0i64; 3];
        for a in 0..3 {
            dir[a] = fits(to_fixed_trunc(d[a], 32 - l).ok_or(DdaOverflow)?).ok_or(DdaOverflow)?;
        }
        // A world direction d moves d·2^(fw − shift) raw per unit of world t; the normalised
        // one moves d·2^(32 − l) raw per unit of t'. So t' = t_world · 2^(fw − shift − 32 + l)
        // and t'_raw = t' · 2^32: t_world = t'_raw · 2^-(fw − shift + l).
        let t_exp = fw - shift + l;
        let world_to_raw = |t: f32| -> Result<i64, DdaOverflow> {
            if t == f32::INFINITY {
                return Ok(NEVER);
            }
            if t == f32::NEG_INFINITY {
                return Ok(-NEVER);
            }
            let v = if t_exp >= 0 {
                f32_to_fixed_i128(t, t_exp as u32)
            } else {
                f32_to_fixed_i128(t, 0).map(|v| v >> (-t_exp).min(127))
            };
            // Beyond the format: clamp (a bound further than any walk).
            Ok(v.map_or(if t > 0.0 { NEVER } else { -NEVER }, |v| {
                i64::try_from(v).unwrap_or(if v > 0 { NEVER } else { -NEVER })
            }))
        };
        let (mut t0, mut t1) = (world_to_raw(t_min)?, world_to_raw(t_max)?);
        // Slab clip against [0, ext_g] per axis; entry rounded down, exit up.
        for a in 0..3 {
            if dir[a] == 0 {
                if org[a] < 0 || org[a] > ext_g[a] {
                    return Ok(Self::empty());
                }
                continue;
            }
            let (n0, n1) = div_q(-(org[a] as i128), dir[a] as i128);
            let (f0, f1) = div_q((ext_g[a] - org[a]) as i128, dir[a] as i128);
            let (near, far) = if dir[a] > 0 { (n0, f1) } else { (f0, n1) };
            let (near, far) = (sat(near), sat(far));
            t0 = t0.max(near);
            t1 = t1.min(far);
            if t0 > t1 {
                return Ok(Self::empty());
            }
        }
        if t1 <= t0 || t0 == NEVER || t0 == -NEVER {
            return Ok(Self::empty());
        }
        let mut tr = Self { walk: Walk::on_grid(grid.dims, 0, NEVER), deltas: Deltas { t_delta: [0; 3], t_exp } };
        for a in 0..3 {
            let n = grid.dims[a] as i32;
            tr.walk.dims[a] = n;
            let cell_size = ext_g[a] / n as i64;
            // Entry point, floor + clamp into the grid.
            let entry = org[a] as i128 + ((t0 as i128 * dir[a] as i128) >> FRAC);
            let c = if entry <= 0 { 0 } else { (entry / cell_size.max(1) as i128).min((n - 1) as i128) as i32 };
            tr.walk.cell[a] = c;
            if dir[a] == 0 {
                continue;
            }
            tr.walk.step[a] = if dir[a] > 0 { 1 } else { -1 };
            let k = if dir[a] > 0 { c + 1 } else { c };
            let plane = if k >= n { ext_g[a] } else { k as i64 * cell_size };
            let (fl, _) = div_q((plane - org[a]) as i128, dir[a] as i128);
            tr.walk.t_next[a] = sat(fl);
            let (dl, _) = div_q(cell_size as i128, (dir[a] as i128).abs());
            tr.deltas.t_delta[a] = sat(dl);
        }
        tr.walk.start(t0, t1, grid.dims);
        Ok(tr)
    }
}

impl Stepper for Deltas {
    type T = i64;

    #[inline]
    fn min(a: i64, b: i64) -> i64 {
        a.min(b)
    }

    #[inline]
    fn max(a: i64, b: i64) -> i64 {
        a.max(b)
    }

    /// One `t_delta` further (the incremental form); saturates at "never".
    #[inline]
    fn next_crossing(&self, walk: &Walk<i64>, a: usize) -> i64 {
        walk.t_next[a].saturating_add(self.t_delta[a])
    }

    #[inline]
    fn world(&self, t: i64) -> f32 {
        if t == NEVER {
            return f32::INFINITY;
        }
        fixed_to_f32(t as i128, self.t_exp)
    }
}

impl Iterator for FixedTraversal {
    type Item = VoxelStep;

    #[inline]
    fn next(&mut self) -> Option<VoxelStep> {
        self.walk.next(&self.deltas)
    }
}
