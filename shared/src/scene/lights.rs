//! The lighting record (SPEC.md §5.6): one point light (optionally a spotlight), ambient and
//! background colours, and the ray depth of reflections.

use super::layout::{enum_u8, SceneError, LIGHTING_LEN, MAX_DEPTH};
use crate::bytes::{record, Reader};

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

/// Lighting and path settings of a scene (one record).
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
        Self::DEFAULT
    }
}

impl LightingRecord {
    /// One white omnidirectional light without falloff, white ambient, depth 1, the
    /// contract's background (docs/CONTRACTS.md § Shading): a mesh file's lighting.
    pub const DEFAULT: Self = Self {
        light_count: 1,
        max_depth: 1,
        falloff: Falloff::None,
        light_colour: [1.0; 3],
        spot_dir: [0.0; 3],
        cos_outer: -1.0,
        cos_inner: -1.0,
        ambient_colour: [1.0; 3],
        background: [0.08, 0.08, 0.12],
    };

    /// Serialises the 80-byte record.
    pub fn to_bytes(&self) -> [u8; LIGHTING_LEN] {
        record(|w| {
            w.bytes(&[self.light_count, self.max_depth, self.falloff as u8, 0])?;
            w.vec3(self.light_colour)?;
            w.vec3(self.spot_dir)?;
            w.f32s(&[self.cos_outer, self.cos_inner])?;
            w.vec3(self.ambient_colour)?;
            w.vec3(self.background)
        })
    }

    /// Parses and range-checks the 80-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let light_count = r.u8().map_err(t)?;
        let max_depth = r.u8().map_err(t)?;
        let falloff = enum_u8(r.u8().map_err(t)?, &[Falloff::None, Falloff::InverseSquare])?;
        let _ = r.u8().map_err(t)?;
        let f = r.f32s::<14>().map_err(t)?;
        if f.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        let [l0, l1, l2, s0, s1, s2, cos_outer, cos_inner, a0, a1, a2, b0, b1, b2] = f;
        if light_count > 1 || !(1..=MAX_DEPTH).contains(&max_depth) || cos_inner < cos_outer {
            return Err(SceneError::BadRecord);
        }
        Ok(Self {
            light_count,
            max_depth,
            falloff,
            light_colour: [l0, l1, l2],
            spot_dir: [s0, s1, s2],
            cos_outer,
            cos_inner,
            ambient_colour: [a0, a1, a2],
            background: [b0, b1, b2],
        })
    }
}
