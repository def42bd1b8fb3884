//! A scene with analytic primitives, extended materials and lighting (scene image v2), as
//! built from a scene file (`scene_file`): triangles from OBJ meshes plus ViRAY's analytic
//! primitives (seed 000 §4.4–4.5) with full affine transforms.
//!
//! Primitive ids: triangles `0..T` (the mesh, in order), analytic primitives `T..T+P`.

use gridrt_shared::scene::Material;
use gridrt_shared::scene_v2::{Affine, LightingRecord, MaterialExt, ObjectKind, ObjectRecord, PrimKind};

use crate::camera::RenderSettings;
use crate::scene::{Bounds, Mesh};

/// Row-major 3×4 affine map in f64.
pub type Affine64 = [[f64; 4]; 3];

/// The identity map.
pub const IDENTITY: Affine64 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// `a ∘ b` (apply b first).
pub fn compose(a: &Affine64, b: &Affine64) -> Affine64 {
    let mut r = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..4 {
            let mut v = if j == 3 { a[i][3] } else { 0.0 };
            for k in 0..3 {
                v += a[i][k] * b[k][j];
            }
            r[i][j] = v;
        }
    }
    r
}

/// Inverse of an affine map; `None` when singular.
pub fn invert(m: &Affine64) -> Option<Affine64> {
    let a = |i: usize, j: usize| m[i][j];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    if det.is_nan() || det.abs() <= 1e-300 || !det.is_finite() {
        return None;
    }
    let inv = [
        [
            (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) / det,
            (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) / det,
            (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) / det,
        ],
        [
            (a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2)) / det,
            (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) / det,
            (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) / det,
        ],
        [
            (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0)) / det,
            (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) / det,
            (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) / det,
        ],
    ];
    let mut r = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = inv[i][j];
        }
        r[i][3] = -(inv[i][0] * m[0][3] + inv[i][1] * m[1][3] + inv[i][2] * m[2][3]);
    }
    Some(r)
}

/// Applies `m` to a point.
pub fn apply_point(m: &Affine64, p: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
}

/// Applies the linear part of `m` to a vector.
pub fn apply_vector(m: &Affine64, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// Applies the transposed linear part (object normal → world normal for a world→object map).
pub fn apply_transpose(m: &Affine64, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
}

/// Translate · Rz · Ry · Rx · Scale (angles in degrees).
pub fn trs(translate: [f64; 3], rotate_deg: [f64; 3], scale: [f64; 3]) -> Affine64 {
    let s = [[scale[0], 0.0, 0.0, 0.0], [0.0, scale[1], 0.0, 0.0], [0.0, 0.0, scale[2], 0.0]];
    let (sx, cx) = rotate_deg[0].to_radians().sin_cos();
    let (sy, cy) = rotate_deg[1].to_radians().sin_cos();
    let (sz, cz) = rotate_deg[2].to_radians().sin_cos();
    let rx = [[1.0, 0.0, 0.0, 0.0], [0.0, cx, -sx, 0.0], [0.0, sx, cx, 0.0]];
    let ry = [[cy, 0.0, sy, 0.0], [0.0, 1.0, 0.0, 0.0], [-sy, 0.0, cy, 0.0]];
    let rz = [[cz, -sz, 0.0, 0.0], [sz, cz, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let mut m = compose(&rz, &compose(&ry, &compose(&rx, &s)));
    for (i, t) in translate.iter().enumerate() {
        m[i][3] = *t;
    }
    m
}

/// The f32 wire form of a world→object map (row-major 3×4).
pub fn to_wire(m: &Affine64) -> Affine {
    let mut a = [0f32; 12];
    for i in 0..3 {
        for j in 0..4 {
            a[4 * i + j] = m[i][j] as f32;
        }
    }
    a
}

/// The f64 map of the f32 wire form (the reference uses exactly what the device gets).
pub fn from_wire(a: &Affine) -> Affine64 {
    let mut m = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..4 {
            m[i][j] = a[4 * i + j] as f64;
        }
    }
    m
}

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

/// Everything of a scene-file scene.
#[derive(Debug, Clone)]
pub struct World {
    /// Triangles (prim ids `0..T`) and the v1 material table (index = material id).
    pub mesh: Mesh,
    /// Extended material records, parallel to `mesh.materials`.
    pub material_ext: Vec<MaterialExt>,
    /// Analytic primitives (prim ids `T + i`).
    pub prims: Vec<AnalyticPrim>,
    /// Object table (prim id ranges and texture spaces).
    pub objects: Vec<ObjectRecord>,
    /// Lighting and path record.
    pub lighting: LightingRecord,
    /// Camera, light position and intensity, ambient strength, frame size.
    pub settings: RenderSettings,
    /// Material names (for messages), parallel to `mesh.materials`.
    pub material_names: Vec<String>,
}

impl World {
    /// Bounds of all geometry.
    pub fn bounds(&self) -> Option<Bounds> {
        let mut b = self.mesh.bounds();
        for p in &self.prims {
            let pb = p.bounds();
            b = Some(match b {
                None => pb,
                Some(mut a) => {
                    for i in 0..3 {
                        a.min[i] = a.min[i].min(pb.min[i]);
                        a.max[i] = a.max[i].max(pb.max[i]);
                    }
                    a
                }
            });
        }
        b
    }

    /// The material of index `i` (v1 record and extension).
    pub fn material(&self, i: u32) -> (Material, MaterialExt) {
        (
            self.mesh.materials.get(i as usize).copied().unwrap_or(crate::scene::DEFAULT_MATERIAL),
            self.material_ext.get(i as usize).copied().unwrap_or_default(),
        )
    }

    /// Object kind of an analytic primitive kind.
    pub fn object_kind(kind: PrimKind) -> ObjectKind {
        match kind {
            PrimKind::Sphere => ObjectKind::Sphere,
            PrimKind::Cylinder => ObjectKind::Cylinder,
            PrimKind::Cone => ObjectKind::Cone,
            PrimKind::Disk => ObjectKind::Disk,
            PrimKind::Square => ObjectKind::Square,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trs_inverse_round_trips() {
        let m = trs([1.0, 2.0, 3.0], [10.0, 20.0, 30.0], [2.0, 0.5, 3.0]);
        let inv = invert(&m).unwrap();
        let p = [0.3, -0.7, 1.1];
        let q = apply_point(&inv, apply_point(&m, p));
        for i in 0..3 {
            assert!((p[i] - q[i]).abs() < 1e-12);
        }
        assert!(invert(&trs([0.0; 3], [0.0; 3], [1.0, 0.0, 1.0])).is_none());
    }

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
