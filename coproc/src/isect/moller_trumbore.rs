//! Möller–Trumbore ray–triangle intersection.
//!
//! Source: T. Möller, B. Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection",
//! Journal of Graphics Tools 2(1), 1997, the non-culling branch: edges e1 = b − a,
//! e2 = c − a; P = d × e2; det = e1·P; u = (o − a)·P / det; Q = (o − a) × e1;
//! v = d·Q / det; t = e2·Q / det.
//!
//! Deviation from the paper: the paper rejects |det| < ε with an absolute ε = 10⁻⁶, which is
//! scale dependent (it drops every hit on triangles smaller than ~10⁻³ units). Here only an
//! exactly zero determinant (ray parallel to the plane, or a degenerate triangle) or a
//! non-finite reciprocal is rejected; the barycentric tests are inclusive (u ≥ 0, v ≥ 0,
//! u + v ≤ 1) and the kernel's lower bound is `t > 0`. Not watertight: a ray through a
//! shared edge may miss both triangles by rounding (seed 002 compares this trade-off).
//!
//! Storage: the 9 vertex words of the PE image. Cost of one full test: edges 6,
//! P 9, det 5, reciprocal 1, s 3, u 6, Q 9, v 6, t 6, compares 6 → 57.

use super::{Kernel, KernelKind, Triangle};
use gridrt_shared::math::{Ray, Vec3};

/// The Möller–Trumbore kernel.
#[derive(Debug, Clone, Copy)]
pub struct MollerTrumbore;

/// Per-ray data: origin and direction.
#[derive(Debug, Clone, Copy)]
pub struct MtRay {
    origin: Vec3,
    dir: Vec3,
}

impl Kernel for MollerTrumbore {
    const KIND: KernelKind = KernelKind::MollerTrumbore;
    const TRIANGLE_WORDS: usize = 9;
    const FLOPS_PER_TEST: u32 = 57;
    type RayData = MtRay;

    #[inline]
    fn prepare(ray: &Ray) -> MtRay {
        MtRay { origin: ray.origin, dir: ray.dir }
    }

    #[inline]
    fn intersect(r: &MtRay, tri: &Triangle, t_bound: f32) -> Option<f32> {
        let [a, b, c] = *tri;
        let e1 = b - a;
        let e2 = c - a;
        let p = r.dir.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv_det = 1.0 / det;
        if !inv_det.is_finite() {
            return None;
        }
        let s = r.origin - a;
        let u = s.dot(p) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = r.dir.dot(q) * inv_det;
        if !(v >= 0.0 && u + v <= 1.0) {
            return None;
        }
        let t = e2.dot(q) * inv_det;
        // `!(t > 0)` also rejects NaN.
        if !(t > 0.0) || t > t_bound {
            return None;
        }
        Some(t)
    }
}
