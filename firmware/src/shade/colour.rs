//! Colour output: the background, the default albedo and the 8-bit rule of
//! docs/CONTRACTS.md § Shading (linear, no gamma).

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
}
