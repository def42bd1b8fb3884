//! Wald's projection test with precomputed per-triangle data ("TriAccel").
//!
//! Source: I. Wald, *Realtime Ray Tracing and Interactive Global Illumination*, PhD thesis,
//! Saarland University 2004, §7.1 "Fast Triangle Intersection in RTRT" (after Badouel,
//! "An Efficient Ray-Polygon Intersection", Graphics Gems 1990); formulas as reconstructed in
//! seed 002 §1.3 (eqs. 35–39). Intersect the ray with the plane first, then test the hit
//! point's barycentrics in the 2-D projection that drops the normal's dominant axis r:
//!
//! ```text
//! N = e1 × e2,  r = argmax |N_i|,  s = r+1, q = r+2 (mod 3, cyclic so that Δ = N_r)
//! n_s = N_s/N_r, n_q = N_q/N_r, n_d = V0·N/N_r                       (plane, n_r ≡ 1)
//! t = (n_d − o_r − n_s·o_s − n_q·o_q) / (d_r + n_s·d_s + n_q·d_q)
//! h_s = o_s + t·d_s,  h_q = o_q + t·d_q
//! β = k_us·h_s + k_uq·h_q + k_ud,  γ = k_vs·h_s + k_vq·h_q + k_vd       (hit iff β, γ ≥ 0, β+γ ≤ 1)
//! k_us = e2q/Δ, k_uq = −e2s/Δ, k_ud = (e2s·v0q − e2q·v0s)/Δ
//! k_vs = −e1q/Δ, k_vq = e1s/Δ, k_vd = (e1q·v0s − e1s·v0q)/Δ
//! ```
//!
//! Record (10 words = 40 B): `[r, n_s, n_q, n_d, k_us, k_uq, k_ud, k_vs, k_vq, k_vd]`. Wald's
//! own layout pads this to 48 B for alignment; a PE memory has no cache lines, so we do not.
//! The axis word is 3 for a degenerate triangle (N = 0, or a coefficient not finite in f32)
//! and 4 for a record whose values overflow the fixed-point storage. The coefficients are
//! computed in f64 from the f32 vertices and rounded once to the format.
//!
//! Numerics: the plane constant `n_d` and `k_ud`, `k_vd` carry absolute positions, so their
//! rounding grows with the distance from the world origin (the translation stress test shows
//! it); `k_*` grow like 1/edge for small triangles, which is Wald's weak point in fixed point.
//! Not watertight: neighbours may project along different axes.
//!
//! Cost of one full f32 test ([`Wald::OPS`]): den (mul 2, add 2, cmp 1), numerator (mul 2,
//! add 3), t (div 1, cmp 2), h (mul 2, add 2), β (mul 2, add 2, cmp 1), γ (mul 2, add 2,
//! cmp 1), β + γ (add 1, cmp 1) → add 12, mul 10, div 1, cmp 6.
//! Fixed point ([`WaldFx`]): the same, with the t range test done before the division on the
//! sign-normalised numerator (add 12, mul 11, div 1, cmp 8).

use core::marker::PhantomData;

use super::{Kernel, KernelKind, RecordStatus, Triangle, AXIS_DEGENERATE, AXIS_OVERFLOW};
use crate::numeric::{beyond, FixedFormat, FixedFrame, Fx, FxRay, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::Ray;

/// Record words.
const WORDS: usize = 10;

/// Wald's precomputed coefficients in f64 (before rounding to a format): axis and the nine
/// values of the record, or `None` for a degenerate triangle.
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
    let nd = v[0][r] + ns * v[0][s] + nq * v[0][q];
    let p = v[0];
    let vals = [
        ns,
        nq,
        nd,
        e2[q] / nr,
        -e2[s] / nr,
        (e2[s] * p[q] - e2[q] * p[s]) / nr,
        -e1[q] / nr,
        e1[s] / nr,
        (e1[q] * p[s] - e1[s] * p[q]) / nr,
    ];
    Some((r, vals))
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

/// Wald's kernel in f32.
#[derive(Debug, Clone, Copy)]
pub struct Wald;

/// Per-ray data: origin and direction as arrays (indexed by the record's axes).
#[derive(Debug, Clone, Copy)]
pub struct WaldRay {
    o: [f32; 3],
    d: [f32; 3],
}

impl Kernel for Wald {
    const KIND: KernelKind = KernelKind::Wald;
    const FORMAT: NumberFormat = NumberFormat::F32;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = false;
    const OPS: OpCount = OpCount { add: 12, mul: 10, div: 1, cmp: 6 };
    type RayData = WaldRay;

    #[inline]
    fn prepare(ray: &Ray, _frame: &FixedFrame) -> Result<WaldRay, Overflow> {
        Ok(WaldRay { o: ray.origin.to_array(), d: ray.dir.to_array() })
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
    fn intersect(ray: &WaldRay, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(w) = rec.get(..WORDS).and_then(|w| <&[u32; WORDS]>::try_from(w).ok()) else { return Ok(None) };
        let Some((r, s, q)) = axes(w[0]) else { return Ok(None) };
        let f = |i: usize| f32::from_bits(w[i]);
        let (ns, nq, nd) = (f(1), f(2), f(3));
        let (o, d) = (&ray.o, &ray.d);
        // Plane: distance along the ray (eq. 35).
        let den = d[r] + ns * d[s] + nq * d[q];
        if den == 0.0 {
            return Ok(None);
        }
        let t = (nd - o[r] - ns * o[s] - nq * o[q]) / den;
        // `!(t > 0)` also rejects NaN.
        if !(t > 0.0) || t > t_bound || t == f32::INFINITY {
            return Ok(None);
        }
        // Barycentrics of the projected hit point (eqs. 36–39).
        let hs = o[s] + t * d[s];
        let hq = o[q] + t * d[q];
        let beta = hs * f(4) + hq * f(5) + f(6);
        if !(beta >= 0.0) {
            return Ok(None);
        }
        let gamma = hs * f(7) + hq * f(8) + f(9);
        if !(gamma >= 0.0 && beta + gamma <= 1.0) {
            return Ok(None);
        }
        Ok(Some(t))
    }
}

/// Wald's kernel in fixed point (frame coordinates, checked arithmetic).
#[derive(Debug, Clone, Copy)]
pub struct WaldFx<Q>(PhantomData<Q>);

impl<Q: FixedFormat> Kernel for WaldFx<Q> {
    const KIND: KernelKind = KernelKind::Wald;
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
        let (ns, nq, nd) = (f(1), f(2), f(3));
        let (o, d) = (&ray.o, &ray.d);
        let den = (d[r] + ns * d[s] + nq * d[q]).ok()?;
        if den.is_zero() {
            return Ok(None);
        }
        let num = (nd - o[r] - ns * o[s] - nq * o[q]).ok()?;
        // Sign-normalise (den > 0) and cull the range before dividing.
        let (num, den) = if den.is_neg() { (-num, -den) } else { (num, den) };
        if !num.is_pos() || beyond(num, den, ray.bound(t_bound)) {
            return Ok(None);
        }
        let t = (num / den).ok()?;
        if !t.is_pos() {
            return Ok(None);
        }
        let hs = o[s] + t * d[s];
        let hq = o[q] + t * d[q];
        let beta = (hs * f(4) + hq * f(5) + f(6)).ok()?;
        if beta.is_neg() {
            return Ok(None);
        }
        let gamma = (hs * f(7) + hq * f(8) + f(9)).ok()?;
        if gamma.is_neg() || (beta + gamma).ok()? > Fx::ONE {
            return Ok(None);
        }
        Ok(ray.world_t(t))
    }
}
