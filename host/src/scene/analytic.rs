//! ViRAY's analytic primitives placed in the world with full affine
//! transforms: their bounds (for grid binning) and the plane of the flat ones.

use gridrt_shared::scene::{Affine, PrimKind};

use super::mesh::{Bounds, Mesh};
use super::transform::{apply_point, apply_transpose, from_wire, invert, to_wire, Affine64};

/// One analytic primitive placed in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalyticPrim {
    /// Canonical shape.
    pub kind: PrimKind,
    /// Material index.
    pub material: u32,
    /// Object → world map (f64, as authored).
    pub to_world: Affine64,
    /// World → object map as sent to the device (f32).
    pub to_object: Affine,
}

impl AnalyticPrim {
    /// A primitive; `None` when the map is singular.
    pub fn new(kind: PrimKind, material: u32, to_world: Affine64) -> Option<Self> {
        let inv = invert(&to_world)?;
        let to_object = to_wire(&inv);
        to_object.iter().all(|v| v.is_finite()).then_some(Self { kind, material, to_world, to_object })
    }

    /// Corners of the canonical box that contains the shape.
    fn canonical_box(&self) -> ([f64; 3], [f64; 3]) {
        match self.kind {
            PrimKind::Sphere | PrimKind::Cylinder => ([-1.0; 3], [1.0; 3]),
            PrimKind::Cone => ([-1.0, 0.0, -1.0], [1.0; 3]),
            PrimKind::Disk | PrimKind::Square => ([-1.0, 0.0, -1.0], [1.0, 0.0, 1.0]),
        }
    }

    /// Conservative world bounds (the image of the canonical box; for a sphere the exact
    /// box of the ellipsoid), grown by a relative 2^-16 for the f32 map.
    pub fn bounds(&self) -> Bounds {
        let m = &self.to_world;
        let (lo, hi) = match self.kind {
            PrimKind::Sphere => {
                let c = [m[0][3], m[1][3], m[2][3]];
                let r = [0, 1, 2].map(|i| (m[i][0] * m[i][0] + m[i][1] * m[i][1] + m[i][2] * m[i][2]).sqrt());
                ([0, 1, 2].map(|i| c[i] - r[i]), [0, 1, 2].map(|i| c[i] + r[i]))
            }
            _ => {
                let (a, b) = self.canonical_box();
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for k in 0..8 {
                    let p = [
                        if k & 1 == 0 { a[0] } else { b[0] },
                        if k & 2 == 0 { a[1] } else { b[1] },
                        if k & 4 == 0 { a[2] } else { b[2] },
                    ];
                    let q = apply_point(m, p);
                    for i in 0..3 {
                        lo[i] = lo[i].min(q[i]);
                        hi[i] = hi[i].max(q[i]);
                    }
                }
                (lo, hi)
            }
        };
        let size = (0..3)
            .map(|i| hi[i] - lo[i])
            .fold(0.0f64, f64::max)
            .max(lo.iter().chain(hi.iter()).fold(0.0f64, |a, b| a.max(b.abs())));
        let pad = size / 65536.0;
        Bounds { min: lo.map(|v| (v - pad) as f32), max: hi.map(|v| (v + pad) as f32) }
    }

    /// For disks and squares: a point of the plane and its (unit) normal.
    pub fn plane(&self) -> Option<([f64; 3], [f64; 3])> {
        match self.kind {
            PrimKind::Disk | PrimKind::Square => {
                let p = apply_point(&self.to_world, [0.0; 3]);
                let inv = from_wire(&self.to_object);
                let n = apply_transpose(&inv, [0.0, 1.0, 0.0]);
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                Some((p, n.map(|c| c / l)))
            }
            _ => None,
        }
    }
}

impl Bounds {
    /// The smallest box holding both.
    pub fn union(&self, other: &Bounds) -> Bounds {
        Bounds {
            min: [0, 1, 2].map(|i| self.min[i].min(other.min[i])),
            max: [0, 1, 2].map(|i| self.max[i].max(other.max[i])),
        }
    }

    /// Bounds of a mesh's triangles and analytic primitives; `None` when there are none.
    pub fn of_geometry(mesh: &Mesh, prims: &[AnalyticPrim]) -> Option<Bounds> {
        prims.iter().map(AnalyticPrim::bounds).fold(mesh.bounds(), |acc, b| Some(acc.map_or(b, |a| a.union(&b))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::transform::trs;

    #[test]
    fn sphere_bounds_are_tight_and_disk_plane_is_rotated() {
        let s = AnalyticPrim::new(PrimKind::Sphere, 0, trs([5.0, 0.0, 0.0], [0.0, 45.0, 0.0], [2.0; 3])).unwrap();
        let b = s.bounds();
        assert!((b.min[0] - 3.0).abs() < 1e-3 && (b.max[0] - 7.0).abs() < 1e-3, "{b:?}");
        let d = AnalyticPrim::new(PrimKind::Disk, 0, trs([0.0, 1.0, 0.0], [90.0, 0.0, 0.0], [1.0; 3])).unwrap();
        let (p, n) = d.plane().unwrap();
        assert!((p[1] - 1.0).abs() < 1e-12);
        assert!((n[2].abs() - 1.0).abs() < 1e-6, "{n:?}");
    }
}
