//! The light's factor `max(n·l, 0)` at a hit, estimated in integers for the fixed-point
//! 8-bit rule ([`MatteBytes`](super::MatteBytes)).
//!
//! [`irradiance_toward`](super::irradiance_toward) (no falloff) computes `l = d/|d|` with a
//! square root, a division and three multiplications, then `n·l`: on a soft-float core
//! about 800 instructions. A matte camera hit needs of it only whether the factor is positive
//! (a shadow ray is traced) and its value to within the byte rule's margin. Here `n` and `d`
//! become 30-bit fixed point (`d` scaled by its largest component), `n·d` and `|d|²` are
//! exact 64-bit integer sums, and `1/|d|` comes from a 48-entry table and three Newton steps.
//!
//! **Bound.** With f32 inputs `n` (a unit normal as `try_normalize` gives it) and `d`, the
//! f32 factor is within 7.6u of the real `n·d/|d|` (u = 2⁻²⁴: 4.5u on each component of the
//! light vector — `|d|²`, the square root, the reciprocal, the product — and 3u for the dot
//! product's roundings, on unit vectors), and the estimate within 2⁻²⁵ (truncations to 2⁻²⁹
//! and the reciprocal square root's), so the two differ by less than 2⁻²⁰
//! ([`FACTOR_ERROR`]). [`light_factor`] answers only when the estimate is more than 2⁻¹⁹
//! from 0: then the f32 factor has the estimate's sign. Pinned by
//! `light_factor_is_within_its_bound_of_the_f32_factor`.

use gridrt_shared::math::Vec3;

/// The estimate's distance from 0 below which the f32 factor decides (2⁻¹⁹ in 2.30).
const UNSURE: i64 = 1 << 11;

/// Bound on the difference between the estimate and the f32 factor, as a power of two:
/// 2⁻²⁰ (module doc).
pub const FACTOR_ERROR: u32 = 20;

/// What the estimate says about the f32 factor `max(n·l, 0)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightFactor {
    /// Positive, this value·2⁻³⁰ within 2⁻²⁰ ([`FACTOR_ERROR`]) of the f32 factor.
    Lit(u32),
    /// Zero: the light is behind the surface.
    Unlit,
    /// Too close to 0 to tell, or inputs outside the estimate's range: compute it in f32.
    Unsure,
}

/// `2⁴⁶/√h` for `h` at the middle of each of the 48 intervals `[k·2²⁶, (k+1)·2²⁶)`,
/// k = 16..64 (the initial value of the Newton steps, within 2⁻⁶; each step squares the
/// relative error and multiplies it by 3/2: 2⁻¹¹, 2⁻²², then the truncations' 2⁻²⁹).
const RSQRT: [u32; 48] = {
    let mut t = [0u32; 48];
    let mut i = 0;
    while i < 48 {
        // h = (2k + 1)·2^25, k = i + 16; floor(√h) by bisection.
        let h = ((2 * (i as u64 + 16)) + 1) << 25;
        let (mut lo, mut hi) = (0u64, 1u64 << 32);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid * mid <= h {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        t[i] = ((1u64 << 46) / lo) as u32;
        i += 1;
    }
    t
};

/// A normal component `c` (|c| < 2) as `c·2²⁹` truncated; `None` from 2 up (and NaN).
#[inline(always)]
fn q29_of_unit(c: f32) -> Option<i32> {
    let bits = c.to_bits();
    let abs = bits & 0x7FFF_FFFF;
    if abs >= 0x4000_0000 {
        return None;
    }
    let exp = abs >> 23;
    let sig = (abs & 0x007F_FFFF) | 0x0080_0000;
    // c·2^29 = sig·2^(exp − 121).
    let v = if exp >= 121 {
        sig << (exp - 121)
    } else if exp > 121 - 31 {
        sig >> (121 - exp)
    } else {
        0
    };
    // v < 2^30: the magnitude and its negation are i32s.
    let v = v as i32;
    Some(if bits >> 31 != 0 { -v } else { v })
}

/// A component of `d` as `c·2^(156 − e_max)` truncated (below 2³⁰ in magnitude), for the
/// largest biased exponent `e_max` of the three.
#[inline(always)]
fn scaled(c: f32, e_max: u32) -> i32 {
    let bits = c.to_bits();
    let abs = bits & 0x7FFF_FFFF;
    let exp = abs >> 23;
    let shift = e_max - exp;
    let v = if exp == 0 || shift >= 31 { 0 } else { (((abs & 0x007F_FFFF) | 0x0080_0000) << 6) >> shift };
    // v < 2^30, as in `q29_of_unit`.
    let v = v as i32;
    if bits >> 31 != 0 {
        -v
    } else {
        v
    }
}

/// `a·b` of two values below 2³⁰ in magnitude, widened: one `mul` and one `mulh` on a 32-bit
/// core (an i64 product of i64 operands is four multiplications and their carries).
#[inline(always)]
fn wide(a: i32, b: i32) -> i64 {
    i64::from(a) * i64::from(b)
}

/// The light's factor at a hit with unit normal `n` and light offset `d = light − p` (module
/// doc).
pub fn light_factor(n: Vec3, d: Vec3) -> LightFactor {
    let (n, d) = (n.to_array(), d.to_array());
    let (Some(n0), Some(n1), Some(n2)) = (q29_of_unit(n[0]), q29_of_unit(n[1]), q29_of_unit(n[2])) else {
        return LightFactor::Unsure;
    };
    let e_max =
        (d[0].to_bits() & 0x7FFF_FFFF).max(d[1].to_bits() & 0x7FFF_FFFF).max(d[2].to_bits() & 0x7FFF_FFFF) >> 23;
    // |d| between 2^-60 and 2^60: its f32 square neither overflows nor underflows, so the f32
    // light vector exists (and NaN and ∞ are out).
    if !(67..=187).contains(&e_max) {
        return LightFactor::Unsure;
    }
    let (d0, d1, d2) = (scaled(d[0], e_max), scaled(d[1], e_max), scaled(d[2], e_max));
    // Both sums are exact: products below 2^60, the largest |d| component at least 2^29.
    let s = wide(n0, d0) + wide(n1, d1) + wide(n2, d2);
    let q = (wide(d0, d0) + wide(d1, d1) + wide(d2, d2)) as u64;
    // q in [2^58, 2^62): to [2^60, 2^62) by an even shift, then h = q/2^30 in [2^30, 2^32).
    let j = u32::from(q < 1 << 60);
    let h = ((q << (2 * j)) >> 30) as u32;
    // y ≈ 2^46/√h: the table, then three Newton steps y·(3 − h·y²/2^92)/2.
    let idx = ((h >> 26) as usize).wrapping_sub(16);
    // In u32 with u32 × u32 → u64 products (`mul` and `mulhu`): y ≤ 2^31 from the table, and
    // a Newton step never lands above 2^46/√h (r(3 − r²)/2 ≤ 1 for r = y·√h/2^46) but for
    // its truncations, so y < 2^32 throughout; y²/2^32 ≤ 2^30, w < 2^32.
    let mut y = RSQRT.get(idx).copied().unwrap_or(1 << 30);
    for _ in 0..3 {
        let y2 = ((u64::from(y) * u64::from(y)) >> 32) as u32; // y²/2^32 < 2^30
        let hy2 = (u64::from(h) * u64::from(y2)) >> 28; // h·y²/2^60 ≈ 2^32
        let w = ((3u64 << 32).saturating_sub(hy2) >> 2) as u32; // (3 − h·y²/2^92)·2^30
        y = ((u64::from(y) * u64::from(w)) >> 31) as u32;
    }
    // e·2^30 = 2·s/√q = (s/2^30)·y·2^(j − 30): |s/2^30| ≤ 2^30.
    let e30 = ((s >> 30) * i64::from(y)) >> (30 - j);
    if e30 > UNSURE {
        LightFactor::Lit(e30.min(i64::from(u32::MAX)) as u32)
    } else if e30 < -UNSURE {
        LightFactor::Unlit
    } else {
        LightFactor::Unsure
    }
}

/// The sign of the f32 dot product `sfloat::dot(n, v) > 0` for a unit normal `n`, in
/// integers: `n·v` from the same 30-bit fixed point as [`light_factor`] (`v` scaled by its
/// largest component `v_max`), exact to 6·2³⁰ units of 2⁻²⁹·v_max·2⁻³⁰; the f32 dot product
/// is within 3.01u·3·v_max of the real one (three roundings on terms up to v_max), under
/// 2³⁹ of those units (for v_max ≥ 2⁻¹⁰⁰: no underflow that matters). `None` within 2³⁹
/// of 0, or for a `v` below 2⁻¹⁰⁰, ∞ or NaN
/// (the caller computes the f32 dot product). Pinned by
/// `dot_sign_is_the_f32_dot_products_sign`.
pub fn dot_sign(n: Vec3, v: Vec3) -> Option<bool> {
    let (n, v) = (n.to_array(), v.to_array());
    let (n0, n1, n2) = (q29_of_unit(n[0])?, q29_of_unit(n[1])?, q29_of_unit(n[2])?);
    let e_max =
        (v[0].to_bits() & 0x7FFF_FFFF).max(v[1].to_bits() & 0x7FFF_FFFF).max(v[2].to_bits() & 0x7FFF_FFFF) >> 23;
    // v_max ≥ 2^-100: the f32 products' underflow (2^-150 each) is far below 3.01u·v_max.
    if !(27..255).contains(&e_max) {
        return None;
    }
    let s = wide(n0, scaled(v[0], e_max)) + wide(n1, scaled(v[1], e_max)) + wide(n2, scaled(v[2], e_max));
    if s > 1 << 39 {
        Some(true)
    } else if s < -(1 << 39) {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use crate::fmath::try_normalize;
    use crate::shade::light::irradiance_toward;
    use gridrt_shared::scene::{Falloff, LightingRecord};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Where the estimate answers, the f32 factor of `irradiance_toward` has its sign and lies
    /// within 2⁻²⁰ of it: random normals and light offsets over 2⁻⁴⁰..2⁴⁰, offsets nearly in
    /// the tangent plane, and axis-aligned cases; and it answers for nearly all of them.
    #[test]
    fn light_factor_is_within_its_bound_of_the_f32_factor() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x0011_6477);
        let lighting = LightingRecord { falloff: Falloff::None, ..LightingRecord::default() };
        let (mut answered, mut asked, mut worst) = (0u64, 0u64, 0f64);
        let mut check = |n: Vec3, d: Vec3, count: bool| {
            let (e, _) = irradiance_toward(&lighting, n, Vec3::ZERO, d);
            let got = light_factor(n, d);
            match got {
                LightFactor::Lit(e30) => {
                    assert!(e > 0.0, "{n:?} {d:?}: {got:?}, f32 {e}");
                    let diff = (e30 as f64 / (1u64 << 30) as f64 - e as f64).abs();
                    worst = worst.max(diff);
                    assert!(diff < 2f64.powi(-(FACTOR_ERROR as i32)), "{n:?} {d:?}: {got:?}, f32 {e}");
                }
                LightFactor::Unlit => assert_eq!(e, 0.0, "{n:?} {d:?}"),
                LightFactor::Unsure => {}
            }
            if count {
                asked += 1;
                answered += u64::from(got != LightFactor::Unsure);
            }
        };
        let unit = |rng: &mut ChaCha8Rng| loop {
            let v = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            if let Some(n) = try_normalize(v) {
                break n;
            }
        };
        for _ in 0..200_000 {
            let n = unit(&mut rng);
            let scale = 2f32.powi(rng.gen_range(-40..40));
            let d = unit(&mut rng) * rng.gen_range(0.5..2.0f32) * scale;
            check(n, d, true);
            // Nearly in the tangent plane: n·d a few ulps either side of 0.
            let t = (d - n * d.dot(n)) + n * (d.length() * rng.gen_range(-1e-5..1e-5f32));
            check(n, t, false);
        }
        for n in [Vec3::X, Vec3::Y, -Vec3::Z] {
            for d in [Vec3::X, Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, 0.0, -1e-3), Vec3::new(1.0, 1.0, 0.0)] {
                check(n, d, false);
            }
        }
        // Out of range: ∞, NaN, zero and tiny or huge offsets, a non-unit "normal".
        for d in [Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::new(f32::NAN, 1.0, 0.0), Vec3::ZERO, Vec3::splat(1e-30)] {
            assert_eq!(light_factor(Vec3::Z, d), LightFactor::Unsure, "{d:?}");
        }
        assert_eq!(light_factor(Vec3::splat(2.0), Vec3::Z), LightFactor::Unsure);
        eprintln!("largest difference {worst:e}");
        assert!(answered as f64 > 0.999 * asked as f64, "{answered} of {asked}");
    }

    /// Where `dot_sign` answers, it is the sign of the f32 `sfloat::dot(n, v) > 0`: random unit
    /// normals and vectors over 2⁻⁹⁵..2¹²⁰, vectors nearly perpendicular to the normal; and it
    /// answers for nearly all of them.
    #[test]
    fn dot_sign_is_the_f32_dot_products_sign() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x0D07_5164);
        let unit = |rng: &mut ChaCha8Rng| loop {
            let v = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            if let Some(n) = try_normalize(v) {
                break n;
            }
        };
        let (mut answered, mut asked) = (0u64, 0u64);
        for _ in 0..200_000 {
            let n = unit(&mut rng);
            let scale = 2f32.powi(rng.gen_range(-95..120));
            let v = unit(&mut rng) * rng.gen_range(0.5..2.0f32) * scale;
            let t = (v - n * v.dot(n)) + n * (v.length() * rng.gen_range(-1e-5..1e-5f32));
            for (w, count) in [(v, true), (t, false)] {
                let got = dot_sign(n, w);
                if let Some(positive) = got {
                    assert_eq!(positive, crate::sfloat::dot(n, w) > 0.0, "{n:?} {w:?}");
                }
                if count {
                    asked += 1;
                    answered += u64::from(got.is_some());
                }
            }
        }
        assert_eq!(dot_sign(Vec3::Z, Vec3::ZERO), None);
        assert_eq!(dot_sign(Vec3::Z, Vec3::splat(1e-32)), None);
        assert_eq!(dot_sign(Vec3::Z, Vec3::new(0.0, 0.0, f32::NAN)), None);
        assert!(answered as f64 > 0.999 * asked as f64, "{answered} of {asked}");
    }

    /// The factor and the sign as the i64 arithmetic before the 32-bit products computed
    /// them (the reference for `the_32_bit_products_equal_the_i64_arithmetic`).
    mod wide_reference {
        use super::super::{LightFactor, RSQRT, UNSURE};
        use gridrt_shared::math::Vec3;
        fn q29_of_unit(c: f32) -> Option<i64> {
            let bits = c.to_bits();
            let abs = bits & 0x7FFF_FFFF;
            if abs >= 0x4000_0000 {
                return None;
            }
            let exp = abs >> 23;
            let sig = (abs & 0x007F_FFFF) | 0x0080_0000;
            // c·2^29 = sig·2^(exp − 121).
            let v = if exp >= 121 {
                sig << (exp - 121)
            } else if exp > 121 - 31 {
                sig >> (121 - exp)
            } else {
                0
            };
            Some(if bits >> 31 != 0 { -i64::from(v) } else { i64::from(v) })
        }

        fn scaled(c: f32, e_max: u32) -> i64 {
            let bits = c.to_bits();
            let abs = bits & 0x7FFF_FFFF;
            let exp = abs >> 23;
            let shift = e_max - exp;
            let v = if exp == 0 || shift >= 31 { 0 } else { (((abs & 0x007F_FFFF) | 0x0080_0000) << 6) >> shift };
            if bits >> 31 != 0 {
                -i64::from(v)
            } else {
                i64::from(v)
            }
        }

        fn light_factor(n: Vec3, d: Vec3) -> LightFactor {
            let (n, d) = (n.to_array(), d.to_array());
            let (Some(n0), Some(n1), Some(n2)) = (q29_of_unit(n[0]), q29_of_unit(n[1]), q29_of_unit(n[2])) else {
                return LightFactor::Unsure;
            };
            let e_max =
                (d[0].to_bits() & 0x7FFF_FFFF).max(d[1].to_bits() & 0x7FFF_FFFF).max(d[2].to_bits() & 0x7FFF_FFFF)
                    >> 23;
            // |d| between 2^-60 and 2^60: its f32 square neither overflows nor underflows, so the f32
            // light vector exists (and NaN and ∞ are out).
            if !(67..=187).contains(&e_max) {
                return LightFactor::Unsure;
            }
            let (d0, d1, d2) = (scaled(d[0], e_max), scaled(d[1], e_max), scaled(d[2], e_max));
            // Both sums are exact: products below 2^60, the largest |d| component at least 2^29.
            let s = n0 * d0 + n1 * d1 + n2 * d2;
            let q = (d0 * d0 + d1 * d1 + d2 * d2) as u64;
            // q in [2^58, 2^62): to [2^60, 2^62) by an even shift, then h = q/2^30 in [2^30, 2^32).
            let j = u32::from(q < 1 << 60);
            let h = ((q << (2 * j)) >> 30) as u32;
            // y ≈ 2^46/√h: the table, then three Newton steps y·(3 − h·y²/2^92)/2.
            let idx = ((h >> 26) as usize).wrapping_sub(16);
            let mut y = u64::from(RSQRT.get(idx).copied().unwrap_or(1 << 30));
            for _ in 0..3 {
                let y2 = (y * y) >> 32; // y²/2^32 < 2^30
                let hy2 = (u64::from(h) * y2) >> 28; // h·y²/2^60 ≈ 2^32
                let w = (3u64 << 32).saturating_sub(hy2) >> 2; // (3 − h·y²/2^92)·2^30
                y = (y * w) >> 31;
            }
            // e·2^30 = 2·s/√q = (s/2^30)·y·2^(j − 30): |s/2^30| ≤ 2^30.
            let e30 = ((s >> 30) * y as i64) >> (30 - j);
            if e30 > UNSURE {
                LightFactor::Lit(e30.min(i64::from(u32::MAX)) as u32)
            } else if e30 < -UNSURE {
                LightFactor::Unlit
            } else {
                LightFactor::Unsure
            }
        }

        fn dot_sign(n: Vec3, v: Vec3) -> Option<bool> {
            let (n, v) = (n.to_array(), v.to_array());
            let (n0, n1, n2) = (q29_of_unit(n[0])?, q29_of_unit(n[1])?, q29_of_unit(n[2])?);
            let e_max =
                (v[0].to_bits() & 0x7FFF_FFFF).max(v[1].to_bits() & 0x7FFF_FFFF).max(v[2].to_bits() & 0x7FFF_FFFF)
                    >> 23;
            // v_max ≥ 2^-100: the f32 products' underflow (2^-150 each) is far below 3.01u·v_max.
            if !(27..255).contains(&e_max) {
                return None;
            }
            let s = n0 * scaled(v[0], e_max) + n1 * scaled(v[1], e_max) + n2 * scaled(v[2], e_max);
            if s > 1 << 39 {
                Some(true)
            } else if s < -(1 << 39) {
                Some(false)
            } else {
                None
            }
        }

        pub(super) fn light_factor_ref(n: Vec3, d: Vec3) -> LightFactor {
            light_factor(n, d)
        }
        pub(super) fn dot_sign_ref(n: Vec3, v: Vec3) -> Option<bool> {
            dot_sign(n, v)
        }
    }

    /// `light_factor` and `dot_sign` with 32-bit operands and `u32 × u32` products give what
    /// the i64 arithmetic gave, for every input: random unit and non-unit normals (components
    /// up to 2), offsets over 2⁻⁷⁰..2⁷⁰ and the edges of the ranges.
    #[test]
    fn the_32_bit_products_equal_the_i64_arithmetic() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x3232_6464);
        let mut lit = 0u32;
        for i in 0..400_000 {
            let n = if i % 4 == 0 {
                Vec3::new(rng.gen_range(-1.999..1.999), rng.gen_range(-1.999..1.999), rng.gen_range(-1.999..1.999))
            } else {
                let v = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                try_normalize(v).unwrap_or(Vec3::Z)
            };
            let scale = 2f32.powi(rng.gen_range(-70..70));
            let mut d = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * scale;
            if i % 7 == 0 {
                d[rng.gen_range(0..3)] = 0.0;
            }
            if i % 11 == 0 {
                d[rng.gen_range(0..3)] = f32::from_bits(rng.gen_range(0..0x0080_0000));
            }
            let got = light_factor(n, d);
            assert_eq!(got, wide_reference::light_factor_ref(n, d), "{n:?} {d:?}");
            lit += u32::from(matches!(got, LightFactor::Lit(_)));
            assert_eq!(dot_sign(n, d), wide_reference::dot_sign_ref(n, d), "{n:?} {d:?}");
        }
        assert!(lit > 100_000, "{lit}");
        for c in [0.0, -0.0, 1.0, -1.0, 1.999_999_9, -1.999_999_9, 2.0, f32::MIN_POSITIVE, 1e-30, f32::NAN] {
            for e in [1e-18f32, 1.0, 1e18, f32::MAX, f32::INFINITY] {
                let (n, d) = (Vec3::new(c, 0.5, -0.25), Vec3::new(e, -e * 0.5, c));
                assert_eq!(light_factor(n, d), wide_reference::light_factor_ref(n, d), "{n:?} {d:?}");
                assert_eq!(dot_sign(n, d), wide_reference::dot_sign_ref(n, d), "{n:?} {d:?}");
            }
        }
    }

    /// The table's start is within 2⁻⁶ of `2⁴⁶/√h` over each interval.
    #[test]
    fn rsqrt_table_starts_within_two_to_the_minus_six() {
        for (i, &y) in RSQRT.iter().enumerate() {
            for h in [(i as f64 + 16.0) * 2f64.powi(26), (i as f64 + 17.0) * 2f64.powi(26)] {
                let exact = 2f64.powi(46) / h.sqrt();
                assert!((y as f64 / exact - 1.0).abs() < 2f64.powi(-6), "{i}");
            }
        }
    }
}
