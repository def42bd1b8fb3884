//! Hanika and Keller's projection test, designed for fixed point.
//!
//! Source: J. Hanika, A. Keller, "Towards Hardware Ray Tracing using Fixed Point Arithmetic",
//! IEEE Symposium on Interactive Ray Tracing 2007 (and Hanika's Ulm diploma thesis 2007);
//! formulas as in seed 002 §1.4 (eqs. 40–44). Like Wald's test it intersects the plane
//! first and decides inside/outside in the projection that drops the normal's dominant
//! axis r, but the hit point is taken *relative to V0* and the edges are pre-divided by
//! `N_r`, so no precomputed value carries an absolute position except V0 itself:
//!
//! ```text
//! n_s = N_s/N_r, n_q = N_q/N_r, d' = v0r + v0s·n_s + v0q·n_q        (eqs. 40–41)
//! e'_ik = (v_ik − v0k)/N_r,  i ∈ {1, 2}, k ∈ {s, q}                 (eq. 42)
//! t = (d' − o_r − n_s·o_s − n_q·o_q) / (d_r + n_s·d_s + n_q·d_q)
//! h_s = o_s + t·d_s − v0s,  h_q = o_q + t·d_q − v0q                 (eq. 43)
//! γ = e'_1s·h_q − e'_1q·h_s,  β = e'_2q·h_s − e'_2s·h_q              (eq. 44; hit iff β, γ ≥ 0, β+γ ≤ 1)
//! ```
//!
//! (Seed 002 labels eq. 44's results u and v the other way round; the inside test is
//! symmetric.) Record (10 words = 40 B, the paper's struct): `[r, d', n_s, n_q, v0s, v0q,
//! e'_1s, e'_1q, e'_2s, e'_2q]`; axis word 3 = degenerate, 4 = fixed-point storage overflow.
//! Coefficients are computed in f64 from the f32 vertices and rounded once to the format.
//!
//! Deviation: the paper's hardware shifts the edges by an extra exponent E and uses
//! format-specific widths per variable; here every value uses the format's one Q layout
//! (`crate::numeric`), which is what the bench compares.
//!
//! Cost of one full f32 test ([`HanikaKeller::OPS`]): den (mul 2, add 2, cmp 1), numerator
//! (mul 2, add 3), t (div 1, cmp 2), h (mul 2, add 4), γ (mul 2, add 1, cmp 1), β (mul 2,
//! add 1, cmp 1), β + γ (add 1, cmp 1) → add 12, mul 10, div 1, cmp 6. Fixed point
//! ([`HanikaKellerFx`]): range test before the division (add 12, mul 11, div 1, cmp 8).

use core::marker::PhantomData;

use super::{Kernel, KernelKind, RecordStatus, Triangle, AXIS_DEGENERATE, AXIS_OVERFLOW};
use crate::numeric::{beyond, FixedFormat, FixedFrame, Fx, FxRay, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::Ray;

/// Record words.
const WORDS: usize = 10;

/// The record's values in f64: axis and `[d', n_s, n_q, v0s, v0q, e'1s, e'1q, e'2s, e'2q]`.
fn coefficients(v: [[f64; 3]; 3]) -> Option<(usize, [f64; 9])> {
    let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
    let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let r = if n[0].abs() >= n[1].abs() && n[0].abs() >= n[2].abs() {
        0
    } else if n[1].abs() >= n[2].abs() {
        1
    } else {
        2
    };
    let (s, q) = ((r + 1) % 3, (r + 2) % 3);
    let nr = n[r];
    if !(nr != 0.0 && nr.is_finite()) {
        return None;
    }
    let (ns, nq) = (n[s] / nr, n[q] / nr);
    let p = v[0];
    let dd = p[r] + p[s] * ns + p[q] * nq;
    Some((r, [dd, ns, nq, p[s], p[q], e1[s] / nr, e1[q] / nr, e2[s] / nr, e2[q] / nr]))
}

#[inline(always)]
fn axes(r: u32) -> Option<(usize, usize, usize)> {
    match r {
        0 => Some((0, 1, 2)),
        1 => Some((1, 2, 0)),
        2 => Some((2, 0, 1)),
        _ => None,
    }
}

/// Hanika–Keller in f32.
#[derive(Debug, Clone, Copy)]
pub struct HanikaKeller;

/// Per-ray data: origin and direction as arrays.
#[derive(Debug, Clone, Copy)]
pub struct HkRay {
    o: [f32; 3],
    d: [f32; 3],
}

impl Kernel for HanikaKeller {
    const KIND: KernelKind = KernelKind::HanikaKeller;
    const FORMAT: NumberFormat = NumberFormat::F32;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = false;
    const OPS: OpCount = OpCount { add: 12, mul: 10, div: 1, cmp: 6 };
    type RayData = HkRay;

    #[inline]
    fn prepare(ray: &Ray, _frame: &FixedFrame) -> Result<HkRay, Overflow> {
        Ok(HkRay { o: ray.origin.to_array(), d: ray.dir.to_array() })
    }

    fn precompute(tri: &Triangle, _frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        let v = tri.map(|p| p.to_array().map(|c| c as f64));
        let mut words = [0u32; WORDS];
        let status = match coefficients(v) {
            Some((r, vals)) if vals.iter().all(|x| (*x as f32).is_finite()) => {
                words[0] = r as u32;
                for (w, x) in words[1..].iter_mut().zip(vals) {
                    *w = (x as f32).to_bits();
                }
                RecordStatus::Ok
            }
            _ => {
                words[0] = AXIS_DEGENERATE;
                RecordStatus::Degenerate
            }
        };
        for (o, w) in out.iter_mut().zip(words) {
            *o = w;
        }
        status
    }

    #[inline]
    fn intersect(ray: &HkRay, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(w) = rec.get(..WORDS).and_then(|w| <&[u32; WORDS]>::try_from(w).ok()) else { return Ok(None) };
        let Some((r, s, q)) = axes(w[0]) else { return Ok(None) };
        let f = |i: usize| f32::from_bits(w[i]);
        let (dd, ns, nq) = (f(1), f(2), f(3));
        let (o, d) = (&ray.o, &ray.d);
        let den = d[r] + ns * d[s] + nq * d[q];
        if den == 0.0 {
            return Ok(None);
        }
        let t = (dd - o[r] - ns * o[s] - nq * o[q]) / den;
        if !(t > 0.0) || t > t_bound || t == f32::INFINITY {
            return Ok(None);
        }
        // Hit point relative to V0 (eq. 43), barycentrics with pre-divided edges (eq. 44).
        let hs = o[s] + t * d[s] - f(4);
        let hq = o[q] + t * d[q] - f(5);
        let gamma = f(6) * hq - f(7) * hs;
        let beta = f(9) * hs - f(8) * hq;
        if !(beta >= 0.0 && gamma >= 0.0 && beta + gamma <= 1.0) {
            return Ok(None);
        }
        Ok(Some(t))
    }
}

/// Hanika–Keller in fixed point (frame coordinates, checked arithmetic).
#[derive(Debug, Clone, Copy)]
pub struct HanikaKellerFx<Q>(PhantomData<Q>);

impl<Q: FixedFormat> Kernel for HanikaKellerFx<Q> {
    const KIND: KernelKind = KernelKind::HanikaKeller;
    const FORMAT: NumberFormat = Q::FORMAT;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = false;
    const OPS: OpCount = OpCount { add: 12, mul: 11, div: 1, cmp: 8 };
    type RayData = FxRay<Q>;

    #[inline]
    fn prepare(ray: &Ray, frame: &FixedFrame) -> Result<FxRay<Q>, Overflow> {
        FxRay::new(frame, ray.origin.to_array(), ray.dir.to_array())
    }

    fn precompute(tri: &Triangle, frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        let v = tri.map(|p| frame.point(p.to_array()));
        let mut words = [0u32; WORDS];
        let status = match coefficients(v) {
            None => {
                words[0] = AXIS_DEGENERATE;
                RecordStatus::Degenerate
            }
            Some((r, vals)) => {
                words[0] = r as u32;
                let mut status = RecordStatus::Ok;
                for (w, x) in words[1..].iter_mut().zip(vals) {
                    match Fx::<Q>::from_f64(x).to_word() {
                        Ok(x) => *w = x,
                        Err(Overflow) => status = RecordStatus::Overflow,
                    }
                }
                if status == RecordStatus::Overflow {
                    words[0] = AXIS_OVERFLOW;
                }
                status
            }
        };
        for (o, w) in out.iter_mut().zip(words) {
            *o = w;
        }
        status
    }

    #[inline]
    fn intersect(ray: &FxRay<Q>, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(w) = rec.get(..WORDS).and_then(|w| <&[u32; WORDS]>::try_from(w).ok()) else { return Ok(None) };
        let Some((r, s, q)) = axes(w[0]) else {
            return if w[0] == AXIS_OVERFLOW { Err(Overflow) } else { Ok(None) };
        };
        let f = |i: usize| Fx::<Q>::from_word(w[i]);
        let (dd, ns, nq) = (f(1), f(2), f(3));
        let (o, d) = (&ray.o, &ray.d);
        let den = (d[r] + ns * d[s] + nq * d[q]).ok()?;
        if den.is_zero() {
            return Ok(None);
        }
        let num = (dd - o[r] - ns * o[s] - nq * o[q]).ok()?;
        let (num, den) = if den.is_neg() { (-num, -den) } else { (num, den) };
        if !num.is_pos() || beyond(num, den, ray.bound(t_bound)) {
            return Ok(None);
        }
        let t = (num / den).ok()?;
        if !t.is_pos() {
            return Ok(None);
        }
        let hs = o[s] + t * d[s] - f(4);
        let hq = o[q] + t * d[q] - f(5);
        let gamma = (f(6) * hq - f(7) * hs).ok()?;
        let beta = (f(9) * hs - f(8) * hq).ok()?;
        if beta.is_neg() || gamma.is_neg() || (beta + gamma).ok()? > Fx::ONE {
            return Ok(None);
        }
        Ok(ray.world_t(t))
    }
}
