//! Materials (SPEC.md §5.3): a 16-byte colour record and a 96-byte shading-model record per
//! material, the models being ViRAY's (seed 000 §4.6) plus GridRT's matte surface.

use super::layout::{enum_u8, SceneError, MATERIAL_LEN, MATERIAL_MODEL_LEN};
use crate::bytes::Reader;

/// Colour and mirror reflectance of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Diffuse reflectance, linear RGB in `[0, 1]`.
    pub diffuse: [f32; 3],
    /// Mirror reflectance in `[0, 1]` (0 = not reflective).
    pub reflect: f32,
}

impl Material {
    /// Serialises the 16-byte record.
    pub fn to_bytes(&self) -> [u8; MATERIAL_LEN] {
        let mut b = [0u8; MATERIAL_LEN];
        for (dst, v) in b.chunks_exact_mut(4).zip(self.diffuse.iter().chain(core::iter::once(&self.reflect))) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
        b
    }

    /// Parses a 16-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let diffuse = r.vec3().map_err(|_| SceneError::Truncated)?;
        let reflect = r.f32().map_err(|_| SceneError::Truncated)?;
        if diffuse.iter().chain(core::iter::once(&reflect)).any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        Ok(Self { diffuse, reflect })
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
    /// GridRT's matte surface (docs/CONTRACTS.md § Shading): `c_d·(k_a·L_a + vis·E·c_L·k_d)`,
    /// no 1/π. What a mesh file's materials get, so OBJ/PLY scenes shade as they always have.
    Matte = 2,
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
    /// Constant coefficient (the colour record's `reflect`).
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

/// Shading-model record of a material: one per colour record ([`Material`]), same index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialModel {
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

impl Default for MaterialModel {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl MaterialModel {
    /// A scene file's material before its fields are set (docs/SCENE-FILE.md): Lambert, no
    /// specular, no reflection, no texture.
    pub const DEFAULT: Self = Self {
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
            };

    /// GridRT's matte surface, what a mesh file's materials get: shades as
    /// docs/CONTRACTS.md § Shading has always written it, `albedo·(ambient + I·n·l·vis)`.
    pub const MATTE: Self = Self { diffuse_model: DiffuseModel::Matte, ..Self::DEFAULT };

    /// Serialises the 96-byte record.
    pub fn to_bytes(&self) -> [u8; MATERIAL_MODEL_LEN] {
        let mut b = [0u8; MATERIAL_MODEL_LEN];
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
        let diffuse_model = enum_u8(e[0], &[D::Lambert, D::OrenNayar, D::Matte])?;
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
