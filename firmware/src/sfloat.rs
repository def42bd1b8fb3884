//! f32 addition, subtraction and multiplication for the hot loops, correctly rounded (IEEE 754
//! binary32, ties to even): on a core without an FPU (`cfg(soft_float)`, see the build script)
//! the common case runs inline in integer arithmetic, elsewhere these are the plain operators.
//!
//! The integer path takes the case where both operands and the result are normal numbers
//! (the whole of a ray's walk and shading on sane scenes) without a library call: 55
//! instructions per `add_int` call and 48 per `mul_int` call on a frame's mix of operands,
//! the return included (riscv32imac, `scripts/qemu-profile.py` over an 80×60 frame of
//! bun_zipper_res4; docs/bench-firmware.md has the commands). Everything else —
//! zeros, subnormals, infinities, NaN, overflow, an underflowing result — goes to the library,
//! so every result is the operator's, bit for bit (pinned against the native operators by
//! `integer_paths_equal_the_operators` over random and edge-case operands).
//!
//! Addition keeps three bits below the significand (guard, round, sticky), which is enough for
//! a correctly rounded sum or difference; multiplication rounds the exact 48-bit product.
//! Operation order is the caller's: `sub(mul(a, b), c)` is `a * b - c`, rounded twice.
//!
//! With the feature `cfu-float` (the SoC's VexRiscv `full+cfu`), addition and multiplication
//! are one custom instruction each, answered by the co-processor RTL's IEEE units behind the
//! CPU's CFU port ([`cfu`]): the same bits, except that a NaN result is the canonical quiet
//! NaN.

use gridrt_shared::math::Vec3;

/// Biased exponent field mask of `|x|` bits, and the range test for a normal number.
const EXP_ONE: u32 = 0x0080_0000;
const NORMAL_SPAN: u32 = 0x7F00_0000;
const FRAC: u32 = 0x007F_FFFF;
const SIGN: u32 = 0x8000_0000;
/// `|x|` bits of +∞: below it, finite.
const INF: u32 = 0x7F80_0000;

/// `a + b`.
#[inline(always)]
pub fn add(a: f32, b: f32) -> f32 {
    if cfg!(feature = "cfu-float") {
        cfu::add(a, b)
    } else if cfg!(soft_float) {
        add_int(a, b)
    } else {
        a + b
    }
}

/// `a − b` (IEEE defines it as `a + (−b)`; the negation is a sign flip).
#[inline(always)]
pub fn sub(a: f32, b: f32) -> f32 {
    add(a, -b)
}

/// `a · b`.
#[inline(always)]
pub fn mul(a: f32, b: f32) -> f32 {
    if cfg!(feature = "cfu-float") {
        cfu::mul(a, b)
    } else if cfg!(soft_float) {
        mul_int(a, b)
    } else {
        a * b
    }
}

/// `a / b`.
#[inline(always)]
pub fn div(a: f32, b: f32) -> f32 {
    if cfg!(soft_float) {
        div_int(a, b)
    } else {
        a / b
    }
}

/// `1 / b`.
#[inline(always)]
pub fn recip(b: f32) -> f32 {
    if cfg!(soft_float) {
        recip_int(b)
    } else {
        1.0 / b
    }
}

/// `a + b` where an operand is often ±0 (a camera ray's column and row terms, one of which
/// is zero per component when the camera is axis-aligned): that case in a few integer
/// instructions on a soft-float core without the f32 unit, where `add` would call its
/// out-of-line zero path; else [`add`].
#[inline(always)]
pub fn add_often_zero(a: f32, b: f32) -> f32 {
    if cfg!(all(soft_float, not(feature = "cfu-float"))) {
        if let Some(sum) = sum_with_zero(a, b) {
            return sum;
        }
    }
    add(a, b)
}

/// `a + b` when an operand is ±0 and the other finite (`add_slow`'s rule), else `None`.
#[inline(always)]
fn sum_with_zero(a: f32, b: f32) -> Option<f32> {
    let (ua, ub) = (a.to_bits(), b.to_bits());
    let finite = |u: u32| u & INF != INF;
    if ub & !SIGN == 0 && finite(ua) {
        // x + ±0 = x for x ≠ 0; ±0 + ±0 is −0 only when both are −0 (ties to even).
        return Some(if ua & !SIGN != 0 { a } else { f32::from_bits(ua & ub) });
    }
    if ua & !SIGN == 0 && finite(ub) {
        return Some(b);
    }
    None
}

/// [`vadd`] with [`add_often_zero`] per component.
#[inline(always)]
pub fn vadd_often_zero(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(add_often_zero(a.x, b.x), add_often_zero(a.y, b.y), add_often_zero(a.z, b.z))
}

/// `a + b` of glam's `Vec3`.
#[inline(always)]
pub fn vadd(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(add(a.x, b.x), add(a.y, b.y), add(a.z, b.z))
}

/// `a − b` of glam's `Vec3`.
#[inline(always)]
pub fn vsub(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(sub(a.x, b.x), sub(a.y, b.y), sub(a.z, b.z))
}

/// `v · s` (and `s · v`) of glam's `Vec3`.
#[inline(always)]
pub fn vscale(v: Vec3, s: f32) -> Vec3 {
    Vec3::new(mul(v.x, s), mul(v.y, s), mul(v.z, s))
}

/// glam's `a.dot(b)`: `(ax·bx + ay·by) + az·bz`.
#[inline(always)]
pub fn dot(a: Vec3, b: Vec3) -> f32 {
    add(add(mul(a.x, b.x), mul(a.y, b.y)), mul(a.z, b.z))
}

/// `x as i32` (truncation toward zero, saturating, NaN → 0): a few integer instructions on
/// every core where the soft-float conversion is a library call.
#[inline(always)]
pub fn trunc_i32(x: f32) -> i32 {
    if cfg!(soft_float) {
        trunc_i32_bits(x)
    } else {
        x as i32
    }
}

/// [`trunc_i32`] from the bits.
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // shifts by 0..=30, checked below
pub fn trunc_i32_bits(x: f32) -> i32 {
    let bits = x.to_bits();
    let e = (bits >> 23 & 0xFF) as i32 - 127;
    if e < 0 {
        return 0;
    }
    if e >= 31 {
        return if bits & !SIGN > 0x7F80_0000 {
            0
        } else if bits & SIGN != 0 {
            i32::MIN
        } else {
            i32::MAX
        };
    }
    let m = (bits & FRAC) | EXP_ONE;
    let v = if e >= 23 { m << (e - 23) } else { m >> (23 - e) } as i32;
    if bits & SIGN != 0 {
        -v
    } else {
        v
    }
}

/// `x as f32` (rounded to nearest, ties to even): exact in a few integer instructions for
/// `x < 2^24`, the library conversion above.
#[inline(always)]
pub fn u32_to_f32(x: u32) -> f32 {
    if cfg!(soft_float) {
        u32_to_f32_bits(x)
    } else {
        x as f32
    }
}

/// [`u32_to_f32`] from the bits.
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // shifts by 8..=31 for 0 < x < 2^24
pub fn u32_to_f32_bits(x: u32) -> f32 {
    if x == 0 || x >= 1 << 24 {
        return x as f32;
    }
    // The leading 1 moves to bit 23 (dropped); the exponent is its position.
    let lz = x.leading_zeros();
    f32::from_bits((158 - lz) << 23 | ((x << lz) & 0x7FFF_FFFF) >> 8)
}

/// `|x|` is a normal number.
#[inline(always)]
fn normal(abs: u32) -> bool {
    abs.wrapping_sub(EXP_ONE) < NORMAL_SPAN
}

/// `a + b` in integers when both are normal and the sum is normal, else the operator.
/// Out of line: one copy (code budget), a call costs a few instructions.
#[inline(never)]
pub fn add_int(a: f32, b: f32) -> f32 {
    add_inline(a, b)
}

/// `a · b` in integers when both are normal and the product is normal, else the operator.
/// Out of line, as [`add_int`].
#[inline(never)]
pub fn mul_int(a: f32, b: f32) -> f32 {
    mul_inline(a, b)
}

/// The sum for the operands and results the integer path leaves out: a zero operand with a
/// finite other one in integers (camera vectors and accumulators have zero components, so
/// this is common), the rest by the operator. Out of line, so the integer path needs no
/// stack frame (the call is a tail call).
#[inline(never)]
fn add_slow(a: f32, b: f32) -> f32 {
    let (ua, ub) = (a.to_bits(), b.to_bits());
    let (aa, ab) = (ua & !SIGN, ub & !SIGN);
    if ab == 0 && aa < INF {
        // x + ±0 = x for x ≠ 0; ±0 + ±0 is −0 only when both are −0 (ties to even).
        return if aa != 0 { a } else { f32::from_bits(ua & ub) };
    }
    if aa == 0 && ab < INF {
        return b;
    }
    a + b
}

/// The product for the operands and results the integer path leaves out: a zero times a
/// finite number in integers (the zero with the sign of the product), the rest by the
/// operator. Out of line, as [`add_slow`].
#[inline(never)]
fn mul_slow(a: f32, b: f32) -> f32 {
    let (ua, ub) = (a.to_bits(), b.to_bits());
    let (aa, ab) = (ua & !SIGN, ub & !SIGN);
    if (aa == 0 && ab < INF) || (ab == 0 && aa < INF) {
        return f32::from_bits((ua ^ ub) & SIGN);
    }
    a * b
}

/// `a / b` in integers when both are normal and the quotient is normal, else the operator:
/// a reciprocal of the divisor's significand from a 64-entry table and two Newton–Raphson
/// steps in 32-bit fixed point (multiplies only: a soft-core's divider takes ~32 cycles per
/// `divu`), the quotient from it, then corrected against its exact remainder, so the
/// rounding is the operator's whatever the estimate's error.
#[inline(never)]
pub fn div_int(a: f32, b: f32) -> f32 {
    div_inline(a, b)
}

/// `1 / b` as [`div_int`] computes it, with the dividend's steps folded (the walk's three
/// reciprocals per ray).
#[inline(never)]
pub fn recip_int(b: f32) -> f32 {
    div_inline(1.0, b)
}

/// [`div_int`], inline.
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // bounded by the normal-number ranges checked first
fn div_inline(a: f32, b: f32) -> f32 {
    let (ua, ub) = (a.to_bits(), b.to_bits());
    let (aa, ab) = (ua & !SIGN, ub & !SIGN);
    if !normal(aa) || !normal(ab) {
        return div_slow(a, b);
    }
    let mut e = (aa >> 23) as i32 - (ab >> 23) as i32 + 127;
    let mut x = (aa & FRAC) | EXP_ONE;
    let y = (ab & FRAC) | EXP_ONE;
    // x in [y, 2y): the quotient q = floor(x·2^24 / y) lies in [2^24, 2^25).
    if x < y {
        x <<= 1;
        e -= 1;
    }
    if e <= 0 {
        return div_slow(a, b);
    }
    // y' = y·2^-24 in [1/2, 1) as 0.32 fixed point; r ≈ 1/y' in 2.30, from below after the
    // first step (Newton's iteration for 1/y' never overshoots, truncation only lowers it).
    let yq = y << 8;
    let mut r = u32::from(RECIP[(yq >> 25 & 63) as usize]) << 15;
    // Two steps r·(2 − y'·r), written out (a loop costs a counter at opt-level "s"):
    // t = y'·r in 2.30, r < 2^31 and 2 − y'r ≤ 1 + 2^-6, so the shifts fit.
    let t = mulhi(yq, r);
    r = mulhi(r << 1, ((1 << 31) - t) << 1);
    let t = mulhi(yq, r);
    r = mulhi(r << 1, ((1 << 31) - t) << 1);
    // q from below: x·r·2^5 truncated (r is within 2^-26 of 1/y', so q is the floor or one
    // below it), then up to the exact floor by the remainder.
    let mut q = mulhi(x << 7, r) >> 5;
    // The remainder x·2^24 − q·y is below 2^32: exact in wrapping arithmetic.
    let mut rem = (x << 24).wrapping_sub(q.wrapping_mul(y));
    if rem >= y {
        rem -= y;
        q += 1;
    }
    if rem >= y {
        return div_slow(a, b);
    }
    match pack((ua ^ ub) & SIGN, e as u32, round_even::<2>(q << 1 | u32::from(rem != 0))) {
        Some(r) => r,
        None => div_slow(a, b),
    }
}

/// The high word of the 64-bit product (`mulhu`).
#[inline(always)]
fn mulhi(a: u32, b: u32) -> u32 {
    ((u64::from(a) * u64::from(b)) >> 32) as u32
}

/// `round(2^15 / y')` at the middle of each of 64 equal steps of y' in [1/2, 1): the start of
/// [`div_int`]'s reciprocal, about 7 bits.
const RECIP: [u16; 64] = {
    let mut t = [0u16; 64];
    let mut i = 0;
    while i < 64 {
        // y' = (129 + 2i)/256: 2^15/y' = 2^23/(129 + 2i), rounded.
        t[i] = ((1u32 << 24) / (129 + 2 * i as u32)).div_ceil(2) as u16;
        i += 1;
    }
    t
};

/// The quotient for the operands and results [`div_int`] leaves out: the operator.
#[inline(never)]
fn div_slow(a: f32, b: f32) -> f32 {
    a / b
}

/// Rounds a significand `m` with its leading 1 at bit `23 + G` and `G` bits below the last
/// kept bit (sticky folded into the lowest) to nearest, ties to even: adding `2^(G−1) − 1`
/// plus the last kept bit carries exactly when the dropped bits exceed half, or equal it with
/// an odd last bit. The result lies in `[2^23, 2^24]`; 2^24 (a carry out of the significand)
/// packs as the next binade with [`pack`].
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // m < 2^31: no overflow
fn round_even<const G: u32>(m: u32) -> u32 {
    (m + ((1 << (G - 1)) - 1) + ((m >> G) & 1)) >> G
}

/// The bits of `sign · m · 2^(e − 127 − 23)` for a biased exponent `e ≥ 1` and `m` in
/// `[2^23, 2^24]`: the leading 1 of `m` adds itself to the exponent field (so a rounding
/// carry to 2^24 moves to the next binade by itself). `None` when that reaches the exponent
/// field of infinities (the caller then takes the operator's result).
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // e ≤ 510, m ≤ 2^24: below 2^32
fn pack(sign: u32, e: u32, m: u32) -> Option<f32> {
    let r = ((e - 1) << 23) + m;
    if r >= 0x7F80_0000 {
        None
    } else {
        Some(f32::from_bits(sign | r))
    }
}

/// [`add_int`], inline.
#[inline(always)]
#[allow(clippy::arithmetic_side_effects)] // bounded by the normal-number ranges checked first
fn add_inline(a: f32, b: f32) -> f32 {
    let (ua, ub) = (a.to_bits(), b.to_bits());
    let (aa, ab) = (ua & !SIGN, ub & !SIGN);
    if !normal(aa) || !normal(ab) {
        return add_slow(a, b);
    }
    // x: the operand of larger magnitude (its sign is the result's).
    let (x, ax, ay) = if aa >= ab { (ua, aa, ab) } else { (ub, ab, aa) };
    let (ex, ey) = (ax >> 23, ay >> 23);
    // Significands with three bits below: 27 bits.
    let mx = ((ax & FRAC) | EXP_ONE) << 3;
    let my = ((ay & FRAC) | EXP_ONE) << 3;
    let d = ex - ey;
    let my = if d == 0 {
        my
    } else if d < 27 {
        (my >> d) | u32::from(my << (32 - d) != 0)
    } else {
        1
    };
    let mut e = ex as i32;
    let mut m;
    if (ua ^ ub) & SIGN == 0 {
        m = mx + my;
        if m >= 1 << 27 {
            m = (m >> 1) | (m & 1);
            e += 1;
        }
    } else {
        m = mx - my;
        if m == 0 {
            return 0.0;
        }
        // Bring the leading 1 to bit 26 by a binary search: RV32IMAC has no count-leading-
        // zeros instruction (`leading_zeros` is a 30-instruction bit trick there). Below
        // exponent distance 2 this is a cancellation; above, one step at most.
        if m < 1 << 25 {
            if m < 1 << 11 {
                m <<= 16;
                e -= 16;
            }
            if m < 1 << 19 {
                m <<= 8;
                e -= 8;
            }
            if m < 1 << 23 {
                m <<= 4;
                e -= 4;
            }
            if m < 1 << 25 {
                m <<= 2;
                e -= 2;
            }
        }
        if m < 1 << 26 {
            m <<= 1;
            e -= 1;
        }
        if e <= 0 {
            return add_slow(a, b);
        }
    }
    match pack(x & SIGN, e as u32, round_even::<3>(m)) {
        Some(r) => r,
        None => add_slow(a, b),
    }
}

/// [`mul_int`], inline: the integer path of [`Multiplier`], the operator outside it.
#[inline(always)]
fn mul_inline(a: f32, b: f32) -> f32 {
    match Multiplier::new(b).and_then(|m| m.times(a)) {
        Some(r) => r,
        None => mul_slow(a, b),
    }
}

/// Multiplication by one normal factor `b`, unpacked once: the walk multiplies every boundary
/// of an axis by the axis's `1/d`. [`Multiplier::times`] is [`mul_int`]'s integer path inline,
/// without `b`'s unpacking and the call.
#[derive(Debug, Clone, Copy)]
pub struct Multiplier {
    /// `b`'s significand with its leading 1 at bit 30.
    sig: u32,
    /// `b`'s biased exponent.
    exp: u32,
    /// `b`'s sign bit.
    sign: u32,
}

impl Multiplier {
    /// The multiplier by `b`, for a normal `b`.
    #[inline(always)]
    pub fn new(b: f32) -> Option<Self> {
        let ub = b.to_bits();
        let ab = ub & !SIGN;
        normal(ab).then_some(Self { sig: ((ab & FRAC) | EXP_ONE) << 7, exp: ab >> 23, sign: ub & SIGN })
    }

    /// `a · b` correctly rounded, when `a` and the product are normal (`None` otherwise: the
    /// caller takes [`mul`]).
    #[inline(always)]
    #[allow(clippy::arithmetic_side_effects)] // bounded by the normal-number ranges checked first
    pub fn times(self, a: f32) -> Option<f32> {
        let ua = a.to_bits();
        let aa = ua & !SIGN;
        if !normal(aa) {
            return None;
        }
        // Biased exponent of the product when the significands' product is below 2: 2 ..= 381.
        let mut e = (aa >> 23) + self.exp;
        // Significands with the leading 1 at bits 31 and 30: the product is in [2^61, 2^63), its
        // high word in [2^29, 2^31).
        let p = u64::from(((aa & FRAC) | EXP_ONE) << 8) * u64::from(self.sig);
        let (hi, lo) = ((p >> 32) as u32, p as u32);
        // The leading 1 to bit 30, seven bits below the last kept one, the rest sticky in bit 0.
        let m = if hi >= 1 << 30 {
            e += 1;
            hi | u32::from(lo != 0)
        } else {
            hi << 1 | u32::from(lo != 0)
        };
        // Below 128 the product is subnormal or underflows (the operator rounds it).
        if e <= 127 {
            return None;
        }
        pack((ua ^ self.sign) & SIGN, e - 127, round_even::<7>(m))
    }
}

/// The SoC's floating-point CFU (`gridrt_cfu_f32`, rtl/README.md, "The CPU's floating-point
/// CFU"): a custom-0 R-type instruction, function `{funct7, funct3}`, `rd = rs1 ∘ rs2` on
/// binary32 bits. The CPU must enable its CFU port first ([`cfu::enable`]). Off the RISC-V
/// target (host tests, the loopback simulator) the unit's Rust twin answers.
pub mod cfu {
    use gridrt_shared::cfu as spec;

    /// Enables VexRiscv's CFU port (CSR 0xBC0, bit 31; a custom instruction before this is
    /// an illegal instruction). Nothing off the RISC-V target.
    #[inline(always)]
    pub fn enable() {
        #[cfg(target_arch = "riscv32")]
        // SAFETY: sets one bit of a machine-mode CSR that only gates custom instructions.
        unsafe {
            core::arch::asm!("csrs 0xBC0, {0}", in(reg) 0x8000_0000u32, options(nomem, nostack));
        }
    }

    /// One instruction: `rd = rs1 ∘ rs2` of the function `funct3` on the unit; off the
    /// target, the unit's Rust twin.
    macro_rules! op {
        ($funct3:path, $function:path, $a:expr, $b:expr) => {{
            let (a, b): (f32, f32) = ($a, $b);
            #[cfg(target_arch = "riscv32")]
            {
                let y: u32;
                // SAFETY: a register-only instruction (no memory, no stack) the CFU answers.
                unsafe {
                    core::arch::asm!(
                        ".insn r 0x0B, {f3}, {f7}, {y}, {a}, {b}",
                        f3 = const $funct3,
                        f7 = const spec::FUNCT7,
                        y = lateout(reg) y,
                        a = in(reg) a.to_bits(),
                        b = in(reg) b.to_bits(),
                        options(pure, nomem, nostack),
                    );
                }
                f32::from_bits(y)
            }
            #[cfg(not(target_arch = "riscv32"))]
            f32::from_bits(spec::execute($function, a.to_bits(), b.to_bits()))
        }};
    }

    /// `a + b` by the unit.
    #[inline(always)]
    pub fn add(a: f32, b: f32) -> f32 {
        op!(spec::FUNCT3_ADD, spec::ADD, a, b)
    }

    /// `a · b` by the unit.
    #[inline(always)]
    pub fn mul(a: f32, b: f32) -> f32 {
        op!(spec::FUNCT3_MUL, spec::MUL, a, b)
    }
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn same(got: f32, want: f32) -> bool {
        got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan())
    }

    /// A random f32 biased toward the hard cases: near exponents, equal magnitudes, the edges
    /// of the normal range, special values.
    fn operand(rng: &mut ChaCha8Rng, other: f32) -> f32 {
        let sign = if rng.gen() { SIGN } else { 0 };
        match rng.gen_range(0..10) {
            0 => f32::from_bits(rng.gen()),
            1 => [0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MIN_POSITIVE, f32::MAX, 1.0]
                [rng.gen_range(0..8)],
            // Same or adjacent exponent, random significand: cancellations.
            2 | 3 => {
                let e = (other.to_bits() >> 23 & 0xFF) as i32 + rng.gen_range(-2..=2);
                f32::from_bits(sign | (e.clamp(0, 255) as u32) << 23 | rng.gen::<u32>() & FRAC)
            }
            // A few ulps from the other operand.
            4 => {
                f32::from_bits(other.to_bits().wrapping_add_signed(rng.gen_range(-3..=3)))
                    * if rng.gen() { 1.0 } else { -1.0 }
            }
            // Exponents 24..28 apart: the sticky bit.
            5 => {
                let e = (other.to_bits() >> 23 & 0xFF) as i32 - rng.gen_range(20..32);
                f32::from_bits(sign | (e.clamp(0, 255) as u32) << 23 | rng.gen::<u32>() & FRAC)
            }
            // Short significands: exact ties.
            6 => f32::from_bits(sign | rng.gen_range(1..255u32) << 23 | (rng.gen::<u32>() & FRAC) & !0xFFF),
            // Near the edges of the normal range.
            7 => {
                f32::from_bits(sign | [1u32, 2, 3, 252, 253, 254][rng.gen_range(0..6)] << 23 | rng.gen::<u32>() & FRAC)
            }
            _ => f32::from_bits(sign | rng.gen_range(100..156u32) << 23 | rng.gen::<u32>() & FRAC),
        }
    }

    #[test]
    fn integer_paths_equal_the_operators() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x005F_10A7);
        for i in 0..20_000_000u32 {
            let seed = f32::from_bits(rng.gen::<u32>() & !SIGN | 0x3F00_0000);
            let a = operand(&mut rng, seed);
            let b = operand(&mut rng, a);
            let (a, b) = if i & 1 == 0 { (a, b) } else { (b, a) };
            assert!(same(add_int(a, b), a + b), "{a:e} + {b:e}: {:e} != {:e}", add_int(a, b), a + b);
            assert!(same(add_int(a, -b), a - b), "{a:e} - {b:e}");
            assert!(same(mul_int(a, b), a * b), "{a:e} * {b:e}: {:e} != {:e}", mul_int(a, b), a * b);
        }
        for i in 0..4_000_000u32 {
            let seed = f32::from_bits(rng.gen::<u32>() & !SIGN | 0x3F00_0000);
            let a = operand(&mut rng, seed);
            let b = operand(&mut rng, a);
            let (a, b) = if i & 1 == 0 { (a, b) } else { (b, a) };
            assert!(same(div_int(a, b), a / b), "{a:e} / {b:e}: {:e} != {:e}", div_int(a, b), a / b);
            assert!(same(recip_int(b), 1.0 / b), "1 / {b:e}: {:e} != {:e}", recip_int(b), 1.0 / b);
        }
        // Every divisor significand against 1 and against the largest numerator significand.
        for m in 0..1u32 << 23 {
            let b = f32::from_bits(0x3F80_0000 | m);
            assert!(same(div_int(1.0, b), 1.0 / b), "1 / {b:e}");
            for b in [b, -b, b * 1e-30, b * 1e30, b * 1e-38, b * 1e38] {
                assert!(same(recip_int(b), 1.0 / b), "recip {b:e}");
            }
            let a = f32::from_bits(0x3FFF_FFFF);
            assert!(same(div_int(a, b), a / b), "{a:e} / {b:e}");
        }
        // x − x is +0 under ties-to-even, as the operator gives.
        assert_eq!(add_int(1.5, -1.5).to_bits(), 0);
    }

    /// The zero shortcut of `add_often_zero` answers exactly where the operator's sum is
    /// the other operand or a signed zero, and leaves everything else to `add`: every pair
    /// of ±0, ±finite, ±∞ and NaN, and random operands.
    #[test]
    fn sums_with_a_zero_equal_the_operator() {
        let specials = [0.0, -0.0, 1.5, -2.25e-40, f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        let mut rng = ChaCha8Rng::seed_from_u64(0x2E50_ADD5);
        let mut pairs: Vec<(f32, f32)> = specials.iter().flat_map(|&a| specials.map(|b| (a, b))).collect();
        for _ in 0..200_000 {
            let a = operand(&mut rng, 1.0);
            let z = if rng.gen() { 0.0 } else { -0.0 };
            pairs.extend([(a, z), (z, a), (a, operand(&mut rng, a))]);
        }
        let mut shortcut = 0;
        for (a, b) in pairs {
            let zero_and_finite = (a == 0.0 && b.is_finite()) || (b == 0.0 && a.is_finite());
            match sum_with_zero(a, b) {
                Some(sum) => {
                    assert!(same(sum, a + b), "{a:e} + {b:e}: {sum:e}");
                    shortcut += 1;
                }
                None => assert!(!zero_and_finite, "{a:e} + {b:e} left to add"),
            }
            assert!(same(add_often_zero(a, b), a + b), "{a:e} + {b:e}");
        }
        assert!(shortcut > 300_000, "{shortcut}");
    }

    /// The CFU path off the target (the unit's Rust twin) gives the operators' sums and
    /// products, a NaN as the canonical quiet NaN: the function ids it sends are add's and
    /// mul's (swapped or wrong ids would answer the other operation or NaN).
    #[test]
    fn cfu_twin_paths_equal_the_operators_with_canonical_nans() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x0CF0_0F32);
        for _ in 0..200_000u32 {
            let seed = f32::from_bits(rng.gen::<u32>() & !SIGN | 0x3F00_0000);
            let a = operand(&mut rng, seed);
            let b = operand(&mut rng, a);
            for (got, want) in [(cfu::add(a, b), a + b), (cfu::mul(a, b), a * b)] {
                let want = if want.is_nan() { f32::from_bits(0x7FC0_0000) } else { want };
                assert_eq!(got.to_bits(), want.to_bits(), "{a:e}, {b:e}");
            }
        }
    }

    /// A [`Multiplier`]'s products are the operator's, bit for bit, wherever it gives one
    /// (operand pairs biased to the hard cases, as above), and it gives one for every pair of
    /// normal operands with a normal product.
    #[test]
    fn multiplier_products_equal_the_operator() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x3017_1F1E);
        let mut answered = 0u32;
        for i in 0..4_000_000u32 {
            let seed = f32::from_bits(rng.gen::<u32>() & !SIGN | 0x3F00_0000);
            let a = operand(&mut rng, seed);
            let b = operand(&mut rng, a);
            let (a, b) = if i & 1 == 0 { (a, b) } else { (b, a) };
            let Some(by_b) = Multiplier::new(b) else {
                assert!(!b.is_normal(), "{b:e}");
                continue;
            };
            match by_b.times(a) {
                Some(p) => {
                    assert!(same(p, a * b), "{a:e} * {b:e}: {p:e} != {:e}", a * b);
                    answered += 1;
                }
                None => assert!(
                    !a.is_normal() || !(a * b).is_normal() || (a * b).abs() == f32::MIN_POSITIVE,
                    "{a:e} * {b:e}"
                ),
            }
        }
        assert!(answered > 1_000_000, "{answered}");
    }

    #[test]
    fn truncation_equals_the_cast() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x007C_0001);
        let edges = [0.0, -0.0, 0.5, -0.99, 1.0, -1.0, 2147483520.0, 2147483648.0, -2147483648.0, -2147483904.0];
        let specials = [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MAX, f32::MIN, f32::MIN_POSITIVE];
        for x in edges.into_iter().chain(specials) {
            assert_eq!(trunc_i32_bits(x), x as i32, "{x:e}");
        }
        for _ in 0..2_000_000 {
            let x = f32::from_bits(rng.gen());
            assert_eq!(trunc_i32_bits(x), x as i32, "{x:e}");
            let y = f32::from_bits(rng.gen_range(0x3F00_0000..0x4F80_0000) | if rng.gen() { SIGN } else { 0 });
            assert_eq!(trunc_i32_bits(y), y as i32, "{y:e}");
        }
    }

    #[test]
    fn small_integers_convert_as_the_cast() {
        for x in (0..1u32 << 24).step_by(7).chain([1, 2, 3, (1 << 24) - 1, 1 << 24, u32::MAX]) {
            assert_eq!(u32_to_f32_bits(x).to_bits(), (x as f32).to_bits(), "{x}");
        }
    }

    #[test]
    fn vector_forms_are_glams() {
        let (a, b) = (Vec3::new(0.1, -2.5, 3.75), Vec3::new(1e-3, 7.0, -0.3));
        assert_eq!(vadd(a, b), a + b);
        assert_eq!(vsub(a, b), a - b);
        assert_eq!(vscale(a, 0.7), a * 0.7);
        assert_eq!(vscale(a, 0.7), 0.7 * a);
        assert_eq!(dot(a, b).to_bits(), a.dot(b).to_bits());
    }
}
