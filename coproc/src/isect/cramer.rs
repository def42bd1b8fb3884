//! GridRT's PE kernel: Cramer's rule on the barycentric system.
//!
//! Source: P. Shirley, *Fundamentals of Computer Graphics* §4.4.2 / "Realistic Ray Tracing"
//! (the formulation GridRT's PE program implements, seed 004 §2.4, eq. 2.8–2.11):
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
//! Fixes over the PE program (seed 004 §6.2 "Robustness"):
//! - the 2×2 cofactors use Kahan's `difference_of_products` (1.5 ulp) instead of `x·y − z·w`;
//! - det ≈ 0 is rejected when |det| cannot be told from zero: |det| ≤ γ(4)·Σ|aᵢ·Cᵢ| (the
//!   rounding bound of the cofactor expansion), so a ray parallel to the plane or a degenerate
//!   triangle never divides by a noise-level determinant; the PE divided by 0 and its
//!   subtraction-based compare then treated NaN as "equal";
//! - NaN never passes a test (every comparison is written so NaN rejects);
//! - inclusive edges (β ≥ 0, γ ≥ 0, β + γ ≤ 1) and a strict `t > 0`.
//!
//! Storage: the 9 vertex words of the PE image (the PE stored exactly these 9 words per
//! triangle, 288 bits). Cost of one full test: 57 FP instructions in the PE program
//! (24 add/sub, 27 mul, 5 cmp, 1 div; see `timing::gridrt_pe`) + 8 for the det tolerance → 65.

use super::{Kernel, KernelKind, Triangle};
use gridrt_shared::math::{difference_of_products, gamma, Ray, Vec3};

/// Rounding bound of the 3-term cofactor expansion, evaluated at compile time.
const GAMMA4: f32 = gamma(4);

/// The Cramer's-rule kernel of GridRT's PE.
#[derive(Debug, Clone, Copy)]
pub struct Cramer;

/// Per-ray data: origin (R26–R28) and direction (R29–R31).
#[derive(Debug, Clone, Copy)]
pub struct CramerRay {
    origin: Vec3,
    dir: Vec3,
}

impl Kernel for Cramer {
    const KIND: KernelKind = KernelKind::Cramer;
    const TRIANGLE_WORDS: usize = 9;
    const FLOPS_PER_TEST: u32 = 65;
    type RayData = CramerRay;

    #[inline]
    fn prepare(ray: &Ray) -> CramerRay {
        CramerRay { origin: ray.origin, dir: ray.dir }
    }

    #[inline]
    fn intersect(r: &CramerRay, tri: &Triangle, t_bound: f32) -> Option<f32> {
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
        if !(t > 0.0) || t > t_bound {
            return None;
        }
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The PE divided by an exactly zero |A| (ray parallel to the plane): 1/0 = ∞, β = 0·∞ =
    /// NaN, and its subtraction-based compare treated NaN as "equal", so garbage could pass.
    #[test]
    fn cramer_rejects_zero_determinant_of_parallel_ray() {
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let ray = Ray { origin: Vec3::new(0.2, 0.2, 1e-30), dir: Vec3::new(1.0, 0.0, 0.0) };
        assert_eq!(Cramer::intersect(&Cramer::prepare(&ray), &tri, f32::INFINITY), None);
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
        let t = Cramer::intersect(&Cramer::prepare(&ray), &tri, f32::INFINITY);
        assert!(t.is_some_and(|t| (t - 1.0).abs() < 1e-5), "{t:?}");
    }
}
