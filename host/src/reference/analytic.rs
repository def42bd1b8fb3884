//! ViRAY's analytic primitives intersected in f64, with the f32 world→object maps the device
//! receives (widened), so both sides render the same geometry.

use gridrt_shared::scene::PrimKind;

use super::vec3::dot;
use crate::scene::transform::{apply_point, apply_transpose, apply_vector, Affine64};

/// One analytic primitive in f64.
pub(super) struct Prim {
    /// Shape.
    pub(super) kind: PrimKind,
    /// World → object map.
    pub(super) w2o: Affine64,
    /// Material index.
    pub(super) material: u32,
    /// Global primitive id.
    pub(super) id: u32,
}

fn quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    // a t² + 2 b t + c = 0
    if a == 0.0 {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let q = if b >= 0.0 { -(b + s) } else { -(b - s) };
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t0, t1) = (q / a, c / q);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

impl Prim {
    /// Nearest t > 0 and the object-space hit point.
    pub(super) fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<f64> {
        let o = apply_point(&self.w2o, o);
        let d = apply_vector(&self.w2o, d);
        let first = |r: Option<(f64, f64)>, ok: &dyn Fn(f64) -> bool| {
            r.and_then(|(a, b)| [a, b].into_iter().find(|&t| t > 0.0 && ok(t)))
        };
        match self.kind {
            PrimKind::Sphere => first(quadratic(dot(d, d), dot(o, d), dot(o, o) - 1.0), &|_| true),
            PrimKind::Cylinder => first(
                quadratic(d[0] * d[0] + d[2] * d[2], o[0] * d[0] + o[2] * d[2], o[0] * o[0] + o[2] * o[2] - 1.0),
                &|t| (o[1] + t * d[1]).abs() <= 1.0,
            ),
            PrimKind::Cone => {
                let (ou, du) = (1.0 - o[1], -d[1]);
                let a = d[0] * d[0] + d[2] * d[2] - du * du;
                let b = o[0] * d[0] + o[2] * d[2] - ou * du;
                let c = o[0] * o[0] + o[2] * o[2] - ou * ou;
                let ok = |t: f64| (0.0..=1.0).contains(&(ou + t * du));
                if a == 0.0 {
                    if b == 0.0 {
                        return None;
                    }
                    let t = -c / (2.0 * b);
                    return (t > 0.0 && ok(t)).then_some(t);
                }
                first(quadratic(a, b, c), &ok)
            }
            PrimKind::Disk | PrimKind::Square => {
                if d[1] == 0.0 {
                    return None;
                }
                let t = -o[1] / d[1];
                if !(t > 0.0 && t.is_finite()) {
                    return None;
                }
                let (x, z) = (o[0] + t * d[0], o[2] + t * d[2]);
                let inside =
                    if self.kind == PrimKind::Disk { x * x + z * z <= 1.0 } else { x.abs() <= 1.0 && z.abs() <= 1.0 };
                inside.then_some(t)
            }
        }
    }

    pub(super) fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        let q = apply_point(&self.w2o, p);
        let n = match self.kind {
            PrimKind::Sphere => q,
            PrimKind::Cylinder => [q[0], 0.0, q[2]],
            PrimKind::Cone => [q[0], 1.0 - q[1], q[2]],
            PrimKind::Disk | PrimKind::Square => [0.0, 1.0, 0.0],
        };
        apply_transpose(&self.w2o, n)
    }
}
