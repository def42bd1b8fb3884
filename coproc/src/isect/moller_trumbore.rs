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
//! shared edge may miss both triangles by rounding (Andrade Guerra 2020 compares this trade-off).
//!
//! Storage: the 9 vertex words (36 B; "minimum storage" is the paper's point). f32 reads
//! them from the scene image, fixed point from the load-time table.
//!
//! Cost of one full f32 test ([`MollerTrumboreRule::OPS_F32`]): edges (add 6), P (mul 6, add 3),
//! det (mul 3, add 2, cmp 1), reciprocal (div 1, cmp 1 finite), s (add 3), u (mul 4, add 2,
//! cmp 2), Q (mul 6, add 3), v (mul 4, add 2, cmp 1), u + v (add 1, cmp 1), t (mul 4, add 2,
//! cmp 2) → add 24, mul 27, div 1, cmp 8.
//!
//! # Fixed point ([`MollerTrumboreFx`], [`MollerTrumboreRule::OPS_FIXED`])
//!
//! Seed 002 found the reciprocal of det "the most problematic part" of a fixed-point MT and
//! kept it in f32. Here the division is deferred instead: the signs and ranges of the
//! numerators are tested against det (sign-normalised so det > 0: 0 ≤ u·det ≤ det,
//! v·det ≥ 0, (u + v)·det ≤ det, t·det > 0 and t·det ≤ bound·det), and the only division is
//! t = t_num / det for a hit, in the fixed-point format itself (no float anywhere).
//! Cost: edges (add 6), T (add 3), P (mul 6, add 3), det (mul 3, add 2, cmp 2), u_num (mul 3,
//! add 2, cmp 2), Q (mul 6, add 3), v_num (mul 3, add 2, cmp 1), u + v (add 1, cmp 1), t_num
//! (mul 3, add 2, cmp 1), range (mul 1, cmp 1), division (div 1) → add 24, mul 25, div 1, cmp 8.

use super::kernel::{KernelKind, Triangle};
use super::vertex::{F32Vertices, FxVertices, VertexTest};
use crate::numeric::{beyond, fx_cross, fx_dot, fx_sub, FixedFormat, Fx, Fx3, FxRay, OpCount, Overflow};
use gridrt_shared::math::Ray;

/// The Möller–Trumbore test on the vertex record (module doc).
#[derive(Debug, Clone, Copy)]
pub struct MollerTrumboreRule;

/// The Möller–Trumbore kernel in f32.
pub type MollerTrumbore = F32Vertices<MollerTrumboreRule>;

/// Möller–Trumbore in fixed point with the division deferred (module doc).
pub type MollerTrumboreFx<Q> = FxVertices<MollerTrumboreRule, Q>;

impl VertexTest for MollerTrumboreRule {
    const KIND: KernelKind = KernelKind::MollerTrumbore;
    const OPS_F32: OpCount = OpCount { add: 24, mul: 27, div: 1, cmp: 8 };
    const OPS_FIXED: OpCount = OpCount { add: 24, mul: 25, div: 1, cmp: 8 };

    #[inline(always)]
    fn test_f32(r: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32> {
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
        if !(t > 0.0) || t > t_bound || t == f32::INFINITY {
            return None;
        }
        Some(t)
    }

    #[inline]
    fn test_fx<Q: FixedFormat>(r: &FxRay<Q>, [a, b, c]: [Fx3<Q>; 3], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let e1 = fx_sub(b, a);
        let e2 = fx_sub(c, a);
        let p = fx_cross(r.d, e2);
        let mut det = fx_dot(e1, p).ok()?;
        if det.is_zero() {
            return Ok(None);
        }
        // Sign-normalise so det > 0; every numerator is negated with it.
        let neg = det.is_neg();
        let sgn = |x: Fx<Q>| if neg { -x } else { x };
        det = sgn(det);
        let s = fx_sub(r.o, a);
        let u = sgn(fx_dot(s, p)).ok()?;
        if u.is_neg() || u > det {
            return Ok(None);
        }
        let q = fx_cross(s, e1);
        let v = sgn(fx_dot(r.d, q)).ok()?;
        if v.is_neg() || (u + v).ok()? > det {
            return Ok(None);
        }
        let t_num = sgn(fx_dot(e2, q)).ok()?;
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
