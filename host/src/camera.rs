//! Camera, light and frame settings (docs/CONTRACTS.md), and the f64 pinhole camera the
//! reference renderer uses.
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

/// f64 pinhole camera of docs/CONTRACTS.md.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraF64 {
    eye: [f64; 3],
    forward: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    half_w: f64,
    half_h: f64,
    width: f64,
    height: f64,
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    if l > 0.0 {
        a.map(|c| c / l)
    } else {
        a
    }
}

impl CameraF64 {
    /// Camera for `settings` (inputs widened from their f32 wire values).
    pub fn new(settings: &RenderSettings) -> Self {
        let c = &settings.camera;
        let w = |v: [f32; 3]| v.map(|x| x as f64);
        let eye = w(c.eye);
        let forward = normalize(sub(w(c.target), eye));
        let right = normalize(cross(forward, w(c.up)));
        let up = cross(right, forward);
        let half_h = (c.fov_y_deg as f64).to_radians() * 0.5;
        let half_h = half_h.tan();
        let half_w = half_h * settings.width as f64 / settings.height as f64;
        Self { eye, forward, right, up, half_w, half_h, width: settings.width as f64, height: settings.height as f64 }
    }

    /// Origin and (unnormalised) direction of the ray through the centre of pixel `(x, y)`.
    pub fn primary_ray(&self, x: u32, y: u32) -> ([f64; 3], [f64; 3]) {
        let sx = (2.0 * (x as f64 + 0.5) / self.width - 1.0) * self.half_w;
        let sy = (1.0 - 2.0 * (y as f64 + 0.5) / self.height) * self.half_h;
        let d = [0, 1, 2].map(|i| self.forward[i] + sx * self.right[i] + sy * self.up[i]);
        (self.eye, d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_camera_looks_down_minus_z_at_the_centre() {
        let b = Bounds { min: [-1.0, -1.0, -1.0], max: [1.0, 1.0, 1.0] };
        let s = RenderSettings::default_for(&b);
        assert_eq!(s.camera.target, [0.0, 0.0, 0.0]);
        assert!((s.camera.eye[2] as f64 - 1.6 * 12f64.sqrt()).abs() < 1e-6);
        assert_eq!((s.width, s.height), (320, 240));
        let cam = CameraF64::new(&s);
        // The centre of the image (between pixels 159/160, 119/120) is straight ahead:
        // pixel (159, 119) is half a pixel left/up of it.
        let (_, d) = cam.primary_ray(159, 119);
        assert!(d[0] < 0.0 && d[1] > 0.0 && (d[2] + 1.0).abs() < 1e-12);
        let (_, d2) = cam.primary_ray(160, 120);
        assert!((d[0] + d2[0]).abs() < 1e-15 && (d[1] + d2[1]).abs() < 1e-15);
        // Top-left pixel points up and left by almost the half FOV.
        let (_, tl) = cam.primary_ray(0, 0);
        let half_h = (22.5f64).to_radians().tan();
        assert!((tl[1] - half_h * (1.0 - 1.0 / 240.0)).abs() < 1e-12);
        assert_eq!(s.to_request(7).flags, render_flags::SHADOWS);
        assert_eq!(s.with_shadows(false).with_prim_ids(true).flags(), render_flags::PRIM_IDS);
    }
}
