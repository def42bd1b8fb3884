//! Materials (SPEC.md §5.3): a 16-byte colour record and a 96-byte shading-model record per
//! material, the models being ViRAY's plus GridRT's matte surface.

use super::layout::{enum_u8, SceneError, MATERIAL_LEN, MATERIAL_MODEL_LEN};
use crate::bytes::{record, Reader};

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
        record(|w| {
            w.vec3(self.diffuse)?;
            w.f32(self.reflect)
        })
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
        record(|w| {
            w.bytes(&[
                self.diffuse_model as u8,
                self.specular_model as u8,
                self.reflect_mode as u8,
                self.texture as u8,
                self.mapping as u8,
                self.bilinear as u8,
                self.tex_log2,
                0,
            ])?;
            w.f32s(&[self.ka, self.kd, self.ks, self.sigma2, self.exponent])?;
            w.vec3(self.specular)?;
            w.f32s(&[self.eta, self.kappa])?;
            w.vec3(self.colour2)?;
            w.f32s(&self.uv_scale)?;
            w.f32s(&self.uv_offset)?;
            w.f32(self.tex_param)?;
            w.u32(self.tex_seed)
        })
    }

    /// Parses and range-checks a 96-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let [diffuse, specular, reflect, texture, mapping, bilinear, tex_log2, _] = r.array::<8>().map_err(t)?;
        use DiffuseModel as D;
        use Mapping as M;
        use ReflectMode as R;
        use SpecularModel as S;
        use TextureKind as T;
        let diffuse_model = enum_u8(diffuse, &[D::Lambert, D::OrenNayar, D::Matte])?;
        let specular_model = enum_u8(specular, &[S::None, S::BlinnPhong, S::TorranceSparrow])?;
        let reflect_mode = enum_u8(reflect, &[R::None, R::Constant, R::Dielectric, R::Conductor])?;
        let texture = enum_u8(texture, &[T::None, T::Checker, T::Xor, T::Marble, T::Wood, T::RgbDots])?;
        let mapping = enum_u8(mapping, &[M::Planar, M::Cylindrical, M::Spherical])?;
        if bilinear > 1 || !(1..=12).contains(&tex_log2) {
            return Err(SceneError::BadRecord);
        }
        let f = r.f32s::<18>().map_err(t)?;
        if f.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        let [ka, kd, ks, sigma2, exponent, s0, s1, s2, eta, kappa, c0, c1, c2, su, sv, ou, ov, tex_param] = f;
        let tex_seed = r.u32().map_err(t)?;
        let m = Self {
            diffuse_model,
            specular_model,
            reflect_mode,
            texture,
            mapping,
            bilinear: bilinear == 1,
            tex_log2,
            ka,
            kd,
            ks,
            sigma2,
            exponent,
            specular: [s0, s1, s2],
            eta,
            kappa,
            colour2: [c0, c1, c2],
            uv_scale: [su, sv],
            uv_offset: [ou, ov],
            tex_param,
            tex_seed,
        };
        if m.eta <= 0.0 || m.exponent < 0.0 || m.sigma2 < 0.0 || m.kappa < 0.0 {
            return Err(SceneError::BadRecord);
        }
        Ok(m)
    }
}
