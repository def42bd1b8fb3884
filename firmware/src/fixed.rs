//! Exact conversions between f32 and fixed point, by bit manipulation only.
//!
//! The fixed-point ray generation and DDA (cargo feature `fixed-raygen`, [`crate::camera`] and
//! [`crate::dda`]) exist for soft-cores without an FPU, where every f32 operation is a
//! software routine of tens of instructions. Their inputs (eye, basis, grid box) and outputs
//! (the f32 words of the FSL request) are f32, so the conversions here use integer operations
//! only: no float arithmetic, no rounding except the one documented.

/// Number format of ray generation and the 3D-DDA.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RayFormat {
    /// f32 arithmetic (the default build).
    F32,
    /// Integer arithmetic (feature `fixed-raygen`): Q30 camera basis, Q31.32 grid units.
    Fixed,
}

impl RayFormat {
    /// The format this build uses (`Camera::primary_ray`, `dda::build_list`).
    pub const DEFAULT: RayFormat = if cfg!(feature = "fixed-raygen") { RayFormat::Fixed } else { RayFormat::F32 };

    /// Both formats.
    pub const ALL: [RayFormat; 2] = [RayFormat::F32, RayFormat::Fixed];

    /// Short name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::Fixed => "fixed",
        }
    }
}

/// `x · 2^frac` as an i128, exact when `x` has no bits below `2^-frac` and truncated toward
/// −∞ otherwise (floor). `None` for NaN, ±∞ or a result beyond ±2^126.
pub fn f32_to_fixed_i128(x: f32, frac: u32) -> Option<i128> {
    let bits = x.to_bits();
    let neg = bits >> 31 != 0;
    let exp = ((bits >> 23) & 0xFF) as i32;
    let man = bits & 0x7F_FFFF;
    if exp == 0xFF {
        return None;
    }
    // value = m · 2^(e), m a 24-bit integer (with the hidden bit) or a subnormal mantissa.
    let (m, e) = if exp == 0 { (man as i128, -149) } else { ((man | 0x80_0000) as i128, exp - 150) };
    let shift = e + frac as i32;
    let mag = if shift >= 0 {
        if shift > 102 {
            return if m == 0 { Some(0) } else { None };
        }
        m << shift
    } else if shift <= -64 {
        0
    } else {
        m >> (-shift)
    };
    if neg {
        // floor for negatives: subtract one when bits were dropped.
        let dropped = shift < 0 && (shift <= -64 || m & ((1i128 << (-shift)) - 1) != 0) && m != 0;
        Some(-mag - dropped as i128)
    } else {
        Some(mag)
    }
}

/// [`f32_to_fixed_i128`] narrowed to i64.
pub fn f32_to_fixed(x: f32, frac: u32) -> Option<i64> {
    f32_to_fixed_i128(x, frac).and_then(|v| i64::try_from(v).ok())
}

/// `v · 2^-frac` rounded to the nearest f32 (ties to even), by integer operations only;
/// `frac` may be negative (a left shift). Results beyond f32's range are ±∞; below its
/// subnormal range, ±0.
pub fn fixed_to_f32(v: i128, frac: i32) -> f32 {
    if v == 0 {
        return 0.0;
    }
    let neg = v < 0;
    let mag = v.unsigned_abs();
    // mag = 2^msb · 1.xxx ; value = mag · 2^-frac.
    let msb = 127 - mag.leading_zeros() as i32;
    let mut exp = msb - frac; // unbiased exponent of the value
    let sign = if neg { 0x8000_0000u32 } else { 0 };
    if exp > 127 {
        return f32::from_bits(sign | 0x7F80_0000);
    }
    // Keep 24 significant bits (fewer for subnormals), round to nearest even.
    let keep = if exp < -126 { 24 - (-126 - exp) } else { 24 };
    if keep <= 0 {
        // Below half the smallest subnormal (or exactly half: ties to even → 0) unless more.
        let half_ulp_exp = -150; // value of half the smallest subnormal is 2^-150
        if exp > half_ulp_exp || (exp == half_ulp_exp && mag.count_ones() > 1) {
            return f32::from_bits(sign | 1);
        }
        return f32::from_bits(sign);
    }
    let drop = msb + 1 - keep;
    let mut m: u128 = if drop > 0 {
        let q = mag >> drop;
        let rem = mag & ((1u128 << drop) - 1);
        let half = 1u128 << (drop - 1);
        if rem > half || (rem == half && q & 1 == 1) {
            q + 1
        } else {
            q
        }
    } else {
        mag << (-drop)
    };
    if keep < 24 {
        // Subnormal: m is the mantissa field; a carry to 2^23 encodes the smallest normal.
        return f32::from_bits(sign | m as u32);
    }
    // Rounding may carry into a new bit.
    if m >> 24 != 0 {
        m >>= 1;
        exp += 1;
        if exp > 127 {
            return f32::from_bits(sign | 0x7F80_0000);
        }
    }
    f32::from_bits(sign | (((exp + 127) as u32) << 23) | (m as u32 & 0x7F_FFFF))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn conversions_are_exact_and_round_to_nearest_even() {
        assert_eq!(f32_to_fixed(1.5, 4), Some(24));
        assert_eq!(f32_to_fixed(-1.5, 4), Some(-24));
        assert_eq!(f32_to_fixed(-0.1, 0), Some(-1)); // floor
        assert_eq!(f32_to_fixed(0.1, 0), Some(0));
        assert_eq!(f32_to_fixed(f32::NAN, 0), None);
        assert_eq!(f32_to_fixed(f32::INFINITY, 0), None);
        assert_eq!(f32_to_fixed(1e30, 32), None);
        assert_eq!(fixed_to_f32(24, 4), 1.5);
        assert_eq!(fixed_to_f32(-3, 1), -1.5);
        assert_eq!(fixed_to_f32(1, -3), 8.0);
        assert_eq!(fixed_to_f32(1 << 100, 0), 2f32.powi(100));
        // 2^24 + 1 is a tie: rounds to even (2^24); 2^24 + 3 rounds up to 2^24 + 4.
        assert_eq!(fixed_to_f32((1 << 24) + 1, 0), 16_777_216.0);
        assert_eq!(fixed_to_f32((1 << 24) + 3, 0), 16_777_220.0);
        assert_eq!(fixed_to_f32(1, 200), 0.0);
        assert_eq!(fixed_to_f32(1, -200), f32::INFINITY);
        assert_eq!(fixed_to_f32(1, 149), f32::from_bits(1));
    }

    /// Round trips and agreement with the hardware conversion on random values of every
    /// magnitude, including subnormals.
    #[test]
    fn fixed_to_f32_matches_hardware_rounding() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xF1C0);
        for _ in 0..200_000 {
            // f64 holds |v| < 2^53 exactly, and the power-of-two scaling is exact: one rounding.
            let v: i64 = rng.gen::<i64>() >> rng.gen_range(11..63);
            let frac: i32 = rng.gen_range(-60..200);
            let want = (v as f64 * 2f64.powi(-frac)) as f32;
            assert_eq!(fixed_to_f32(v as i128, frac).to_bits(), want.to_bits(), "{v} {frac}");
            let x = f32::from_bits(rng.gen());
            if x.is_finite() {
                if let Some(q) = f32_to_fixed_i128(x, 149) {
                    assert_eq!(fixed_to_f32(q, 149).to_bits(), x.to_bits(), "{x:e}");
                }
            }
        }
    }
}
