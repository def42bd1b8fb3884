//! Wald's projection test with precomputed per-triangle data ("TriAccel").
//!
//! Source: I. Wald, *Realtime Ray Tracing and Interactive Global Illumination*, PhD thesis,
//! Saarland University 2004, §7.1 "Fast Triangle Intersection in RTRT" (after Badouel,
//! "An Efficient Ray-Polygon Intersection", Graphics Gems 1990); formulas as reconstructed in
//! the ray–triangle study (Andrade Guerra 2020). Intersect the ray with the plane first, then test the hit
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
//! Record (10 words = 40 B, a projection record of `super::projection`): `[r, n_s, n_q, n_d,
//! k_us, k_uq, k_ud, k_vs, k_vq, k_vd]`. Wald's own layout pads this to 48 B for alignment; a
//! PE memory has no cache lines, so we do not.
//!
//! Numerics: the plane constant `n_d` and `k_ud`, `k_vd` carry absolute positions, so their
//! rounding grows with the distance from the world origin (the translation stress test shows
//! it); `k_*` grow like 1/edge for small triangles, which is Wald's weak point in fixed point.
//! Not watertight: neighbours may project along different axes.
//!
//! Cost of one full f32 test ([`WaldRule::OPS_F32`]): den (mul 2, add 2, cmp 1), numerator (mul 2,
//! add 3), t (div 1, cmp 2), h (mul 2, add 2), β (mul 2, add 2, cmp 1), γ (mul 2, add 2,
//! cmp 1), β + γ (add 1, cmp 1) → add 12, mul 10, div 1, cmp 6.
//! Fixed point ([`WaldFx`], [`WaldRule::OPS_FIXED`]): the same, with the t range test done
//! before the division on the sign-normalised numerator (add 12, mul 11, div 1, cmp 8).

use super::kernel::KernelKind;
use super::projection::{F32Projection, FxProjection, Projection, ProjectionRay, ProjectionTest, WORDS};
use crate::numeric::{FixedFormat, Fx, FxRay, OpCount, Overflow};

/// Wald's test on the projection record (module doc).
#[derive(Debug, Clone, Copy)]
pub struct WaldRule;

/// Wald's kernel in f32.
pub type Wald = F32Projection<WaldRule>;

/// Wald's kernel in fixed point (frame coordinates, checked arithmetic).
pub type WaldFx<Q> = FxProjection<WaldRule, Q>;

impl ProjectionTest for WaldRule {
    const KIND: KernelKind = KernelKind::Wald;
    const OPS_F32: OpCount = OpCount { add: 12, mul: 10, div: 1, cmp: 6 };
    const OPS_FIXED: OpCount = OpCount { add: 12, mul: 11, div: 1, cmp: 8 };
    const PLANE: [usize; 3] = [1, 2, 3];

    /// `[n_s, n_q, n_d, k_us, k_uq, k_ud, k_vs, k_vq, k_vd]`.
    fn coefficients(p: &Projection, v: [[f64; 3]; 3]) -> [f64; 9] {
        let Projection { r, s, q, e1, e2, nr, ns, nq } = *p;
        let nd = v[0][r] + ns * v[0][s] + nq * v[0][q];
        let p = v[0];
        [
            ns,
            nq,
            nd,
            e2[q] / nr,
            -e2[s] / nr,
            (e2[s] * p[q] - e2[q] * p[s]) / nr,
            -e1[q] / nr,
            e1[s] / nr,
            (e1[q] * p[s] - e1[s] * p[q]) / nr,
        ]
    }

    #[inline(always)]
    fn inside_f32(ray: &ProjectionRay, (_, s, q): (usize, usize, usize), w: &[u32; WORDS], t: f32) -> bool {
        let f = |i: usize| f32::from_bits(w[i]);
        let (o, d) = (&ray.o, &ray.d);
        // Barycentrics of the projected hit point (eqs. 36–39).
        let hs = o[s] + t * d[s];
        let hq = o[q] + t * d[q];
        let beta = hs * f(4) + hq * f(5) + f(6);
        if !(beta >= 0.0) {
            return false;
        }
        let gamma = hs * f(7) + hq * f(8) + f(9);
        gamma >= 0.0 && beta + gamma <= 1.0
    }

    #[inline(always)]
    fn inside_fx<Q: FixedFormat>(
        ray: &FxRay<Q>,
        (_, s, q): (usize, usize, usize),
        w: &[u32; WORDS],
        t: Fx<Q>,
    ) -> Result<bool, Overflow> {
        let f = |i: usize| Fx::<Q>::from_word(w[i]);
        let (o, d) = (&ray.o, &ray.d);
        let hs = o[s] + t * d[s];
        let hq = o[q] + t * d[q];
        let beta = (hs * f(4) + hq * f(5) + f(6)).ok()?;
        if beta.is_neg() {
            return Ok(false);
        }
        let gamma = (hs * f(7) + hq * f(8) + f(9)).ok()?;
        Ok(!(gamma.is_neg() || (beta + gamma).ok()? > Fx::ONE))
    }
}
