//! Hit geometry both shading and the shadow/reflection rays need: the hit point, the normal
//! facing the ray, and the offset shadow-ray origin (docs/CONTRACTS.md § Shading).

use crate::fmath::try_normalize;
use crate::sfloat::{add, dot, mul, vadd, vscale, vsub};
use gridrt_shared::math::{Ray, Vec3};

/// Shadow rays end just before the light: t_max = 1 − 2^-10 on the direction `light − p'`,
/// so the light itself is never an occluder.
pub const SHADOW_T_MAX: f32 = 1.0 - 1.0 / 1024.0;

/// Relative part of the shadow-origin offset: 1e-4 · |grid box diagonal|.
pub const SHADOW_EPS_DIAG: f32 = 1e-4;

/// Magnitude part of the shadow-origin offset: 2^-20 · |p|∞ (covers the f32 rounding of p).
pub const SHADOW_EPS_POS: f32 = 1.0 / (1u32 << 20) as f32;

/// Hit point `p = o + t·d` (d not normalised).
#[inline]
pub fn hit_point(ray: &Ray, t: f32) -> Vec3 {
    vadd(ray.origin, vscale(ray.dir, t))
}

/// Unit shading normal, flipped to face the ray (two-sided: if n·d > 0 then n = −n).
/// `None` for a zero or non-finite normal (degenerate triangle); the caller then uses
/// ambient light only.
#[inline]
pub fn facing_normal(normal: [f32; 3], dir: Vec3) -> Option<Vec3> {
    let n = try_normalize(Vec3::from_array(normal))?;
    // On a soft-float core the sign in integers where that is certain (`super::dot_sign`).
    let towards = match cfg!(soft_float).then(|| super::dot_sign(n, dir)).flatten() {
        Some(positive) => positive,
        None => dot(n, dir) > 0.0,
    };
    Some(if towards { -n } else { n })
}

/// `p.abs().max_element()` of glam: on the bits (the order of non-negative floats) when no
/// component is NaN, else glam's NaN-ignoring `max`.
#[inline(always)]
fn max_abs(p: Vec3) -> f32 {
    let b = p.to_array().map(|c| c.to_bits() & 0x7FFF_FFFF);
    if b.iter().all(|&x| x <= 0x7F80_0000) {
        f32::from_bits(b[0].max(b[1]).max(b[2]))
    } else {
        p.abs().max_element()
    }
}

/// Shadow-origin offset ε = 1e-4 · |grid box diagonal| + 2^-20 · |p|∞.
#[inline]
pub fn shadow_epsilon(grid_diag_len: f32, p: Vec3) -> f32 {
    shadow_epsilon_from(SHADOW_EPS_DIAG * grid_diag_len, p)
}

/// [`shadow_epsilon`] with its per-scene term `1e-4 · |grid box diagonal|` computed already.
#[inline]
pub fn shadow_epsilon_from(diag_term: f32, p: Vec3) -> f32 {
    add(diag_term, mul(SHADOW_EPS_POS, max_abs(p)))
}

/// Shadow ray: origin p' = p + n·ε, direction L' = light − p' (not normalised); trace it
/// over `[0, SHADOW_T_MAX]` as an any-hit query. The light is visible when nothing is hit.
#[inline]
pub fn shadow_ray(p: Vec3, n: Vec3, light_pos: Vec3, grid_diag_len: f32) -> Ray {
    shadow_ray_from(p, n, light_pos, SHADOW_EPS_DIAG * grid_diag_len)
}

/// [`shadow_ray`] with the per-scene term of [`shadow_epsilon_from`].
#[inline]
pub fn shadow_ray_from(p: Vec3, n: Vec3, light_pos: Vec3, diag_term: f32) -> Ray {
    let origin = vadd(p, vscale(n, shadow_epsilon_from(diag_term, p)));
    Ray { origin, dir: vsub(light_pos, origin) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_faces_the_ray_from_either_side() {
        let d = Vec3::new(0.0, 0.0, -1.0);
        assert_eq!(facing_normal([0.0, 0.0, 2.0], d), Some(Vec3::Z));
        assert_eq!(facing_normal([0.0, 0.0, -2.0], d), Some(Vec3::Z));
        assert_eq!(facing_normal([0.0; 3], d), None);
        assert_eq!(facing_normal([f32::NAN, 0.0, 1.0], d), None);
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
}
