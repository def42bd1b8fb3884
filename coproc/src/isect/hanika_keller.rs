//! Hanika and Keller's projection test, designed for fixed point.
//!
//! Source: J. Hanika, A. Keller, "Towards Hardware Ray Tracing using Fixed Point Arithmetic",
//! IEEE Symposium on Interactive Ray Tracing 2007 (and Hanika's Ulm diploma thesis 2007);
//! formulas as in the ray–triangle study (Andrade Guerra 2020). Like Wald's test it intersects the plane
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
//! symmetric.) Record (10 words = 40 B, the paper's struct, a projection record of
//! `super::projection`): `[r, d', n_s, n_q, v0s, v0q, e'_1s, e'_1q, e'_2s, e'_2q]`.
//!
//! Deviation: the paper's hardware shifts the edges by an extra exponent E and uses
//! format-specific widths per variable; here every value uses the format's one Q layout
//! (`crate::numeric`), which is what the bench compares.
//!
//! Cost of one full f32 test ([`HanikaKellerRule::OPS_F32`]): den (mul 2, add 2, cmp 1),
//! numerator (mul 2, add 3), t (div 1, cmp 2), h (mul 2, add 4), γ (mul 2, add 1, cmp 1),
//! β (mul 2, add 1, cmp 1), β + γ (add 1, cmp 1) → add 12, mul 10, div 1, cmp 6. Fixed point
//! ([`HanikaKellerFx`], [`HanikaKellerRule::OPS_FIXED`]): range test before the division
//! (add 12, mul 11, div 1, cmp 8).

use super::kernel::KernelKind;
use super::projection::{F32Projection, FxProjection, Projection, ProjectionRay, ProjectionTest, WORDS};
use crate::numeric::{FixedFormat, Fx, FxRay, OpCount, Overflow};

/// Hanika and Keller's test on the projection record (module doc).
#[derive(Debug, Clone, Copy)]
pub struct HanikaKellerRule;

/// Hanika–Keller in f32.
pub type HanikaKeller = F32Projection<HanikaKellerRule>;

/// Hanika–Keller in fixed point (frame coordinates, checked arithmetic).
pub type HanikaKellerFx<Q> = FxProjection<HanikaKellerRule, Q>;

impl ProjectionTest for HanikaKellerRule {
    const KIND: KernelKind = KernelKind::HanikaKeller;
    const OPS_F32: OpCount = OpCount { add: 12, mul: 10, div: 1, cmp: 6 };
    const OPS_FIXED: OpCount = OpCount { add: 12, mul: 11, div: 1, cmp: 8 };
    const PLANE: [usize; 3] = [2, 3, 1];

    /// `[d', n_s, n_q, v0s, v0q, e'1s, e'1q, e'2s, e'2q]`.
    fn coefficients(p: &Projection, v: [[f64; 3]; 3]) -> [f64; 9] {
        let Projection { r, s, q, e1, e2, nr, ns, nq } = *p;
        let p = v[0];
        let dd = p[r] + p[s] * ns + p[q] * nq;
        [dd, ns, nq, p[s], p[q], e1[s] / nr, e1[q] / nr, e2[s] / nr, e2[q] / nr]
    }

    #[inline(always)]
    fn inside_f32(ray: &ProjectionRay, (_, s, q): (usize, usize, usize), w: &[u32; WORDS], t: f32) -> bool {
        let f = |i: usize| f32::from_bits(w[i]);
        let (o, d) = (&ray.o, &ray.d);
        // Hit point relative to V0 (eq. 43), barycentrics with pre-divided edges (eq. 44).
        let hs = o[s] + t * d[s] - f(4);
        let hq = o[q] + t * d[q] - f(5);
        let gamma = f(6) * hq - f(7) * hs;
        let beta = f(9) * hs - f(8) * hq;
        beta >= 0.0 && gamma >= 0.0 && beta + gamma <= 1.0
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
        let hs = o[s] + t * d[s] - f(4);
        let hq = o[q] + t * d[q] - f(5);
        let gamma = (f(6) * hq - f(7) * hs).ok()?;
        let beta = (f(9) * hs - f(8) * hq).ok()?;
        Ok(!(beta.is_neg() || gamma.is_neg() || (beta + gamma).ok()? > Fx::ONE))
    }
}
