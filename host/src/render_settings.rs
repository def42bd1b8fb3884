//! Everything that defines one frame besides the scene ([`RenderSettings`]): camera, light,
//! size and flags, their defaults (docs/CONTRACTS.md). The reference renderer's f64 pinhole
//! camera built from them is `reference::camera`.
//!
//! The values are stored as the f32 the wire carries ([`RenderRequest`]), so the device and
//! the reference start from bit-identical inputs; the reference widens them to f64.

use gridrt_shared::msg::{render_flags, PixelEncoding, RenderRequest};

use crate::bounds::Bounds;

/// Default image width.
pub const DEFAULT_WIDTH: u16 = 320;
/// Default image height.
pub const DEFAULT_HEIGHT: u16 = 240;
/// Default vertical field of view in degrees.
pub const DEFAULT_FOV_Y_DEG: f32 = 45.0;
/// Default ambient term.
pub const DEFAULT_AMBIENT: f32 = 0.15;
/// Default light intensity.
pub const DEFAULT_LIGHT_INTENSITY: f32 = 1.0;

/// Pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Position.
    pub eye: [f32; 3],
    /// Point looked at.
    pub target: [f32; 3],
    /// Up vector.
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

/// Point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Position.
    pub pos: [f32; 3],
    /// Intensity (scales the diffuse term).
    pub intensity: f32,
}

/// Everything that defines one frame besides the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Camera.
    pub camera: Camera,
    /// Light.
    pub light: Light,
    /// Ambient term.
    pub ambient: f32,
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// Trace shadow rays.
    pub shadows: bool,
    /// Ask the device for the primitive id of every primary hit.
    pub prim_ids: bool,
}

fn to_f32(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

impl RenderSettings {
    /// The default view of a scene with bounding box `bounds` (docs/CONTRACTS.md):
    /// target = box centre, eye = target + (0, 0, 1.6·|diag|), up = +y, FOV 45°, 320×240;
    /// light at centre + |diag|·(0.6, 1.0, 0.8), intensity 1, ambient 0.15, shadows on.
    pub fn default_for(bounds: &Bounds) -> Self {
        let c = bounds.center();
        let d = bounds.diagonal_len();
        Self {
            camera: Camera {
                eye: to_f32([c[0], c[1], c[2] + 1.6 * d]),
                target: to_f32(c),
                up: [0.0, 1.0, 0.0],
                fov_y_deg: DEFAULT_FOV_Y_DEG,
            },
            light: Light {
                pos: to_f32([c[0] + 0.6 * d, c[1] + 1.0 * d, c[2] + 0.8 * d]),
                intensity: DEFAULT_LIGHT_INTENSITY,
            },
            ambient: DEFAULT_AMBIENT,
            width: DEFAULT_WIDTH,
            height: DEFAULT_HEIGHT,
            shadows: true,
            prim_ids: false,
        }
    }

    /// Sets the image size.
    #[must_use]
    pub fn with_size(mut self, width: u16, height: u16) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// Enables or disables shadow rays.
    #[must_use]
    pub fn with_shadows(mut self, on: bool) -> Self {
        self.shadows = on;
        self
    }

    /// Enables or disables the primitive-id side channel.
    #[must_use]
    pub fn with_prim_ids(mut self, on: bool) -> Self {
        self.prim_ids = on;
        self
    }

    /// Render flag bits ([`render_flags`]).
    pub fn flags(&self) -> u16 {
        (if self.shadows { render_flags::SHADOWS } else { 0 })
            | (if self.prim_ids { render_flags::PRIM_IDS } else { 0 })
    }

    /// The wire request for frame `frame`.
    pub fn to_request(&self, frame: u16) -> RenderRequest {
        RenderRequest {
            frame,
            width: self.width,
            height: self.height,
            flags: self.flags(),
            eye: self.camera.eye,
            target: self.camera.target,
            up: self.camera.up,
            fov_y_deg: self.camera.fov_y_deg,
            light_pos: self.light.pos,
            light_intensity: self.light.intensity,
            ambient: self.ambient,
            encoding: PixelEncoding::Rgb888,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_camera_targets_the_centre() {
        let b = Bounds { min: [-1.0, -1.0, -1.0], max: [1.0, 1.0, 1.0] };
        let s = RenderSettings::default_for(&b);
        assert_eq!(s.camera.target, [0.0, 0.0, 0.0]);
        assert!((s.camera.eye[2] as f64 - 1.6 * 12f64.sqrt()).abs() < 1e-6);
        assert_eq!((s.width, s.height), (320, 240));
        assert_eq!(s.to_request(7).flags, render_flags::SHADOWS);
        assert_eq!(s.with_shadows(false).with_prim_ids(true).flags(), render_flags::PRIM_IDS);
    }
}
