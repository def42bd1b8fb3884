//! The lighting record (SPEC.md §5.6): one point light (optionally a spotlight), ambient and
//! background colours, and the ray depth of reflections.

use super::layout::{enum_u8, SceneError, LIGHTING_LEN, MAX_DEPTH};
use crate::bytes::Reader;

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
