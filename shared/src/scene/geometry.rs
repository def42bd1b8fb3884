//! Geometry records: triangles and ViRAY's analytic primitives as stored in PE memory
//! (SPEC.md §5.4), the object table that groups primitives (§5.5), and the affine maps both use.

use super::layout::{enum_u8, SceneError, OBJECT_LEN, PRIM_WORDS, TRIANGLE_WORDS};
use crate::bytes::{record, Reader};

/// Analytic primitive kinds, in canonical object space (SPEC.md §5.8.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum PrimKind {
    /// Unit sphere at the origin.
    Sphere = 1,
    /// Open cylinder `x² + z² = 1`, `|y| ≤ 1`.
    Cylinder = 2,
    /// Open cone `x² + z² = (1 − y)²`, `0 ≤ y ≤ 1` (apex at y = 1).
    Cone = 3,
    /// Disk `y = 0`, `x² + z² ≤ 1`.
    Disk = 4,
    /// Square `y = 0`, `|x| ≤ 1`, `|z| ≤ 1` (also what a scene file's plane becomes).
    Square = 5,
}

impl PrimKind {
    /// Kind for a record word.
    pub fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            1 => Self::Sphere,
            2 => Self::Cylinder,
            3 => Self::Cone,
            4 => Self::Disk,
            5 => Self::Square,
            _ => return None,
        })
    }
}

/// A 3×4 affine map, row-major: `y_i = m[4i]·x + m[4i+1]·y + m[4i+2]·z + m[4i+3]`.
pub type Affine = [f32; 12];

/// Applies an affine map to a point.
#[inline]
pub fn affine_point(m: &Affine, p: [f32; 3]) -> [f32; 3] {
    let [a, b, c, d, e, f, g, h, i, j, k, l] = *m;
    let [x, y, z] = p;
    [a * x + b * y + c * z + d, e * x + f * y + g * z + h, i * x + j * y + k * z + l]
}

/// Applies the linear part of an affine map to a vector.
#[inline]
pub fn affine_vector(m: &Affine, v: [f32; 3]) -> [f32; 3] {
    let [a, b, c, _, e, f, g, _, i, j, k, _] = *m;
    let [x, y, z] = v;
    [a * x + b * y + c * z, e * x + f * y + g * z, i * x + j * y + k * z]
}

/// Applies the transposed linear part (maps an object-space normal of a world→object map back
/// to world space, not normalised).
#[inline]
pub fn affine_transpose_vector(m: &Affine, v: [f32; 3]) -> [f32; 3] {
    let [a, b, c, _, e, f, g, _, i, j, k, _] = *m;
    let [x, y, z] = v;
    [a * x + e * y + i * z, b * x + f * y + j * z, c * x + g * y + k * z]
}

/// One analytic primitive as stored in a PE image (16 words).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrimRecord {
    /// Shape.
    pub kind: PrimKind,
    /// Global primitive id.
    pub prim: u32,
    /// Material index.
    pub material: u32,
    /// World → object (canonical space) affine map.
    pub world_to_object: Affine,
}

impl PrimRecord {
    /// The 16 words: kind, prim id, material, 12 affine coefficients, reserved 0.
    pub fn to_words(&self) -> [u32; PRIM_WORDS] {
        let head = [self.kind as u32, self.prim, self.material];
        let affine = self.world_to_object.map(f32::to_bits);
        let mut words = head.into_iter().chain(affine);
        // Word 15 is reserved: the chain ends there and it stays 0.
        core::array::from_fn(|_| words.next().unwrap_or(0))
    }

    /// Decodes 16 words; `None` for an unknown kind.
    pub fn from_words(w: &[u32]) -> Option<Self> {
        let &[kind, prim, material, a, b, c, d, e, f, g, h, i, j, k, l, _reserved] = w.get(..PRIM_WORDS)? else {
            return None;
        };
        let world_to_object = [a, b, c, d, e, f, g, h, i, j, k, l].map(f32::from_bits);
        Some(Self { kind: PrimKind::from_u32(kind)?, prim, material, world_to_object })
    }
}

/// What an object of the object table is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ObjectKind {
    /// A triangle mesh (its primitives are triangles).
    Mesh = 0,
    /// An analytic primitive of the given kind (its one primitive).
    Sphere = 1,
    /// Open cylinder.
    Cylinder = 2,
    /// Open cone.
    Cone = 3,
    /// Disk.
    Disk = 4,
    /// Square.
    Square = 5,
    /// A scene-file plane (stored as a square covering the scene box).
    Plane = 6,
}

/// One object: a range of primitive ids and its texture space (the object table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectRecord {
    /// What it is.
    pub kind: ObjectKind,
    /// Material of the object (meshes: of its first triangle; informative).
    pub material: u16,
    /// First global primitive id.
    pub first_prim: u32,
    /// Number of primitives (ids `first_prim..first_prim + prim_count`).
    pub prim_count: u32,
    /// World → object (texture) space; `p' ∈ [−1, 1]³` on the object.
    pub world_to_object: Affine,
}

impl ObjectRecord {
    /// Serialises the 64-byte record.
    pub fn to_bytes(&self) -> [u8; OBJECT_LEN] {
        record(|w| {
            w.bytes(&[self.kind as u8, 0])?;
            w.u16(self.material)?;
            w.u32(self.first_prim)?;
            w.u32(self.prim_count)?;
            w.u32(0)?;
            w.f32s(&self.world_to_object)
        })
    }

    /// Parses a 64-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        use ObjectKind as K;
        let kind =
            enum_u8(r.u8().map_err(t)?, &[K::Mesh, K::Sphere, K::Cylinder, K::Cone, K::Disk, K::Square, K::Plane])?;
        let _ = r.u8().map_err(t)?;
        let material = r.u16().map_err(t)?;
        let first_prim = r.u32().map_err(t)?;
        let prim_count = r.u32().map_err(t)?;
        let _ = r.u32().map_err(t)?;
        let m = r.f32s::<12>().map_err(t)?;
        if m.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        Ok(Self { kind, material, first_prim, prim_count, world_to_object: m })
    }
}

/// One triangle as stored in PE memory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleRecord {
    /// Vertices a, b, c.
    pub vertices: [[f32; 3]; 3],
    /// Global primitive id.
    pub prim: u32,
    /// Material index.
    pub material: u32,
}

impl TriangleRecord {
    /// The 11 words of the record.
    pub fn to_words(&self) -> [u32; TRIANGLE_WORDS] {
        let v = &self.vertices;
        [
            v[0][0].to_bits(),
            v[0][1].to_bits(),
            v[0][2].to_bits(),
            v[1][0].to_bits(),
            v[1][1].to_bits(),
            v[1][2].to_bits(),
            v[2][0].to_bits(),
            v[2][1].to_bits(),
            v[2][2].to_bits(),
            self.prim,
            self.material,
        ]
    }
}
