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
///
/// On a soft-float core (`cfg(soft_float)`) the same value comes from [`to_u8_exact`], in
/// integers (a few tens of instructions instead of five float routines).
#[inline]
pub fn to_u8(c: f32) -> u8 {
    if cfg!(soft_float) {
        to_u8_exact(c)
    } else {
        (clamp01(c) * 255.0 + 0.5) as u8
    }
}

/// `m` rounded to its 24 most significant bits, ties to even, with the number of bits dropped
/// (`m · 2^e = result · 2^(e + dropped)`, the result possibly `2^24`).
#[inline(always)]
fn round24(m: u64) -> (u64, u32) {
    let bits = 64 - m.leading_zeros();
    if bits <= 24 {
        return (m, 0);
    }
    let s = bits - 24;
    let (q, rem, half) = (m >> s, m & ((1 << s) - 1), 1u64 << (s - 1));
    let up = rem > half || (rem == half && q & 1 == 1);
    (q + up as u64, s)
}

/// [`to_u8`] of the f32 formula, computed exactly in integers: `255·c` and `+ 0.5` are each
/// rounded to 24 bits, ties to even, as the float unit does, then truncated (pinned against
/// the float formula over every f32 of [2⁻¹¹, 1] by `exact_8_bit_rule_equals_the_float_rule`).
pub fn to_u8_exact(c: f32) -> u8 {
    let bits = c.to_bits();
    // NaN, negative and zero: 0 (0.5 truncates to 0); ≥ 1 (and +∞): 255.
    if bits >= 0x3F80_0000 {
        return if bits <= 0x7F80_0000 { 255 } else { 0 };
    }
    // Below 2^-11, 255c + 0.5 < 0.63: 0.
    if bits < 0x3A00_0000 {
        return 0;
    }
    // c = m · 2^-f with m the 24-bit significand, f in 24..=35.
    let m = u64::from(bits & 0x7F_FFFF | 0x80_0000);
    let f = 150 - (bits >> 23);
    // x = fl(255c) = p · 2^-(f - d).
    let (p, d) = round24(255 * m);
    let f = f - d;
    // y = fl(x + 0.5) = q · 2^-(f - e); the result is ⌊y⌋.
    let (q, e) = round24(p + (1 << (f - 1)));
    (q >> (f - e)) as u8
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

    /// The integer rule gives the float rule's byte for every f32 in [2^-11, 1] (both double
    /// rounded), and for the edge cases below and above.
    #[test]
    fn exact_8_bit_rule_equals_the_float_rule() {
        let float = |c: f32| (clamp01(c) * 255.0 + 0.5) as u8;
        for b in 0x3A00_0000u32..=0x3F80_0000 {
            let c = f32::from_bits(b);
            assert_eq!(to_u8_exact(c), float(c), "{c:e}");
        }
        for c in [0.0, -0.0, -1.0, 1e-30, 2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::from_bits(1)] {
            assert_eq!(to_u8_exact(c), float(c), "{c:e}");
        }
        // A tie of + 0.5 that rounds up to the next integer: 1.5 − 2^-23 after ×255.
        assert_eq!(to_u8_exact(0.0058823526), float(0.0058823526));
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
