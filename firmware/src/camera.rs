//! Pinhole camera: one primary ray per pixel centre.
//!
//! The formulas are pinned in `docs/CONTRACTS.md` § Camera, because the host's f64 reference
//! renderer re-implements them; keep both in step. Source: the Suffern-style pinhole camera
//! GridRT's MicroBlaze program uses (GridRT, Nery 2010), with an explicit field of view.
//!
//! # Number formats of ray generation ([`RayFormat`])
//!
//! - `F32` (default): the contract's formula in f32 — 2 screen coordinates and 6 multiply-adds
//!   per pixel, each rounded.
//! - `Fixed` (feature `fixed-raygen`; both are always compiled and tested): per frame,
//!   [`Camera::new`] quantises the basis to Q2.30 and the screen mapping to
//!   `sx = sx0 + x·Δx` with `sx0, Δx` in Q(S+16), where S ≤ 29 is the largest number of
//!   fractional bits with `max(half_w, half_h)·2^S < 2^29`. Per pixel everything is integer: `sx = (sx0 + x·Δx) >> 16` (error ≤ 2⁻ˢ·(1 + x·2⁻¹⁷)),
//!   `dir = (fwd << S) + sx·right + sy·up` in i64 (exact: 32×32-bit products), and one exact
//!   conversion to f32 (one rounding). The ray is the contract's ray to within that rounding
//!   plus 2^(1−S) absolute (S = 29 while the screen half-extents are below 1, e.g. a 90°
//!   field of view; S = 21 for a half-extent of 132): more accurate than the f32 formula,
//!   whose `2(x + 0.5)/W − 1` cancels. Cameras whose screen extent does not fit (a field of
//!   view within ~10⁻⁸ of 180°, or an aspect ratio over 2²⁹) fall back to f32.
//!   A bare-metal image built without `fixed-raygen` skips this setup (it never uses it):
//!   there [`Camera::has_fixed_raygen`] is false.

use crate::fixed::{f32_to_fixed, fixed_to_f32, RayFormat};
use crate::sfloat::{self, add, mul, sub, vadd, vscale};
use gridrt_shared::math::{Ray, Vec3};

/// Why a camera could not be built. Bad inputs are refused here so that no NaN ray is ever
/// sent to the co-processor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraError {
    /// Eye, target or up has a NaN or infinite component.
    NonFinite,
    /// Eye and target coincide: there is no viewing direction.
    EyeIsTarget,
    /// Up is zero or parallel to the viewing direction: the camera frame is undefined.
    DegenerateUp,
    /// Field of view not inside (0°, 180°).
    BadFov,
    /// Width or height is zero.
    BadSize,
}

/// Smallest accepted `|forward × û|` (sine of the angle between view direction and up):
/// below it the right vector is dominated by rounding.
const MIN_UP_SINE: f32 = 1e-6;

/// A validated pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    cam_up: Vec3,
    half_w: f32,
    half_h: f32,
    width: f32,
    height: f32,
    fixed: Option<FixedRayGen>,
}

/// Per-frame state of fixed-point ray generation (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct FixedRayGen {
    /// forward, right, cam_up in Q2.30.
    basis: [[i64; 3]; 3],
    /// `sx = (sx0 + x·dx) >> 16`, `sy = (sy0 + y·dy) >> 16`, in Q(S) after the shift.
    sx0: i64,
    dx: i64,
    sy0: i64,
    dy: i64,
    /// Fractional bits S of the screen coordinates.
    s: u32,
}

impl FixedRayGen {
    /// Quantises a validated camera; `None` when its screen extent does not fit.
    fn new(forward: Vec3, right: Vec3, cam_up: Vec3, half_w: f32, half_h: f32, w: u32, h: u32) -> Option<Self> {
        let q30 = |v: Vec3| -> Option<[i64; 3]> {
            Some([f32_to_fixed(v.x, 30)?, f32_to_fixed(v.y, 30)?, f32_to_fixed(v.z, 30)?])
        };
        let basis = [q30(forward)?, q30(right)?, q30(cam_up)?];
        let m = half_w.max(half_h);
        // Largest S ≤ 29 with m·2^S < 2^29 (so |sx|, |sy| < 2^29 raw); m·2^S is exact in f32.
        let pow2 = |s: u32| f32::from_bits((127 + s) << 23);
        let mut s = 29u32;
        while s > 0 && m * pow2(s) >= pow2(29) {
            s -= 1;
        }
        if m * pow2(s) >= pow2(29) {
            return None;
        }
        // sx = (2(x + 0.5)/W − 1)·half_w = x·(2·half_w/W) + (half_w/W − half_w);
        // sy = (1 − 2(y + 0.5)/H)·half_h = y·(−2·half_h/H) + (half_h − half_h/H).
        // Each coefficient is rounded once, exactly, in integers (`round_scaled`).
        let q = |a: f32, num: u32, den: u32| round_scaled(a, s + 16, num, den);
        Some(Self {
            basis,
            sx0: -q(half_w, w - 1, w),
            dx: q(half_w, 2, w),
            sy0: q(half_h, h - 1, h),
            dy: -q(half_h, 2, h),
            s,
        })
    }

    /// The direction of pixel (x, y), integer arithmetic and one rounding per component.
    #[inline]
    fn direction(&self, x: u32, y: u32) -> Vec3 {
        let sx = (self.sx0 + x as i64 * self.dx) >> 16;
        let sy = (self.sy0 + y as i64 * self.dy) >> 16;
        let [f, r, u] = self.basis;
        let c = |i: usize| {
            let v = (f[i] << self.s) + sx * r[i] + sy * u[i];
            fixed_to_f32(v as i128, 30 + self.s as i32)
        };
        Vec3::new(c(0), c(1), c(2))
    }
}

/// `round(a · 2^shift · num / den)`, halves away from zero, computed exactly in integers
/// (no `f64`: the soft-core has no double arithmetic to spare), for finite `a ≥ 0`, `den ≥ 1`
/// and a result below 2^63 (here `a · 2^shift < 2^45` and `num / den ≤ 2`).
#[inline(never)]
fn round_scaled(a: f32, shift: u32, num: u32, den: u32) -> i64 {
    let bits = a.to_bits() & 0x7FFF_FFFF;
    let (exp, man) = ((bits >> 23) as i32, bits & 0x7F_FFFF);
    // a = man24 · 2^e exactly.
    let (man24, e) = if exp == 0 { (man, -149) } else { (man | 0x80_0000, exp - 150) };
    // p < 2^56; max(1): no division-by-zero panic path (callers pass den ≥ 1).
    let p = man24 as u64 * num as u64;
    let (den, sh) = (den.max(1) as u64, e + shift as i32);
    if sh < 0 {
        // p / (den · 2^k): zero once the divisor exceeds 2·p (any divisor ≥ 2^64 does).
        let k = sh.unsigned_abs();
        if k >= 64 || den > u64::MAX >> k {
            return 0;
        }
        let d = den << k;
        return (p + d / 2).checked_div(d).unwrap_or(0) as i64;
    }
    // Long division of p · 2^sh by den, at most 32 bits of the shift per step (r < 2^32).
    let (mut q, mut r, mut left) = (p / den, p % den, sh as u32);
    while left > 0 {
        let c = left.min(32);
        let t = r << c;
        q = (q << c) + t / den;
        r = t % den;
        left -= c;
    }
    (q + (2 * r >= den) as u64) as i64
}

impl Camera {
    /// Builds the camera of CONTRACTS.md: forward = normalize(target − eye),
    /// right = normalize(forward × up), cam_up = right × forward, half_h = tan(fov/2),
    /// half_w = half_h · W / H.
    pub fn new(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite() && fov_y_deg.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        if width == 0 || height == 0 {
            return Err(CameraError::BadSize);
        }
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(CameraError::BadFov);
        }
        // try_normalize refuses zero, subnormal-overflowing and non-finite lengths.
        let forward = (target - eye).try_normalize().ok_or(CameraError::EyeIsTarget)?;
        let up_n = up.try_normalize().ok_or(CameraError::DegenerateUp)?;
        let side = forward.cross(up_n);
        let sine = side.length();
        if sine.is_nan() || sine < MIN_UP_SINE {
            return Err(CameraError::DegenerateUp);
        }
        // CONTRACTS.md normalises forward × up (with the caller's up); the direction is the
        // same as forward × û, so normalising `side` gives the same vector.
        let right = side.try_normalize().ok_or(CameraError::DegenerateUp)?;
        let cam_up = right.cross(forward);
        // tan(fov/2) with the field of view in turns (fov/720 of a turn): `crate::fmath`.
        let half_h = crate::fmath::tan_turns(fov_y_deg / 720.0);
        let (w, h) = (width as f32, height as f32);
        let half_w = half_h * w / h;
        if !(half_h.is_finite() && half_w.is_finite() && half_w > 0.0) {
            return Err(CameraError::BadFov);
        }
        // The fixed-point setup only where it can be used: host builds (tests, benches, the
        // simulator's `primary_ray_in`) and images built with `fixed-raygen`. A bare-metal
        // f32 image (`target_os = "none"`) only calls `primary_ray` = f32, so it skips the
        // ~2 KB of setup code (the soft-core's 64 KiB code budget); its rays are unchanged.
        let fixed = if cfg!(any(feature = "fixed-raygen", not(target_os = "none"))) {
            FixedRayGen::new(forward, right, cam_up, half_w, half_h, width, height)
        } else {
            None
        };
        Ok(Self { eye, forward, right, cam_up, half_w, half_h, width: w, height: h, fixed })
    }

    /// Ray through the centre of pixel (x, y), x to the right, y down:
    /// sx = (2(x + 0.5)/W − 1)·half_w, sy = (1 − 2(y + 0.5)/H)·half_h,
    /// dir = forward + sx·right + sy·cam_up (not normalised), origin = eye.
    ///
    /// Pixels outside the image extrapolate the same formula (no error, no panic).
    /// Computed in the build's ray-generation format ([`RayFormat::DEFAULT`]).
    #[inline]
    pub fn primary_ray(&self, x: u32, y: u32) -> Ray {
        self.primary_ray_in(RayFormat::DEFAULT, x, y)
    }

    /// [`Camera::primary_ray`] in an explicit format (fixed point falls back to f32 for a
    /// camera whose screen extent does not fit, see the module doc).
    #[inline]
    pub fn primary_ray_in(&self, format: RayFormat, x: u32, y: u32) -> Ray {
        match (format, &self.fixed) {
            (RayFormat::Fixed, Some(f)) => Ray { origin: self.eye, dir: f.direction(x, y) },
            _ => self.primary_ray_f32(x, y),
        }
    }

    /// The rays of row `y`: [`Camera::primary_ray`] with the row's terms computed once.
    #[inline]
    pub fn row(&self, y: u32) -> RowRays<'_> {
        self.row_with(y, &[])
    }

    /// [`Camera::row`] with the column terms of columns `0..columns.len()` from `columns`
    /// (a [`ColumnTerms`] of this camera, [`ColumnTerms::terms`]).
    #[inline]
    pub fn row_with<'a>(&'a self, y: u32, columns: &'a [Vec3]) -> RowRays<'a> {
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / self.height) * self.half_h;
        RowRays { cam: self, y, sy_up: sy * self.cam_up, columns }
    }

    /// True when fixed-point ray generation is available for this camera.
    pub fn has_fixed_raygen(&self) -> bool {
        self.fixed.is_some()
    }

    #[inline]
    fn primary_ray_f32(&self, x: u32, y: u32) -> Ray {
        // Kept spelled out: the row form (`RowRays::ray`) is pinned against it.
        let sx = (2.0 * (x as f32 + 0.5) / self.width - 1.0) * self.half_w;
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / self.height) * self.half_h;
        Ray { origin: self.eye, dir: self.forward + sx * self.right + sy * self.cam_up }
    }

    /// The column's part of the f32 formula with the row term `sy·cam_up` given: the same
    /// operations in the same order, `(forward + sx·right) + sy·cam_up` ([`RowRays::ray`]).
    #[inline(always)]
    fn column_term(&self, x: u32) -> Vec3 {
        // 2·(x + 0.5) is 2x + 1, exact in f32 below x = 2^23: one conversion instead of a
        // conversion, an addition and a multiplication.
        let twice = if x < 1 << 23 { sfloat::u32_to_f32(2 * x + 1) } else { mul(2.0, add(sfloat::u32_to_f32(x), 0.5)) };
        let sx = mul(sub(sfloat::div(twice, self.width), 1.0), self.half_w);
        vadd(self.forward, vscale(self.right, sx))
    }

    /// The eye (origin of every primary ray).
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
    /// `(half_w, half_h, W, H)`: the screen half-extents at distance 1 and the image size.
    pub fn screen(&self) -> (f32, f32, f32, f32) {
        (self.half_w, self.half_h, self.width, self.height)
    }
    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }
    /// Unit right vector.
    pub fn right(&self) -> Vec3 {
        self.right
    }
    /// Unit camera-up vector (orthogonal to forward and right).
    pub fn up(&self) -> Vec3 {
        self.cam_up
    }
}

/// The primary rays of one row (from [`Camera::row`]): per pixel the column's terms only.
#[derive(Debug, Clone, Copy)]
pub struct RowRays<'a> {
    cam: &'a Camera,
    y: u32,
    /// `sy · cam_up` of the row.
    sy_up: Vec3,
    /// `forward + sx·right` of the first columns ([`ColumnTerms`]), or none.
    columns: &'a [Vec3],
}

impl RowRays<'_> {
    /// The row.
    #[inline]
    pub fn y(&self) -> u32 {
        self.y
    }

    /// [`Camera::primary_ray`]`(x, y)` of this row, bit for bit.
    #[inline]
    pub fn ray(&self, x: u32) -> Ray {
        match (RayFormat::DEFAULT, &self.cam.fixed) {
            (RayFormat::Fixed, Some(f)) => Ray { origin: self.cam.eye, dir: f.direction(x, self.y) },
            _ => {
                let column = match self.columns.get(x as usize) {
                    Some(&c) if COLUMN_TERMS > 0 => c,
                    _ => self.cam.column_term(x),
                };
                Ray { origin: self.cam.eye, dir: sfloat::vadd_often_zero(column, self.sy_up) }
            }
        }
    }
}

/// Columns a [`ColumnTerms`] holds: a 512-pixel-wide frame's (6 KiB); wider frames compute
/// the columns past it per pixel. None on a bare-metal hard-float image, which does not use
/// the table (`ColumnTerms::fill`).
pub const COLUMN_TERMS: usize = if cfg!(any(soft_float, not(target_os = "none"))) { 512 } else { 0 };

/// The column terms `forward + sx·right` of a camera's f32 rays, once per frame: on a
/// soft-float core a camera ray is then three additions (the column's term plus the row's),
/// where it was a division, six multiplications and six additions. The same f32 operations
/// on the same operands, so the same rays bit for bit.
#[derive(Debug, Clone)]
pub struct ColumnTerms {
    terms: [Vec3; COLUMN_TERMS],
    len: usize,
}

impl Default for ColumnTerms {
    fn default() -> Self {
        Self { terms: [Vec3::ZERO; COLUMN_TERMS], len: 0 }
    }
}

impl ColumnTerms {
    /// Fills the terms of columns `0..min(width, COLUMN_TERMS)` of `cam`; none when `on` is
    /// false (with an FPU the formula costs less than the table's upkeep).
    #[inline(never)]
    pub fn fill(&mut self, cam: &Camera, width: u16, on: bool) {
        self.len = if on { (width as usize).min(COLUMN_TERMS) } else { 0 };
        for (x, t) in self.terms.iter_mut().take(self.len).enumerate() {
            *t = cam.column_term(x as u32);
        }
    }

    /// The filled terms, column 0 first.
    pub fn terms(&self) -> &[Vec3] {
        self.terms.get(..self.len).unwrap_or(&[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn cam(w: u32, h: u32) -> Camera {
        Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 90.0, w, h).unwrap()
    }

    /// A row's rays are the camera's rays bit for bit (random cameras, sizes and pixels,
    /// pixels outside the image included).
    #[test]
    fn row_rays_equal_primary_rays() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xCA3E_0002);
        let mut checked = 0;
        for _ in 0..500 {
            let v = |rng: &mut ChaCha8Rng| {
                Vec3::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0))
            };
            let (eye, target, up) = (v(&mut rng), v(&mut rng), v(&mut rng));
            let fov = rng.gen_range(1.0..170.0f32);
            let (w, h) = (rng.gen_range(1..4097u32), rng.gen_range(1..4097u32));
            let Ok(c) = Camera::new(eye, target, up, fov, w, h) else { continue };
            for _ in 0..20 {
                let y = rng.gen_range(0..h + 8);
                let row = c.row(y);
                for _ in 0..20 {
                    let x = rng.gen_range(0..w + 8);
                    let (a, b) = (row.ray(x), c.primary_ray(x, y));
                    assert_eq!(a.origin.to_array().map(f32::to_bits), b.origin.to_array().map(f32::to_bits));
                    assert_eq!(a.dir.to_array().map(f32::to_bits), b.dir.to_array().map(f32::to_bits), "{x} {y}");
                    checked += 1;
                }
            }
            // Around and past 2^23, where the column term changes form.
            for x in [(1 << 23) - 1, 1 << 23, (1 << 23) + 1, u32::MAX] {
                let y = rng.gen_range(0..h);
                let (a, b) = (c.row(y).ray(x), c.primary_ray(x, y));
                assert_eq!(a.dir.to_array().map(f32::to_bits), b.dir.to_array().map(f32::to_bits), "{x} {y}");
            }
        }
        assert!(checked > 100_000, "{checked}");
    }

    /// A row whose column terms come from a [`ColumnTerms`] table gives the camera's rays bit
    /// for bit, inside the table and past it (random cameras; frames narrower and wider than
    /// the table).
    #[test]
    fn rows_from_column_terms_equal_primary_rays() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x0C01_7E53);
        let mut table = ColumnTerms::default();
        let mut checked = 0;
        for _ in 0..300 {
            let v = |rng: &mut ChaCha8Rng| {
                Vec3::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0))
            };
            let (eye, target, up) = (v(&mut rng), v(&mut rng), v(&mut rng));
            let fov = rng.gen_range(1.0..170.0f32);
            let (w, h) = (rng.gen_range(1..1200u16), rng.gen_range(1..1200u32));
            let Ok(c) = Camera::new(eye, target, up, fov, w as u32, h) else { continue };
            table.fill(&c, w, true);
            assert_eq!(table.terms().len(), (w as usize).min(COLUMN_TERMS));
            for _ in 0..10 {
                let y = rng.gen_range(0..h);
                let row = c.row_with(y, table.terms());
                for _ in 0..30 {
                    let x = rng.gen_range(0..w as u32);
                    let (a, b) = (row.ray(x), c.primary_ray(x, y));
                    assert_eq!(a.dir.to_array().map(f32::to_bits), b.dir.to_array().map(f32::to_bits), "{x} {y}");
                    checked += 1;
                }
            }
        }
        table.fill(&cam(320, 240), 320, false);
        assert!(table.terms().is_empty());
        assert!(checked > 50_000, "{checked}");
    }

    #[test]
    fn centre_pixel_of_odd_image_looks_straight_at_target() {
        let c = cam(3, 3);
        let r = c.primary_ray(1, 1);
        assert_eq!(r.origin, Vec3::new(0.0, 0.0, 5.0));
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    }

    #[test]
    fn corner_pixels_follow_contract_signs_x_right_y_down() {
        // 90° vertical FOV, 2×2 image: half_h = 1, half_w = 1; pixel centres at ±0.5.
        let c = cam(2, 2);
        let tl = c.primary_ray(0, 0).dir;
        assert!((tl - Vec3::new(-0.5, 0.5, -1.0)).length() < 1e-6, "{tl}");
        let br = c.primary_ray(1, 1).dir;
        assert!((br - Vec3::new(0.5, -0.5, -1.0)).length() < 1e-6, "{br}");
    }

    #[test]
    fn aspect_ratio_scales_horizontal_extent() {
        // W = 2H: half_w = 2·half_h.
        let c = cam(4, 2);
        let d = c.primary_ray(3, 0).dir; // sx = (2·3.5/4 − 1)·2 = 1.5, sy = 0.5
        assert!((d - Vec3::new(1.5, 0.5, -1.0)).length() < 1e-6, "{d}");
    }

    #[test]
    fn invalid_inputs_are_errors_not_nan_rays() {
        let e = Vec3::new(0.0, 0.0, 5.0);
        assert_eq!(Camera::new(e, e, Vec3::Y, 45.0, 4, 4), Err(CameraError::EyeIsTarget));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::ZERO, 45.0, 4, 4), Err(CameraError::DegenerateUp));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Z, 45.0, 4, 4), Err(CameraError::DegenerateUp));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Y, 0.0, 4, 4), Err(CameraError::BadFov));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Y, 180.0, 4, 4), Err(CameraError::BadFov));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Y, f32::NAN, 4, 4), Err(CameraError::NonFinite));
        assert_eq!(Camera::new(Vec3::NAN, Vec3::ZERO, Vec3::Y, 45.0, 4, 4), Err(CameraError::NonFinite));
        assert_eq!(Camera::new(e, Vec3::splat(f32::INFINITY), Vec3::Y, 45.0, 4, 4), Err(CameraError::NonFinite));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Y, 45.0, 0, 4), Err(CameraError::BadSize));
        assert_eq!(Camera::new(e, Vec3::ZERO, Vec3::Y, 45.0, 4, 0), Err(CameraError::BadSize));
    }

    /// Fixed-point ray generation reproduces the contract's formula, evaluated in f64 from the
    /// camera's own (f32) basis and screen extent, to within one rounding of the result plus
    /// its screen quantisation 2^-S; the f32 formula's own error is over 10× larger (its
    /// `2(x + 0.5)/W − 1` cancels). Seeded random cameras and pixels.
    #[test]
    fn fixed_raygen_matches_the_formula_to_one_rounding() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xF1C5_CA3E);
        let (mut worst_fixed, mut worst_f32, mut n) = (0.0f64, 0.0f64, 0);
        for _ in 0..20_000 {
            let v = |rng: &mut ChaCha8Rng| {
                Vec3::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0))
            };
            let (eye, target, up) = (v(&mut rng), v(&mut rng), v(&mut rng));
            let fov = rng.gen_range(1.0..170.0f32);
            let (w, h) = (rng.gen_range(1..4097u32), rng.gen_range(1..4097u32));
            let Ok(c) = Camera::new(eye, target, up, fov, w, h) else { continue };
            assert!(c.has_fixed_raygen());
            let (x, y) = (rng.gen_range(0..w), rng.gen_range(0..h));
            let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * c.half_w as f64;
            let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * c.half_h as f64;
            let f = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
            let (fw, rt, cu) = (f(c.forward), f(c.right), f(c.cam_up));
            let d: [f64; 3] = core::array::from_fn(|i| fw[i] + sx * rt[i] + sy * cu[i]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let fixed = c.primary_ray_in(RayFormat::Fixed, x, y);
            let float = c.primary_ray_in(RayFormat::F32, x, y);
            assert_eq!(fixed.origin, eye);
            // One f32 rounding of the result (≤ 2^-24·len) plus the screen quantisation 2^-S
            // of sx and sy (unit basis vectors), and the Q30 basis (2^-30 · (1 + |sx| + |sy|)).
            let s_bits = c.fixed.map(|f| f.s).unwrap_or(0);
            let bound = 1.2 * 2f64.powi(-24) * len + 2f64.powi(1 - s_bits as i32) + 2f64.powi(-29) * len;
            for (i, &di) in d.iter().enumerate() {
                let err = (fixed.dir[i] as f64 - di).abs();
                assert!(err <= bound, "{i}: {} vs {di} (S = {s_bits})", fixed.dir[i]);
                worst_fixed = worst_fixed.max(err / len);
                worst_f32 = worst_f32.max((float.dir[i] as f64 - di).abs() / len);
            }
            n += 1;
        }
        assert!(n > 15_000, "{n}");
        assert!(worst_f32 > 10.0 * worst_fixed, "f32 {worst_f32:e} vs fixed {worst_fixed:e}");
    }

    #[test]
    fn fixed_raygen_hits_the_worked_pixels_exactly() {
        // The literal cases of the f32 tests, in fixed point.
        let c = cam(3, 3);
        let r = c.primary_ray_in(RayFormat::Fixed, 1, 1);
        assert_eq!(r.dir, Vec3::new(0.0, 0.0, -1.0));
        let c = cam(2, 2);
        assert!((c.primary_ray_in(RayFormat::Fixed, 0, 0).dir - Vec3::new(-0.5, 0.5, -1.0)).length() < 1e-7);
        assert!((c.primary_ray_in(RayFormat::Fixed, 1, 1).dir - Vec3::new(0.5, -0.5, -1.0)).length() < 1e-7);
        // Extreme but valid: fov 179.9° on a 1×4096 image still fits Q(S).
        let wide = Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 179.9, 4096, 1).unwrap();
        assert!(wide.has_fixed_raygen());
        let r = wide.primary_ray_in(RayFormat::Fixed, 4095, 0);
        assert!(r.dir.is_finite());
        assert_eq!(RayFormat::DEFAULT, if cfg!(feature = "fixed-raygen") { RayFormat::Fixed } else { RayFormat::F32 });
    }

    #[test]
    fn random_valid_cameras_give_finite_rays_matching_f64_formula() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xCA3E_0001);
        let mut checked = 0;
        for _ in 0..2000 {
            let v = |rng: &mut ChaCha8Rng| {
                Vec3::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0))
            };
            let (eye, target, up) = (v(&mut rng), v(&mut rng), v(&mut rng));
            let fov = rng.gen_range(1.0..170.0f32);
            let (w, h) = (rng.gen_range(1..4097u32), rng.gen_range(1..4097u32));
            let Ok(c) = Camera::new(eye, target, up, fov, w, h) else { continue };
            let (x, y) = (rng.gen_range(0..w), rng.gen_range(0..h));
            let r = c.primary_ray(x, y);
            assert!(r.is_valid());
            // f64 re-implementation of CONTRACTS.md.
            let f = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
            let (e, t, u) = (f(eye), f(target), f(up));
            let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            let cross = |a: [f64; 3], b: [f64; 3]| {
                [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
            };
            let norm = |a: [f64; 3]| {
                let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                [a[0] / l, a[1] / l, a[2] / l]
            };
            let fw = norm(sub(t, e));
            let rt = norm(cross(fw, u));
            let cu = cross(rt, fw);
            let hh = (fov as f64).to_radians().mul_add(0.5, 0.0).tan();
            let hw = hh * w as f64 / h as f64;
            let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * hw;
            let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * hh;
            let d: [f64; 3] = core::array::from_fn(|i| fw[i] + sx * rt[i] + sy * cu[i]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            for i in 0..3 {
                // Relative to the ray's length; loose for near-parallel up vectors.
                assert!((r.dir[i] as f64 - d[i]).abs() <= 1e-3 * len, "{:?} vs {d:?}", r.dir);
            }
            checked += 1;
        }
        assert!(checked > 1900);
    }

    #[test]
    fn round_scaled_rounds_exactly_halves_away_from_zero() {
        assert_eq!(round_scaled(0.5, 0, 1, 1), 1);
        assert_eq!(round_scaled(2.5, 0, 1, 1), 3);
        assert_eq!(round_scaled(0.75, 0, 1, 2), 0);
        assert_eq!(round_scaled(1.0, 0, 1, 2), 1);
        assert_eq!(round_scaled(1.0, 45, 2, 3), 23_456_248_059_221); // 2^46/3 = ….33
        assert_eq!(round_scaled(1.0, 0, 1, 3), 0);
        assert_eq!(round_scaled(f32::from_bits(1), 45, 2, 1), 0);
        assert_eq!(round_scaled(0.0, 45, 2, 1), 0);
        // Against f64 (exact for these sizes up to its one rounding): equal, or one apart
        // only where f64's rounding of the quotient lands on the other side of a half.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..20_000 {
            let a: f32 = rng.gen_range(1e-9f32..300.0);
            let shift = rng.gen_range(16..=45u32);
            let den = rng.gen_range(1..=5000u32);
            let num = if rng.gen_bool(0.5) { 2 } else { den - 1 };
            let exact = a as f64 * 2f64.powi(shift as i32) * num as f64 / den as f64;
            if exact >= 2f64.powi(46) {
                continue;
            }
            let got = round_scaled(a, shift, num, den);
            let want = exact.round() as i64;
            let near_half = ((exact - exact.trunc()) - 0.5).abs() < 1e-6;
            assert!(got == want || near_half, "{a} {shift} {num}/{den}: {got} vs {exact}");
        }
    }
}
