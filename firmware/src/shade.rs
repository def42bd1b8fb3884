//! Shading: ambient + Lambert diffuse from one point light, optionally shadowed.
//!
//! Every formula here is pinned in `docs/CONTRACTS.md` § Shading, because the host's f64
//! reference renderer re-implements it; change both together. The stage structure (a shading
//! stage that the build can switch off, here the shadow ray behind the `shadows` cargo
//! feature) follows ViRAY's compile-time stage switches (seed 000).
//!
//! These are pure functions; the device (`crate::device`) calls them and owns the rays.

use gridrt_shared::math::{Ray, Vec3};

/// Background colour of a miss (linear RGB).
pub const BACKGROUND: [f32; 3] = [0.08, 0.08, 0.12];

/// Albedo of material 0 when the scene has no material table, and of any material index the
/// table does not hold.
pub const DEFAULT_ALBEDO: [f32; 3] = [0.8, 0.8, 0.8];

/// Shadow rays end just before the light: t_max = 1 − 2^-10 on the direction `light − p'`,
/// so the light itself is never an occluder.
pub const SHADOW_T_MAX: f32 = 1.0 - 1.0 / 1024.0;

/// Relative part of the shadow-origin offset: 1e-4 · |grid box diagonal|.
pub const SHADOW_EPS_DIAG: f32 = 1e-4;

/// Magnitude part of the shadow-origin offset: 2^-20 · |p|∞ (covers the f32 rounding of p).
pub const SHADOW_EPS_POS: f32 = 1.0 / (1u32 << 20) as f32;

/// Point light and ambient term of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Light position.
    pub pos: Vec3,
    /// Scale of the diffuse term.
    pub intensity: f32,
    /// Ambient term.
    pub ambient: f32,
}

/// Hit point `p = o + t·d` (d not normalised).
#[inline]
pub fn hit_point(ray: &Ray, t: f32) -> Vec3 {
    ray.origin + ray.dir * t
}

/// Unit shading normal, flipped to face the ray (two-sided: if n·d > 0 then n = −n).
/// `None` for a zero or non-finite normal (degenerate triangle); the caller then uses
/// ambient light only.
#[inline]
pub fn facing_normal(normal: [f32; 3], dir: Vec3) -> Option<Vec3> {
    let n = Vec3::from_array(normal).try_normalize()?;
    Some(if n.dot(dir) > 0.0 { -n } else { n })
}

/// `ndotl = max(0, n·l)` with `l = (light − p)/|light − p|`; 0 when the light sits on p.
#[inline]
pub fn n_dot_l(p: Vec3, n: Vec3, light_pos: Vec3) -> f32 {
    match (light_pos - p).try_normalize() {
        // f32::max returns the non-NaN operand, so a NaN product gives 0.
        Some(l) => n.dot(l).max(0.0),
        None => 0.0,
    }
}

/// Shadow-origin offset ε = 1e-4 · |grid box diagonal| + 2^-20 · |p|∞.
#[inline]
pub fn shadow_epsilon(grid_diag_len: f32, p: Vec3) -> f32 {
    SHADOW_EPS_DIAG * grid_diag_len + SHADOW_EPS_POS * p.abs().max_element()
}

/// Shadow ray: origin p' = p + n·ε, direction L' = light − p' (not normalised); trace it
/// over `[0, SHADOW_T_MAX]` as an any-hit query. The light is visible when nothing is hit.
#[inline]
pub fn shadow_ray(p: Vec3, n: Vec3, light_pos: Vec3, grid_diag_len: f32) -> Ray {
    let origin = p + n * shadow_epsilon(grid_diag_len, p);
    Ray { origin, dir: light_pos - origin }
}

/// colour = albedo · (ambient + intensity · ndotl · visible), per channel, clamped to [0, 1]
/// (NaN → 0).
#[inline]
pub fn lambert(albedo: [f32; 3], light: &Light, ndotl: f32, visible: bool) -> [f32; 3] {
    let lit = light.ambient + light.intensity * ndotl * if visible { 1.0 } else { 0.0 };
    albedo.map(|a| clamp01(a * lit))
}

/// Clamps to [0, 1]; NaN becomes 0.
#[inline]
pub fn clamp01(c: f32) -> f32 {
    if c.is_nan() {
        0.0
    } else {
        c.clamp(0.0, 1.0)
    }
}

/// 8-bit channel: `(c · 255 + 0.5) as u8` on the clamped linear value (no gamma).
#[inline]
pub fn to_u8(c: f32) -> u8 {
    (clamp01(c) * 255.0 + 0.5) as u8
}

/// [`to_u8`] per channel.
#[inline]
pub fn to_rgb8(c: [f32; 3]) -> [u8; 3] {
    c.map(to_u8)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn background_encodes_to_contract_bytes() {
        // 0.08·255 + 0.5 = 20.9 → 20; 0.12·255 + 0.5 = 31.1 → 31.
        assert_eq!(to_rgb8(BACKGROUND), [20, 20, 31]);
    }

    #[test]
    fn eight_bit_rounding_is_round_half_up_and_clamped() {
        assert_eq!(to_u8(0.0), 0);
        assert_eq!(to_u8(1.0), 255);
        assert_eq!(to_u8(2.0), 255);
        assert_eq!(to_u8(-1.0), 0);
        assert_eq!(to_u8(f32::NAN), 0);
        assert_eq!(to_u8(0.5 / 255.0), 1);
        assert_eq!(to_u8(0.49 / 255.0), 0);
    }

    #[test]
    fn normal_faces_the_ray_from_either_side() {
        let d = Vec3::new(0.0, 0.0, -1.0);
        assert_eq!(facing_normal([0.0, 0.0, 2.0], d), Some(Vec3::Z));
        assert_eq!(facing_normal([0.0, 0.0, -2.0], d), Some(Vec3::Z));
        assert_eq!(facing_normal([0.0; 3], d), None);
        assert_eq!(facing_normal([f32::NAN, 0.0, 1.0], d), None);
    }

    #[test]
    fn lambert_matches_contract_formula() {
        let light = Light { pos: Vec3::new(0.0, 0.0, 10.0), intensity: 1.0, ambient: 0.15 };
        let p = Vec3::ZERO;
        let ndotl = n_dot_l(p, Vec3::Z, light.pos);
        assert_eq!(ndotl, 1.0);
        let lit = lambert([0.8; 3], &light, ndotl, true);
        assert!((lit[0] - 0.92).abs() < 1e-6);
        // 0.92·255 + 0.5 = 235.1 → 235.
        assert_eq!(to_rgb8(lit), [235, 235, 235]);
    }

    #[test]
    fn shadowed_point_gets_ambient_only() {
        let light = Light { pos: Vec3::new(0.0, 0.0, 10.0), intensity: 1.0, ambient: 0.15 };
        let c = lambert([0.8, 0.4, 0.2], &light, 1.0, false);
        assert!((c[0] - 0.12).abs() < 1e-6 && (c[1] - 0.06).abs() < 1e-6 && (c[2] - 0.03).abs() < 1e-6);
    }

    #[test]
    fn light_behind_surface_gives_zero_ndotl() {
        assert_eq!(n_dot_l(Vec3::ZERO, Vec3::Z, Vec3::new(0.0, 0.0, -3.0)), 0.0);
        assert_eq!(n_dot_l(Vec3::ZERO, Vec3::Z, Vec3::ZERO), 0.0);
    }

    #[test]
    fn shadow_origin_is_offset_along_normal_by_contract_epsilon() {
        let p = Vec3::new(4.0, -8.0, 2.0);
        let diag = 10.0;
        let eps = 1e-4 * 10.0 + 8.0 / 1048576.0;
        assert_eq!(shadow_epsilon(diag, p), eps);
        let light = Vec3::new(0.0, 10.0, 0.0);
        let r = shadow_ray(p, Vec3::Y, light, diag);
        assert_eq!(r.origin, Vec3::new(4.0, -8.0 + eps, 2.0));
        assert_eq!(r.dir, light - r.origin);
        // t_max stops short of the light.
        assert!(SHADOW_T_MAX < 1.0 && SHADOW_T_MAX == 1.0 - 2f32.powi(-10));
    }

    #[test]
    fn random_shading_inputs_never_give_nan_or_out_of_range() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5AD3);
        for _ in 0..10_000 {
            let mut f = || if rng.gen_bool(0.05) { f32::NAN } else { rng.gen_range(-10.0..10.0f32) };
            let n = facing_normal([f(), f(), f()], Vec3::new(f(), f(), f()));
            let ndotl = n.map_or(0.0, |n| n_dot_l(Vec3::new(f(), f(), f()), n, Vec3::new(f(), f(), f())));
            assert!((0.0..=1.0 + 1e-6).contains(&ndotl), "{ndotl}");
            let light = Light { pos: Vec3::ZERO, intensity: f(), ambient: f() };
            let c = lambert([f(), f(), f()], &light, ndotl, rng.gen());
            assert!(c.iter().all(|v| (0.0..=1.0).contains(v)), "{c:?}");
        }
    }
}
