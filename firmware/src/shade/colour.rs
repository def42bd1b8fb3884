//! Colour output: the background, the default albedo and the 8-bit rule of
//! docs/CONTRACTS.md § Shading (linear, no gamma).

use crate::sfloat;

/// Background colour of a miss (linear RGB) in a mesh scene's default lighting.
pub const BACKGROUND: [f32; 3] = [0.08, 0.08, 0.12];

/// Albedo of a material index the table does not hold.
pub const DEFAULT_ALBEDO: [f32; 3] = [0.8, 0.8, 0.8];

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
///
/// On a soft-float core (`cfg(soft_float)`) the same value comes from [`to_u8_soft`].
#[inline]
pub fn to_u8(c: f32) -> u8 {
    if cfg!(soft_float) {
        to_u8_soft(c)
    } else {
        (clamp01(c) * 255.0 + 0.5) as u8
    }
}

/// [`to_u8`]'s formula with the clamp on the bits and `crate::sfloat`'s integer arithmetic
/// (the same roundings; pinned against the float formula over every f32 of [2⁻¹¹, 1] by
/// `soft_8_bit_rule_equals_the_float_rule`).
pub fn to_u8_soft(c: f32) -> u8 {
    let bits = c.to_bits();
    // ≥ 1 and +∞: 255; NaN and negative values (sign bit set): 0.
    if bits >= 0x3F80_0000 {
        return if bits <= 0x7F80_0000 { 255 } else { 0 };
    }
    // 0 ≤ c < 1: the sum is below 255.5, its truncation fits a byte.
    sfloat::trunc_i32_bits(sfloat::add_int(sfloat::mul_int(c, 255.0), 0.5)) as u8
}

/// [`to_u8`] per channel.
#[inline]
pub fn to_rgb8([r, g, b]: [f32; 3]) -> [u8; 3] {
    [to_u8(r), to_u8(g), to_u8(b)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn background_encodes_to_contract_bytes() {
        // 0.08·255 + 0.5 = 20.9 → 20; 0.12·255 + 0.5 = 31.1 → 31.
        assert_eq!(to_rgb8(BACKGROUND), [20, 20, 31]);
    }

    /// The soft-float rule gives the float rule's byte for every f32 in [2^-11, 1] (both
    /// double rounded), and for the edge cases below and above.
    #[test]
    fn soft_8_bit_rule_equals_the_float_rule() {
        let float = |c: f32| (clamp01(c) * 255.0 + 0.5) as u8;
        for b in 0x3A00_0000u32..=0x3F80_0000 {
            let c = f32::from_bits(b);
            assert_eq!(to_u8_soft(c), float(c), "{c:e}");
        }
        for c in [0.0, -0.0, -1.0, 1e-30, 2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::from_bits(1)] {
            assert_eq!(to_u8_soft(c), float(c), "{c:e}");
        }
        // A tie of + 0.5 that rounds up to the next integer: 1.5 − 2^-23 after ×255.
        assert_eq!(to_u8_soft(0.0058823526), float(0.0058823526));
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
}
