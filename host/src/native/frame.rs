//! Frames of primary rays: rows traced on the caller's thread or on a rayon pool, and the
//! frame's footprint of the grid box, so that pixels whose ray cannot reach the box are
//! answered "culled" without generating or clipping their ray.
//!
//! The footprint is conservative by a wide margin. With the eye outside the box and every
//! box corner in front of it, a ray from the eye meets the box only if its direction's
//! image-plane point `(d·right, d·up) / (d·forward)` lies in the projection of the box,
//! which is inside the rectangle spanned by the projected corners. Per row, the pixels whose
//! image-plane point can lie in that rectangle are found from the row's actual end rays (in
//! f64) and widened by two pixels on each side, and the box itself by 10⁻³ of its extent:
//! f32 ray generation and the firmware's widened slab test move a ray by ~10⁻⁷ of its
//! direction, thousands of times less. Any other camera (eye inside or beside the box, box
//! behind, frames narrower than 2 pixels) gets no footprint: every ray is traced.
//! `bench rays` checks every pixel against the model, and `host/tests/native_path.rs` pins
//! frames on several scenes.

use core::ops::Range;

use gridrt_firmware::camera::Camera;
use gridrt_shared::math::Ray;

use super::scene::NativeScene;
use super::trace::{Hits, Trace};

/// A frame of primary rays `camera.primary_ray(x, y)`, `width`×`height`, with the pixels of
/// each row that may reach the grid box.
#[derive(Debug, Clone)]
pub struct PrimaryFrame<'c> {
    camera: &'c Camera,
    width: u32,
    height: u32,
    /// Per row: the pixels traced; the others are culled.
    rows: Vec<Range<u32>>,
}

impl<'c> PrimaryFrame<'c> {
    /// The frame of `camera` (built for `width`×`height`) over `scene`'s grid box.
    pub fn new(scene: &NativeScene, camera: &'c Camera, width: u32, height: u32) -> Self {
        let rows = footprint(scene, camera, width, height).unwrap_or_else(|| vec![0..width; height as usize]);
        Self { camera, width, height, rows }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Pixels whose ray is traced (the rest are culled without one).
    pub fn traced_pixels(&self) -> u64 {
        self.rows.iter().map(|r| r.len() as u64).sum()
    }
}

/// Per-row traced pixels, or `None` when the camera gets no footprint (module doc).
fn footprint(scene: &NativeScene, camera: &Camera, width: u32, height: u32) -> Option<Vec<Range<u32>>> {
    if width < 2 || height < 2 {
        return None;
    }
    let (lo, hi) = scene.walk.bounds()?;
    let f64v = |v: gridrt_shared::math::Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let eye = f64v(camera.primary_ray(0, 0).origin);
    let (fw, rt, up) = (f64v(camera.forward()), f64v(camera.right()), f64v(camera.up()));
    let margin: [f64; 3] = core::array::from_fn(|a| 1e-3 * (hi[a] as f64 - lo[a] as f64));
    let (lo, hi): ([f64; 3], [f64; 3]) =
        (core::array::from_fn(|a| lo[a] as f64 - margin[a]), core::array::from_fn(|a| hi[a] as f64 + margin[a]));
    if (0..3).all(|a| eye[a] >= lo[a] && eye[a] <= hi[a]) {
        return None;
    }
    // The projected corners' rectangle.
    let (mut u_lo, mut u_hi, mut w_lo, mut w_hi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for i in 0..8 {
        let c = [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ];
        let v = [c[0] - eye[0], c[1] - eye[1], c[2] - eye[2]];
        let z = dot(v, fw);
        if z.is_nan() || z <= 1e-6 * dot(v, v).sqrt() {
            return None;
        }
        let (u, w) = (dot(v, rt) / z, dot(v, up) / z);
        u_lo = u_lo.min(u);
        u_hi = u_hi.max(u);
        w_lo = w_lo.min(w);
        w_hi = w_hi.max(w);
    }
    // Image-plane point of a pixel's actual (f32) ray.
    let point = |x: u32, y: u32| {
        let d = f64v(camera.primary_ray(x, y).dir);
        let z = dot(d, fw);
        (dot(d, rt) / z, dot(d, up) / z)
    };
    let (u0, _) = point(0, 0);
    let (u1, _) = point(width - 1, 0);
    let (_, w0) = point(0, 0);
    let (_, w1) = point(0, height - 1);
    let (du, dw) = ((u1 - u0) / (width - 1) as f64, (w1 - w0) / (height - 1) as f64);
    if !(du.abs() > 0.0 && dw.abs() > 0.0 && du.is_finite() && dw.is_finite()) {
        return None;
    }
    let pad = 2.0;
    let rows = (0..height)
        .map(|y| {
            let (ua, wa) = point(0, y);
            let (ub, wb) = point(width - 1, y);
            // The row's image-plane height must meet the rectangle (plus two pixels).
            let pw = pad * dw.abs();
            if wa.max(wb) < w_lo - pw || wa.min(wb) > w_hi + pw {
                return 0..0;
            }
            // Pixels whose u can lie in [u_lo, u_hi] (u affine in x), plus two pixels.
            let du = (ub - ua) / (width - 1) as f64;
            let (xa, xb) = ((u_lo - ua) / du, (u_hi - ua) / du);
            let (x_lo, x_hi) = (xa.min(xb) - pad, xa.max(xb) + pad);
            let first = x_lo.floor().clamp(0.0, width as f64) as u32;
            let end = (x_hi.ceil() + 1.0).clamp(0.0, width as f64) as u32;
            first..end.max(first)
        })
        .collect();
    Some(rows)
}

impl NativeScene {
    /// The frame of `camera` at `width`×`height` over this scene (see [`PrimaryFrame`]).
    pub fn frame<'c>(&self, camera: &'c Camera, width: u32, height: u32) -> PrimaryFrame<'c> {
        PrimaryFrame::new(self, camera, width, height)
    }

    /// The answers of row `y` of `frame`, appended to `out` (one per pixel, left to right).
    pub fn trace_row(&self, frame: &PrimaryFrame<'_>, y: u32, out: &mut Vec<Trace>) {
        let traced = frame.rows.get(y as usize).cloned().unwrap_or(0..0);
        self.with_search(|trace| {
            out.extend((0..traced.start).map(|_| Trace::Culled));
            let mut rays = Vec::with_capacity(traced.len());
            rays.extend(traced.clone().map(|x| frame.camera.primary_ray(x, y)));
            out.extend(rays.iter().map(trace));
            out.extend((traced.end..frame.width).map(|_| Trace::Culled));
        });
    }

    /// Totals of rows `rows` of `frame`.
    pub fn count_rows(&self, frame: &PrimaryFrame<'_>, rows: Range<u32>) -> Hits {
        self.with_search(|trace| {
            let mut hits = Hits::default();
            // A row's rays first, then the traces: read back long after they were written,
            // the rays' words come from cache instead of stalling on the stores that made
            // them.
            let mut rays: Vec<Ray> = Vec::with_capacity(frame.width as usize);
            for y in rows {
                let traced = frame.rows.get(y as usize).cloned().unwrap_or(0..0);
                hits.culled += (frame.width - traced.len() as u32) as u64;
                rays.clear();
                rays.extend(traced.map(|x| frame.camera.primary_ray(x, y)));
                for ray in &rays {
                    hits.add(&trace(ray));
                }
            }
            hits
        })
    }

    /// Totals of `frame`, on the caller's thread or on `pool` (bands of rows handed out by
    /// rayon's work stealing).
    pub fn count_frame(&self, frame: &PrimaryFrame<'_>, pool: Option<&rayon::ThreadPool>) -> Hits {
        const BAND: u32 = 4;
        let h = frame.height;
        match pool {
            None => self.count_rows(frame, 0..h),
            Some(pool) => pool.install(|| {
                use rayon::prelude::*;
                (0..h.div_ceil(BAND))
                    .into_par_iter()
                    .map(|b| self.count_rows(frame, b * BAND..((b + 1) * BAND).min(h)))
                    .reduce(Hits::default, Hits::merge)
            }),
        }
    }
}
