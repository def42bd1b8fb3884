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
    Some(facing(try_normalize(Vec3::from_array(normal))?, dir))
}

/// The unit normal `n` flipped to face the ray (the second half of [`facing_normal`]).
#[inline]
pub fn facing(n: Vec3, dir: Vec3) -> Vec3 {
    // On a soft-float core the sign in integers where that is certain (`super::dot_sign`).
    let towards = match cfg!(soft_float).then(|| super::dot_sign(n, dir)).flatten() {
        Some(positive) => positive,
        None => dot(n, dir) > 0.0,
    };
    if towards {
        -n
    } else {
        n
    }
}

/// Slots of [`UnitNormals`] (direct-mapped by primitive id); one on a bare-metal hard-float
/// image, which does not use it.
const NORMAL_SLOTS: usize = if cfg!(any(soft_float, not(target_os = "none"))) { 32 } else { 1 };

/// The unit normals of recent hits by primitive: neighbouring pixels mostly hit the same
/// triangle, whose normal the co-processor returns with the same bits each time, and
/// normalising it is a square root, a division and eight other f32 operations (~500
/// instructions on a soft-float core). A slot answers only for the same primitive id and
/// the same normal bits, with the value [`try_normalize`] gave for them: the same normal.
#[derive(Debug, Clone)]
pub struct UnitNormals {
    slots: [NormalSlot; NORMAL_SLOTS],
}

#[derive(Debug, Clone, Copy, Default)]
struct NormalSlot {
    filled: bool,
    prim: u32,
    normal: [u32; 3],
    unit: Option<Vec3>,
}

impl Default for UnitNormals {
    fn default() -> Self {
        Self { slots: [NormalSlot::default(); NORMAL_SLOTS] }
    }
}

impl UnitNormals {
    /// `try_normalize(normal)` for a hit on primitive `prim`, from the slot when it holds them.
    #[inline]
    pub fn unit(&mut self, prim: u32, normal: [f32; 3]) -> Option<Vec3> {
        let bits = normal.map(f32::to_bits);
        let slot = self.slots.get_mut(prim as usize % NORMAL_SLOTS)?;
        // Word by word: `==` on the arrays is a `memcmp` call.
        let [a, b, c] = slot.normal;
        if slot.filled && slot.prim == prim && a == bits[0] && b == bits[1] && c == bits[2] {
            return slot.unit;
        }
        let unit = try_normalize(Vec3::from_array(normal));
        *slot = NormalSlot { filled: true, prim, normal: bits, unit };
        unit
    }
}

/// `p.abs().max_element()` of glam: on the bits (the order of non-negative floats) when no
/// component is NaN, else glam's NaN-ignoring `max`.
#[inline(always)]
fn max_abs(p: Vec3) -> f32 {
    // The components written out (an array `map` and `all` became two loops through memory
    // with an FPU); the largest magnitude's bits are at most +∞'s exactly when none is NaN.
    let abs = |c: f32| c.to_bits() & 0x7FFF_FFFF;
    let m = abs(p.x).max(abs(p.y)).max(abs(p.z));
    if m <= 0x7F80_0000 {
        f32::from_bits(m)
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
    add(diag_term, times_eps_pos(max_abs(p)))
}

/// `SHADOW_EPS_POS · x` for `x ≥ 0` (or NaN): a product by 2⁻²⁰ is exact while it stays
/// normal, so for a biased exponent of 21..=254 it is the exponent lowered by 20 (no `mul`
/// call on a soft-float core); the rest goes to `mul`.
#[inline(always)]
fn times_eps_pos(x: f32) -> f32 {
    if cfg!(soft_float) {
        eps_pos_by_exponent(x)
    } else {
        mul(SHADOW_EPS_POS, x)
    }
}

/// [`times_eps_pos`] on a soft-float core.
#[inline(always)]
fn eps_pos_by_exponent(x: f32) -> f32 {
    let b = x.to_bits();
    if (21..255).contains(&(b >> 23)) {
        f32::from_bits(b - (20 << 23))
    } else {
        mul(SHADOW_EPS_POS, x)
    }
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

    /// The cache gives `try_normalize`'s bits for every lookup: random primitives (many
    /// sharing slots) with normals that change for the same primitive now and then (all
    /// components or one), zero and NaN normals included.
    #[test]
    fn unit_normals_equal_try_normalize() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x0A17_0123);
        let mut cache = UnitNormals::default();
        let mut normals: Vec<[f32; 3]> = (0..200).map(|_| [0; 3].map(|_| rng.gen_range(-4.0..4.0f32))).collect();
        normals[7] = [0.0; 3];
        normals[9] = [f32::NAN, 1.0, 0.0];
        let (mut hits, mut lookups) = (0, 0);
        for _ in 0..100_000 {
            let prim = rng.gen_range(0..200u32);
            if rng.gen_bool(0.01) {
                normals[prim as usize] = [0; 3].map(|_| rng.gen_range(-4.0..4.0f32));
            } else if rng.gen_bool(0.02) {
                // One component changed alone: the slot must compare every word.
                normals[prim as usize][rng.gen_range(0..3)] = rng.gen_range(-4.0..4.0f32);
            }
            let normal = normals[prim as usize];
            let slot = cache.slots[prim as usize % NORMAL_SLOTS];
            hits += u32::from(slot.filled && slot.prim == prim && slot.normal == normal.map(f32::to_bits));
            lookups += 1;
            let want = try_normalize(Vec3::from_array(normal)).map(|v| v.to_array().map(f32::to_bits));
            assert_eq!(cache.unit(prim, normal).map(|v| v.to_array().map(f32::to_bits)), want, "{prim} {normal:?}");
        }
        assert!(hits > 1000 && hits < lookups, "{hits} of {lookups}");
    }

    /// The exponent shift gives `mul`'s product for every non-negative f32 whose shift it
    /// takes, and the boundary cases around it.
    #[test]
    fn eps_pos_product_equals_the_multiplication() {
        assert_eq!(SHADOW_EPS_POS, 2f32.powi(-20));
        let edges = [0, 1, 0x0A00_0000, 0x0A7F_FFFF, 0x0A80_0000, 0x7F7F_FFFF, 0x7F80_0000, 0x7FC0_0000];
        for b in (0..0x7F80_0000u32).step_by(97).chain(0x0A00_0000..0x0A80_0100).chain(edges) {
            let x = f32::from_bits(b);
            let want = SHADOW_EPS_POS * x;
            assert!(eps_pos_by_exponent(x).to_bits() == want.to_bits() || want.is_nan(), "{x:e}");
            assert!(times_eps_pos(x).to_bits() == want.to_bits() || want.is_nan(), "{x:e}");
        }
    }

    /// `max_abs` on the bits gives glam's `p.abs().max_element()` bit for bit: random
    /// components of every sign and class (zeros, subnormals, normals, ±∞, NaN).
    #[test]
    fn max_abs_equals_glams_largest_magnitude() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x03A8_0AB5);
        let special = [0, 0x8000_0000, 1, 0x807F_FFFF, 0x7F80_0000, 0xFF80_0000, 0x7FC0_0000, 0x3F80_0000];
        for _ in 0..20_000 {
            let c =
                [(); 3].map(|_| if rng.gen_bool(0.2) { special[rng.gen_range(0..special.len())] } else { rng.gen() });
            let p = Vec3::from_array(c.map(f32::from_bits));
            let (got, want) = (max_abs(p), p.abs().max_element());
            assert!(got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()), "{p:?}: {got:e} {want:e}");
        }
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
