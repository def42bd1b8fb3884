//! Records of scene image version 2 (SPEC.md §5.8): analytic primitives in PE memory,
//! extended materials (ViRAY shading models, Fresnel, procedural textures), the object table
//! and the lighting record.
//!
//! Version 1 images are unchanged; a version-2 image adds three sections after the v1
//! materials and uses the v2 PE memory image ([`PE_V2_TAG`]) whose reference table addresses
//! triangles and analytic primitives alike (refs `< T` name triangles, refs `T..T+P` name
//! primitives), so primitive ids and hit records are shared with the triangle path.

use crate::bytes::Reader;
use crate::scene::SceneError;

/// Scene image version that carries the sections of this module.
pub const VERSION_2: u16 = 2;
/// Bytes per extended material record.
pub const MATERIAL_EXT_LEN: usize = 96;
/// Bytes per object record.
pub const OBJECT_LEN: usize = 64;
/// Bytes of the lighting record.
pub const LIGHTING_LEN: usize = 80;
/// First word of a version-2 PE memory image. A v1 image starts with its triangle count,
/// which can never be this large (11·T words would not fit any PE memory).
pub const PE_V2_TAG: u32 = 0xFFFF_0002;
/// Words before the voxel table in a v2 PE image: tag, T, V, R, P.
pub const PE_V2_HEADER_WORDS: usize = 5;
/// Words per analytic primitive record in a v2 PE image.
pub const PRIM_WORDS: usize = 16;

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
    [0, 1, 2].map(|i| m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3])
}

/// Applies the linear part of an affine map to a vector.
#[inline]
pub fn affine_vector(m: &Affine, v: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|i| m[4 * i] * v[0] + m[4 * i + 1] * v[1] + m[4 * i + 2] * v[2])
}

/// Applies the transposed linear part (maps an object-space normal of a world→object map back
/// to world space, not normalised).
#[inline]
pub fn affine_transpose_vector(m: &Affine, v: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|j| m[j] * v[0] + m[4 + j] * v[1] + m[8 + j] * v[2])
}

/// One analytic primitive as stored in a v2 PE image (16 words).
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
        let mut w = [0u32; PRIM_WORDS];
        w[0] = self.kind as u32;
        w[1] = self.prim;
        w[2] = self.material;
        for (d, s) in w[3..15].iter_mut().zip(self.world_to_object.iter()) {
            *d = s.to_bits();
        }
        w
    }

    /// Decodes 16 words; `None` for an unknown kind.
    pub fn from_words(w: &[u32]) -> Option<Self> {
        let w: &[u32; PRIM_WORDS] = w.get(..PRIM_WORDS)?.try_into().ok()?;
        let mut m = [0f32; 12];
        for (d, s) in m.iter_mut().zip(w[3..15].iter()) {
            *d = f32::from_bits(*s);
        }
        Some(Self { kind: PrimKind::from_u32(w[0])?, prim: w[1], material: w[2], world_to_object: m })
    }
}

/// Diffuse BRDF of a material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum DiffuseModel {
    /// `f = 1/π`.
    #[default]
    Lambert = 0,
    /// Simplified Oren–Nayar with roughness σ².
    OrenNayar = 1,
}

/// Specular BRDF of a material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum SpecularModel {
    /// No specular highlight.
    #[default]
    None = 0,
    /// Normalised Blinn–Phong `(e+2)/(2π)·(n·h)^e`.
    BlinnPhong = 1,
    /// Torrance–Sparrow with the Blinn distribution, the V-groove G term and Fresnel.
    TorranceSparrow = 2,
}

/// Mirror reflection coefficient of a material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum ReflectMode {
    /// Not reflective (no reflection ray).
    #[default]
    None = 0,
    /// Constant coefficient (the v1 material record's `reflect`).
    Constant = 1,
    /// Unpolarised Fresnel for a dielectric of index `eta`.
    Dielectric = 2,
    /// Unpolarised Fresnel for a conductor of complex index `eta − i·kappa`.
    Conductor = 3,
}

/// Procedural texture of a material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum TextureKind {
    /// No texture: the diffuse colour is the material's.
    #[default]
    None = 0,
    /// Checkerboard of `param` cells per side, mixing colour and colour2.
    Checker = 1,
    /// XOR pattern (grayscale mix).
    Xor = 2,
    /// Marble: sine bands perturbed by value noise (`param` = turbulence).
    Marble = 3,
    /// Wood: concentric rings perturbed by value noise (`param` = rings).
    Wood = 4,
    /// RGB dots on colour2, `param` dots per side.
    RgbDots = 5,
}

/// Texture-coordinate mapping from object space `p' ∈ [−1, 1]³`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Mapping {
    /// `u = (x'+1)/2, v = (z'+1)/2`.
    #[default]
    Planar = 0,
    /// `u = atan2(x', z')/2π` (wrapped), `v = (y'+1)/2`.
    Cylindrical = 1,
    /// `u = atan2(x', z')/2π` (wrapped), `v = 1 − acos(y'/|p'|)/π`.
    Spherical = 2,
}

fn enum_u8<T>(v: u8, table: &[T]) -> Result<T, SceneError>
where
    T: Copy,
{
    table.get(v as usize).copied().ok_or(SceneError::BadRecord)
}

/// Extended material record (v2), one per v1 material, same index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialExt {
    /// Diffuse model.
    pub diffuse_model: DiffuseModel,
    /// Specular model.
    pub specular_model: SpecularModel,
    /// Reflection coefficient mode.
    pub reflect_mode: ReflectMode,
    /// Procedural texture.
    pub texture: TextureKind,
    /// Texture mapping.
    pub mapping: Mapping,
    /// Bilinear filtering (else nearest texel).
    pub bilinear: bool,
    /// Texture resolution: `1 << tex_log2` texels per side, 1..=12.
    pub tex_log2: u8,
    /// Ambient weight k_a.
    pub ka: f32,
    /// Diffuse weight k_d.
    pub kd: f32,
    /// Specular weight k_s.
    pub ks: f32,
    /// Oren–Nayar roughness σ².
    pub sigma2: f32,
    /// Specular exponent e.
    pub exponent: f32,
    /// Specular colour c_s.
    pub specular: [f32; 3],
    /// Real part of the index of refraction.
    pub eta: f32,
    /// Extinction coefficient (conductors).
    pub kappa: f32,
    /// Secondary texture colour.
    pub colour2: [f32; 3],
    /// Texture coordinate scale (tiling).
    pub uv_scale: [f32; 2],
    /// Texture coordinate offset.
    pub uv_offset: [f32; 2],
    /// Texture parameter (cells, turbulence, rings, dots).
    pub tex_param: f32,
    /// Seed of the texture's value noise.
    pub tex_seed: u32,
}

impl Default for MaterialExt {
    fn default() -> Self {
        Self {
            diffuse_model: DiffuseModel::Lambert,
            specular_model: SpecularModel::None,
            reflect_mode: ReflectMode::None,
            texture: TextureKind::None,
            mapping: Mapping::Planar,
            bilinear: true,
            tex_log2: 8,
            ka: 1.0,
            kd: 1.0,
            ks: 0.0,
            sigma2: 0.0,
            exponent: 32.0,
            specular: [1.0; 3],
            eta: 1.5,
            kappa: 0.0,
            colour2: [0.1; 3],
            uv_scale: [1.0; 2],
            uv_offset: [0.0; 2],
            tex_param: 8.0,
            tex_seed: 0,
        }
    }
}

impl MaterialExt {
    /// Serialises the 96-byte record.
    pub fn to_bytes(&self) -> [u8; MATERIAL_EXT_LEN] {
        let mut b = [0u8; MATERIAL_EXT_LEN];
        b[0] = self.diffuse_model as u8;
        b[1] = self.specular_model as u8;
        b[2] = self.reflect_mode as u8;
        b[3] = self.texture as u8;
        b[4] = self.mapping as u8;
        b[5] = self.bilinear as u8;
        b[6] = self.tex_log2;
        let floats = [
            self.ka,
            self.kd,
            self.ks,
            self.sigma2,
            self.exponent,
            self.specular[0],
            self.specular[1],
            self.specular[2],
            self.eta,
            self.kappa,
            self.colour2[0],
            self.colour2[1],
            self.colour2[2],
            self.uv_scale[0],
            self.uv_scale[1],
            self.uv_offset[0],
            self.uv_offset[1],
            self.tex_param,
        ];
        for (i, f) in floats.iter().enumerate() {
            b[8 + 4 * i..12 + 4 * i].copy_from_slice(&f.to_le_bytes());
        }
        b[80..84].copy_from_slice(&self.tex_seed.to_le_bytes());
        b
    }

    /// Parses and range-checks a 96-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let e = r.take(8).map_err(t)?;
        use DiffuseModel as D;
        use Mapping as M;
        use ReflectMode as R;
        use SpecularModel as S;
        use TextureKind as T;
        let diffuse_model = enum_u8(e[0], &[D::Lambert, D::OrenNayar])?;
        let specular_model = enum_u8(e[1], &[S::None, S::BlinnPhong, S::TorranceSparrow])?;
        let reflect_mode = enum_u8(e[2], &[R::None, R::Constant, R::Dielectric, R::Conductor])?;
        let texture = enum_u8(e[3], &[T::None, T::Checker, T::Xor, T::Marble, T::Wood, T::RgbDots])?;
        let mapping = enum_u8(e[4], &[M::Planar, M::Cylindrical, M::Spherical])?;
        if e[5] > 1 || !(1..=12).contains(&e[6]) {
            return Err(SceneError::BadRecord);
        }
        let mut f = [0f32; 18];
        for v in f.iter_mut() {
            *v = r.f32().map_err(t)?;
        }
        if f.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        let tex_seed = r.u32().map_err(t)?;
        let m = Self {
            diffuse_model,
            specular_model,
            reflect_mode,
            texture,
            mapping,
            bilinear: e[5] == 1,
            tex_log2: e[6],
            ka: f[0],
            kd: f[1],
            ks: f[2],
            sigma2: f[3],
            exponent: f[4],
            specular: [f[5], f[6], f[7]],
            eta: f[8],
            kappa: f[9],
            colour2: [f[10], f[11], f[12]],
            uv_scale: [f[13], f[14]],
            uv_offset: [f[15], f[16]],
            tex_param: f[17],
            tex_seed,
        };
        if m.eta <= 0.0 || m.exponent < 0.0 || m.sigma2 < 0.0 || m.kappa < 0.0 {
            return Err(SceneError::BadRecord);
        }
        Ok(m)
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

/// One object: a range of primitive ids and its texture space (v2 object table).
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
        let mut b = [0u8; OBJECT_LEN];
        b[0] = self.kind as u8;
        b[2..4].copy_from_slice(&self.material.to_le_bytes());
        b[4..8].copy_from_slice(&self.first_prim.to_le_bytes());
        b[8..12].copy_from_slice(&self.prim_count.to_le_bytes());
        for (i, f) in self.world_to_object.iter().enumerate() {
            b[16 + 4 * i..20 + 4 * i].copy_from_slice(&f.to_le_bytes());
        }
        b
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
        let mut m = [0f32; 12];
        for v in m.iter_mut() {
            *v = r.f32().map_err(t)?;
        }
        if m.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        Ok(Self { kind, material, first_prim, prim_count, world_to_object: m })
    }
}

/// Distance falloff of the point light.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Falloff {
    /// Constant irradiance (`E = I·cosθ`).
    None = 0,
    /// Inverse square (`E = I·cosθ/r²`), as ViRAY.
    #[default]
    InverseSquare = 1,
}

/// Lighting and path settings of a v2 scene (one record).
///
/// The position, the scalar intensity and the scalar ambient strength stay in the render
/// request (they may change per frame); this record holds what multiplies them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightingRecord {
    /// Point lights: 0 or 1.
    pub light_count: u8,
    /// Ray depth: 1 = primary rays only, 2 = one reflection bounce (ViRAY), … ≤ 8.
    pub max_depth: u8,
    /// Distance falloff.
    pub falloff: Falloff,
    /// Light colour (RGB multiplier of the request's `light_intensity`).
    pub light_colour: [f32; 3],
    /// Spotlight axis (need not be unit); zero = omnidirectional.
    pub spot_dir: [f32; 3],
    /// Cosine of the outer half-angle (no light beyond).
    pub cos_outer: f32,
    /// Cosine of the inner half-angle (full light within); `cos_inner ≥ cos_outer`.
    pub cos_inner: f32,
    /// Ambient colour L_a (multiplier of the request's `ambient`).
    pub ambient_colour: [f32; 3],
    /// Background colour of a miss.
    pub background: [f32; 3],
}

impl Default for LightingRecord {
    fn default() -> Self {
        Self {
            light_count: 1,
            max_depth: 1,
            falloff: Falloff::None,
            light_colour: [1.0; 3],
            spot_dir: [0.0; 3],
            cos_outer: -1.0,
            cos_inner: -1.0,
            ambient_colour: [1.0; 3],
            background: [0.08, 0.08, 0.12],
        }
    }
}

/// Largest `max_depth`.
pub const MAX_DEPTH: u8 = 8;

impl LightingRecord {
    /// Serialises the 80-byte record.
    pub fn to_bytes(&self) -> [u8; LIGHTING_LEN] {
        let mut b = [0u8; LIGHTING_LEN];
        b[0] = self.light_count;
        b[1] = self.max_depth;
        b[2] = self.falloff as u8;
        let floats = [
            self.light_colour[0],
            self.light_colour[1],
            self.light_colour[2],
            self.spot_dir[0],
            self.spot_dir[1],
            self.spot_dir[2],
            self.cos_outer,
            self.cos_inner,
            self.ambient_colour[0],
            self.ambient_colour[1],
            self.ambient_colour[2],
            self.background[0],
            self.background[1],
            self.background[2],
        ];
        for (i, f) in floats.iter().enumerate() {
            b[4 + 4 * i..8 + 4 * i].copy_from_slice(&f.to_le_bytes());
        }
        b
    }

    /// Parses and range-checks the 80-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let light_count = r.u8().map_err(t)?;
        let max_depth = r.u8().map_err(t)?;
        let falloff = enum_u8(r.u8().map_err(t)?, &[Falloff::None, Falloff::InverseSquare])?;
        let _ = r.u8().map_err(t)?;
        let mut f = [0f32; 14];
        for v in f.iter_mut() {
            *v = r.f32().map_err(t)?;
        }
        if f.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        if light_count > 1 || !(1..=MAX_DEPTH).contains(&max_depth) || f[7] < f[6] {
            return Err(SceneError::BadRecord);
        }
        Ok(Self {
            light_count,
            max_depth,
            falloff,
            light_colour: [f[0], f[1], f[2]],
            spot_dir: [f[3], f[4], f[5]],
            cos_outer: f[6],
            cos_inner: f[7],
            ambient_colour: [f[8], f[9], f[10]],
            background: [f[11], f[12], f[13]],
        })
    }
}

/// Version-specific header fields (bytes 4..6 and 60..64 of the header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeaderExt {
    /// Scene image version, 1 or 2.
    pub version: u16,
    /// v2: object records (0 in v1).
    pub object_count: u16,
}

impl HeaderExt {
    /// A version-1 image.
    pub const V1: Self = Self { version: 1, object_count: 0 };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip() {
        let m = MaterialExt {
            diffuse_model: DiffuseModel::OrenNayar,
            specular_model: SpecularModel::TorranceSparrow,
            reflect_mode: ReflectMode::Conductor,
            texture: TextureKind::Marble,
            mapping: Mapping::Spherical,
            tex_seed: 77,
            ..MaterialExt::default()
        };
        assert_eq!(MaterialExt::parse(&m.to_bytes()), Ok(m));
        let o = ObjectRecord {
            kind: ObjectKind::Cone,
            material: 3,
            first_prim: 9,
            prim_count: 1,
            world_to_object: [1.5; 12],
        };
        assert_eq!(ObjectRecord::parse(&o.to_bytes()), Ok(o));
        let l = LightingRecord {
            max_depth: 2,
            falloff: Falloff::InverseSquare,
            cos_outer: 0.7,
            cos_inner: 0.85,
            ..LightingRecord::default()
        };
        assert_eq!(LightingRecord::parse(&l.to_bytes()), Ok(l));
        let p = PrimRecord { kind: PrimKind::Cylinder, prim: 5, material: 2, world_to_object: [0.25; 12] };
        assert_eq!(PrimRecord::from_words(&p.to_words()), Some(p));
    }

    #[test]
    fn bad_enums_and_values_are_rejected() {
        let mut b = MaterialExt::default().to_bytes();
        b[3] = 9;
        assert_eq!(MaterialExt::parse(&b), Err(SceneError::BadRecord));
        let mut b = MaterialExt::default().to_bytes();
        b[6] = 13;
        assert_eq!(MaterialExt::parse(&b), Err(SceneError::BadRecord));
        let mut b = LightingRecord::default().to_bytes();
        b[1] = 0;
        assert_eq!(LightingRecord::parse(&b), Err(SceneError::BadRecord));
        let mut b = LightingRecord::default().to_bytes();
        b[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(LightingRecord::parse(&b), Err(SceneError::NonFinite));
        assert_eq!(PrimRecord::from_words(&[0; PRIM_WORDS]), None);
    }

    #[test]
    fn affine_helpers() {
        // Scale 2 then translate (1, 0, 0): x' = 2x + 1.
        let m: Affine = [2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0];
        assert_eq!(affine_point(&m, [1.0, 1.0, 1.0]), [3.0, 2.0, 2.0]);
        assert_eq!(affine_vector(&m, [1.0, 1.0, 1.0]), [2.0, 2.0, 2.0]);
        let r: Affine = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(affine_transpose_vector(&r, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]);
    }
}
