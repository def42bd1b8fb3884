//! The f64 pinhole camera of docs/CONTRACTS.md, built from the f32 [`RenderSettings`] the
//! wire carries (widened to f64).

use super::vec3::{cross, normalize, sub};
use crate::render_settings::RenderSettings;

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
    use crate::bounds::Bounds;

    #[test]
    fn default_camera_looks_down_minus_z_at_the_centre() {
        let b = Bounds { min: [-1.0, -1.0, -1.0], max: [1.0, 1.0, 1.0] };
        let s = RenderSettings::default_for(&b);
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
    }
}
