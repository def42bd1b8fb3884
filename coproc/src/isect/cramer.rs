//! GridRT's PE kernel: Cramer's rule on the barycentric system.
//!
//! Source: P. Shirley, *Fundamentals of Computer Graphics* §4.4.2 / "Realistic Ray Tracing"
//! (the formulation GridRT's PE program implements, Nery 2010, eqs. 2.8–2.11):
//!
//! ```text
//! | ax−bx  ax−cx  dx | |β|   |ax−ox|
//! | ay−by  ay−cy  dy | |γ| = |ay−oy|     β = |A_β|/|A|, γ = |A_γ|/|A|, t = |A_t|/|A|
//! | az−bz  az−cz  dz | |t|   |az−oz|
//! ```
//!
//! with Shirley's names a..l for the matrix entries (a = ax−bx, d = ax−cx, g = dx,
//! j = ax−ox, …), one reciprocal of |A| (the PE's only `divfp`, instr. 87) and the PE
//! program's early exits in its order: β < 0, γ < 0, β + γ > 1, t < 0, t > best.
//!
//! Fixes over the PE program (GridRT's robustness notes):
//! - the 2×2 cofactors use Kahan's `difference_of_products` (1.5 ulp) instead of `x·y − z·w`;
//! - det ≈ 0 is rejected when |det| cannot be told from zero: |det| ≤ γ(4)·Σ|aᵢ·Cᵢ| (the
//!   rounding bound of the cofactor expansion), so a ray parallel to the plane or a degenerate
//!   triangle never divides by a noise-level determinant; the PE divided by 0 and its
//!   subtraction-based compare then treated NaN as "equal";
//! - NaN never passes a test (every comparison is written so NaN rejects);
//! - inclusive edges (β ≥ 0, γ ≥ 0, β + γ ≤ 1) and a strict `t > 0`.
//!
//! Storage: the 9 vertex words (36 B; the PE stored exactly these 9 words per triangle,
//! 288 bits). f32 reads them from the scene image, fixed point from the load-time table.
//!
//! Cost of one full f32 test ([`CramerRule::OPS_F32`]). The PE program has 57 FP instructions
//! (24 add/sub, 27 mul, 5 cmp, 1 div; `timing::gridrt_pe`); the robustness fixes add Kahan's
//! error terms and the det tolerance: entries (add 9), cofactors (3 × DifferenceOfProducts:
//! mul 9, add 9), det (mul 3, add 2), tolerance (mul 1, add 2, cmp 1), reciprocal (div 1,
//! cmp 1), β (mul 4, add 2, cmp 1), γ cofactors (mul 9, add 9), γ (mul 4, add 2, cmp 1),
//! β + γ (add 1, cmp 1), t (mul 4, add 2, cmp 2) → add 38, mul 34, div 1, cmp 7.
//!
//! # Fixed point ([`CramerFx`], [`CramerRule::OPS_FIXED`])
//!
//! The PE program's arithmetic in checked fixed point: plain rounded products (no Kahan
//! term: a fixed-point difference of two rounded products is already exact to one rounding
//! each), det tested for exactly zero, numerators tested against the sign-normalised det
//! (β ≥ 0, γ ≥ 0, β + γ ≤ det, 0 < t ≤ bound·det), one division for t. Cost: entries (add 9),
//! cofactors (mul 6, add 3), det (mul 3, add 2, cmp 2), β (mul 3, add 2, cmp 1), γ cofactors
//! (mul 6, add 3), γ (mul 3, add 2, cmp 1), β + γ (add 1, cmp 1), t (mul 3, add 2, cmp 1),
//! range (mul 1, cmp 1), division (div 1) → add 24, mul 25, div 1, cmp 7.

use super::kernel::{KernelKind, Triangle};
use super::vertex::{F32Vertices, FxVertices, VertexTest};
use crate::numeric::{beyond, FixedFormat, Fx, Fx3, FxRay, OpCount, Overflow};
use gridrt_shared::math::{difference_of_products, gamma, Ray};

/// Rounding bound of the 3-term cofactor expansion, evaluated at compile time.
const GAMMA4: f32 = gamma(4);

/// GridRT's PE test, Cramer's rule on the vertex record (module doc).
#[derive(Debug, Clone, Copy)]
pub struct CramerRule;

/// The Cramer's-rule kernel of GridRT's PE, in f32.
pub type Cramer = F32Vertices<CramerRule>;

/// The PE program's Cramer test in fixed point (module doc).
pub type CramerFx<Q> = FxVertices<CramerRule, Q>;

impl VertexTest for CramerRule {
    const KIND: KernelKind = KernelKind::Cramer;
    const OPS_F32: OpCount = OpCount { add: 38, mul: 34, div: 1, cmp: 7 };
    const OPS_FIXED: OpCount = OpCount { add: 24, mul: 25, div: 1, cmp: 7 };

    #[inline(always)]
    fn test_f32(r: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32> {
        let [va, vb, vc] = *tri;
        // Shirley's matrix entries (PE instr. 58–66).
        let (a, b, c) = (va.x - vb.x, va.y - vb.y, va.z - vb.z);
        let (d, e, f) = (va.x - vc.x, va.y - vc.y, va.z - vc.z);
        let (g, h, i) = (r.dir.x, r.dir.y, r.dir.z);
        let (j, k, l) = (va.x - r.origin.x, va.y - r.origin.y, va.z - r.origin.z);
        // Cofactors (PE instr. 67–81).
        let ei_hf = difference_of_products(e, i, h, f);
        let gf_di = difference_of_products(g, f, d, i);
        let dh_eg = difference_of_products(d, h, e, g);
        // |A| (PE instr. 82–86) with its rounding-level tolerance.
        let (m0, m1, m2) = (a * ei_hf, b * gf_di, c * dh_eg);
        let det = m0 + m1 + m2;
        if !(det.abs() > GAMMA4 * (m0.abs() + m1.abs() + m2.abs())) {
            return None;
        }
        let inv = 1.0 / det; // PE instr. 87: the only divide
        if !inv.is_finite() {
            return None;
        }
        // β (PE instr. 88–95).
        let beta = (j * ei_hf + k * gf_di + l * dh_eg) * inv;
        if !(beta >= 0.0) {
            return None;
        }
        // γ (PE instr. 96–106).
        let ak_jb = difference_of_products(a, k, j, b);
        let jc_al = difference_of_products(j, c, a, l);
        let bl_kc = difference_of_products(b, l, k, c);
        let gam = (i * ak_jb + h * jc_al + g * bl_kc) * inv;
        if !(gam >= 0.0 && beta + gam <= 1.0) {
            return None;
        }
        // t (PE instr. 110–119).
        let t = -(f * ak_jb + e * jc_al + d * bl_kc) * inv;
        if !(t > 0.0) || t > t_bound || t == f32::INFINITY {
            return None;
        }
        Some(t)
    }

    #[inline]
    fn test_fx<Q: FixedFormat>(r: &FxRay<Q>, [va, vb, vc]: [Fx3<Q>; 3], t_bound: f32) -> Result<Option<f32>, Overflow> {
        // Shirley's matrix entries.
        let (a, b, c) = (va[0] - vb[0], va[1] - vb[1], va[2] - vb[2]);
        let (d, e, f) = (va[0] - vc[0], va[1] - vc[1], va[2] - vc[2]);
        let (g, h, i) = (r.d[0], r.d[1], r.d[2]);
        let (j, k, l) = (va[0] - r.o[0], va[1] - r.o[1], va[2] - r.o[2]);
        // Cofactors and |A|, sign-normalised to |A| > 0.
        let ei_hf = e * i - h * f;
        let gf_di = g * f - d * i;
        let dh_eg = d * h - e * g;
        let det = (a * ei_hf + b * gf_di + c * dh_eg).ok()?;
        if det.is_zero() {
            return Ok(None);
        }
        let neg = det.is_neg();
        let sgn = |x: Fx<Q>| if neg { -x } else { x };
        let det = sgn(det);
        let beta = sgn(j * ei_hf + k * gf_di + l * dh_eg).ok()?;
        if beta.is_neg() {
            return Ok(None);
        }
        let ak_jb = a * k - j * b;
        let jc_al = j * c - a * l;
        let bl_kc = b * l - k * c;
        let gam = sgn(i * ak_jb + h * jc_al + g * bl_kc).ok()?;
        if gam.is_neg() || (beta + gam).ok()? > det {
            return Ok(None);
        }
        let t_num = sgn(-(f * ak_jb + e * jc_al + d * bl_kc)).ok()?;
        if !t_num.is_pos() || beyond(t_num, det, r.bound(t_bound)) {
            return Ok(None);
        }
        let t = (t_num / det).ok()?;
        if !t.is_pos() {
            return Ok(None);
        }
        Ok(r.world_t(t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::math::Vec3;

    /// The PE divided by an exactly zero |A| (ray parallel to the plane): 1/0 = ∞, β = 0·∞ =
    /// NaN, and its subtraction-based compare treated NaN as "equal", so garbage could pass.
    #[test]
    fn cramer_rejects_zero_determinant_of_parallel_ray() {
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let ray = Ray { origin: Vec3::new(0.2, 0.2, 1e-30), dir: Vec3::new(1.0, 0.0, 0.0) };
        assert_eq!(CramerRule::test_f32(&ray, &tri, f32::INFINITY), None);
    }

    /// No absolute epsilon: a 10⁻⁴-sized triangle far from the origin is still hit (an
    /// absolute |det| < 10⁻⁶ test, as in the MT paper, would drop it).
    #[test]
    fn cramer_hits_tiny_triangle_far_away() {
        let s = 1e-4;
        let c = Vec3::new(100.0, 50.0, 30.0);
        let tri = [c, c + Vec3::new(s, 0.0, 0.0), c + Vec3::new(0.0, s, 0.0)];
        let target = c + Vec3::new(s * 0.25, s * 0.25, 0.0);
        let ray = Ray { origin: Vec3::new(0.0, 0.0, -10.0), dir: target - Vec3::new(0.0, 0.0, -10.0) };
        let t = CramerRule::test_f32(&ray, &tri, f32::INFINITY);
        assert!(t.is_some_and(|t| (t - 1.0).abs() < 1e-5), "{t:?}");
    }
}
