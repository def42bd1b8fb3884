//! Small `f32` replacements for the transcendental functions the firmware needs: one place,
//! no `f64` anywhere.
//!
//! Why: libm's `f32` trigonometry (`tanf`, `sinf`, `cosf` with `rem_pio2f`) computes in `f64`
//! and so pulled ~11 KB of soft-double arithmetic (`__adddf3`, `__muldf3`, `__divdf3`, ...) and
//! Payne–Hanek tables into the soft-core image, whose code budget is 64 KiB. Every function
//! here is straight-line `f32` arithmetic (+, −, ×, ÷, no fused multiply-add), so the host
//! (loopback simulator) and the RISC-V image (soft or hard float) compute bit-identical
//! results, and the host's f64 reference renders stay within their PSNR bounds.
//!
//! | function | approximation | max error (measured by the tests against f64 `std`) |
//! |---|---|---|
//! | [`sin_cos_turns`] | exact reduction to ±1/8 turn, Cephes `sinf`/`cosf` polynomials | 1.1e-7 absolute |
//! | [`tan_turns`] | same reduction, `2π·r` with its rounding error, Cephes `tanf` polynomial | 1.4 ulp on (0, 1/8], 1.9 ulp on (1/8, 1/4) |
//! | [`atan2`] | octant reduction, Cephes `atanf` polynomial | 3e-7 rad absolute (1.3 ulp of π) |
//! | [`acos`] | `atan2(√((1−c)(1+c)), c)` | 3e-7 rad absolute |
//! | [`pow`] (`x ≥ 0`) | `exp2(y·log2 x)`: atanh series for `log2`, Cephes `exp2f` polynomial | 2e-7·(1 + abs(y·log2 x)) relative |
//!
//! [`sqrt`], [`length`] and [`try_normalize`] are exact (the correctly rounded square root,
//! glam's `length`/`try_normalize` operation for operation, with `crate::sfloat`'s
//! arithmetic): on a core with the F extension one `fsqrt.s` instruction instead of libm's
//! integer Goldschmidt iteration.
//!
//! Angles of [`sin_cos_turns`] and [`tan_turns`] are in *turns* (1 turn = 2π rad): the
//! callers' arguments are turns already (`sin(2π·t)` of the textures, `tan(fov/2)` with the
//! field of view in degrees = `fov/720` turns), and the reduction of a turn is exact in `f32`.
//!
//! Cephes: Stephen L. Moshier, *Cephes Math Library* (`sinf.c`, `tanf.c`, `atanf.c`, `exp2f.c`),
//! single-precision minimax coefficients.

// The coefficients are written as published (Cephes), so they can be checked against the
// source; the compiler rounds each to the nearest f32.
#![allow(clippy::excessive_precision)]

use crate::sfloat;
use gridrt_shared::math::Vec3;

const FRAC_PI_2: f32 = core::f32::consts::FRAC_PI_2;
const FRAC_PI_4: f32 = core::f32::consts::FRAC_PI_4;
const PI: f32 = core::f32::consts::PI;
const TAU: f32 = core::f32::consts::TAU;

/// The correctly rounded square root (IEEE 754): `fsqrt.s` on a RISC-V core with an FPU, libm
/// elsewhere (the same value; NaN for negative arguments).
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "riscv32", not(soft_float)))]
    {
        let r: f32;
        // SAFETY: one FPU instruction on registers; no memory, no stack, flags only.
        unsafe { core::arch::asm!("fsqrt.s {r}, {x}", r = out(freg) r, x = in(freg) x, options(pure, nomem, nostack)) };
        r
    }
    #[cfg(not(all(target_arch = "riscv32", not(soft_float))))]
    {
        libm::sqrtf(x)
    }
}

/// `v.length()` of glam, with [`sqrt`].
#[inline(always)]
pub fn length(v: Vec3) -> f32 {
    sqrt(sfloat::dot(v, v))
}

/// `v.try_normalize()` of glam (`v · (1/|v|)` when that reciprocal is finite and positive),
/// with [`sqrt`].
#[inline]
pub fn try_normalize(v: Vec3) -> Option<Vec3> {
    let rcp = sfloat::div(1.0, length(v));
    // Finite and > 0: the bits of +min subnormal ..= +MAX (a bit test, no float compare).
    if rcp.to_bits().wrapping_sub(1) < 0x7F7F_FFFF {
        Some(sfloat::vscale(v, rcp))
    } else {
        None
    }
}

/// `t = q/4 + r` with `q = round(4t)` (as an integer mod 4 is all that matters) and
/// `r ∈ [−1/8, 1/8]`, exact for every finite `t` (`q/4` and `t` are multiples of `ulp(t)`).
#[inline]
fn quarter_turns(t: f32) -> (i32, f32) {
    let t4 = 4.0 * t;
    // |4t| ≥ 2^23: 4t is an integer already (and t + 1/2 would round).
    let qf = if t4.abs() < 8_388_608.0 { libm::floorf(t4 + 0.5) } else { t4 };
    // |qf| ≥ 2^25 is a multiple of 4: quadrant 0.
    (if qf.abs() < 2.0e9 { qf as i32 } else { 0 }, t - 0.25 * qf)
}

/// `(sin 2πt, cos 2πt)`.
///
/// Reduction: `q = round(4t)` quarter turns, `r = t − q/4 ∈ [−1/8, 1/8]`, exact in `f32` for
/// every finite `t` (both are multiples of `ulp(t)`); `x = 2π·r` (one rounding, |x| ≤ π/4).
/// Kernels on [−π/4, π/4] (Cephes `sinf.c`):
/// `sin x = x + x³·(−1.6666654611e-1 + x²·(8.3321608736e-3 − x²·1.9515295891e-4))`,
/// `cos x = 1 − x²/2 + x⁴·(4.166664568e-2 + x²·(−1.388731625e-3 + x²·2.443315712e-5))`.
/// Max error 1.1e-7 absolute (test `sin_cos_turns_match_f64`). NaN or ±∞ give NaN.
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    if !t.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let (q, r) = quarter_turns(t);
    let x = TAU * r;
    let z = x * x;
    let s = x + x * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z * (4.166_664_568_298_827e-2 + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    match q & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `sin 2πt` ([`sin_cos_turns`]).
#[inline]
pub fn sin_turns(t: f32) -> f32 {
    sin_cos_turns(t).0
}

/// `cos 2πt` ([`sin_cos_turns`]).
#[inline]
pub fn cos_turns(t: f32) -> f32 {
    sin_cos_turns(t).1
}

/// `2π` in three parts: `TAU_HI` (12 significant bits) + `TAU_MID` (12 bits) = `TAU` (the f32
/// nearest 2π), `TAU_TAIL` ≈ 2π − `TAU`.
const TAU_HI: f32 = 6.281_25;
const TAU_MID: f32 = TAU - TAU_HI;
const TAU_TAIL: f32 = -1.748_455_6e-7;

/// `tan 2πt`, accurate to 1.4 ulp for `t ∈ (0, 1/8]` and 1.9 ulp for `t ∈ (1/8, 1/4)` (the
/// camera's `tan(fov/2)`: correctly rounded for the fields of view 1°…90° of the test
/// `tan_turns_matches_f64`, like libm's `tanf` before).
///
/// The reduction of [`sin_cos_turns`] (`t = q/4 + r`, exact), then `x = 2π·r` carried as
/// `x + e`: `x = fl(TAU·r)` and its rounding error `e` exactly (Dekker's product with
/// Veltkamp's split, no fused multiply-add) plus `TAU_TAIL·r`. Kernel on [−π/4, π/4]
/// (Cephes `tanf.c`): `tan x = x + x³·(3.33331568548e-1 + x²·(1.33387994085e-1 + x²·(5.34112807005e-2
/// + x²·(2.44301354525e-2 + x²·(3.11992232697e-3 + x²·9.38540185543e-3)))))`, corrected by
/// `tan(x + e) ≈ tan x + e·(1 + tan² x)`; odd quarters give `tan(π/2 + x) = −1/tan x`.
pub fn tan_turns(t: f32) -> f32 {
    if !t.is_finite() {
        return f32::NAN;
    }
    let (q, r) = quarter_turns(t);
    let x = TAU * r;
    let c = 4097.0 * r;
    let rh = c - (c - r);
    let rl = r - rh;
    let e = (((TAU_HI * rh - x) + TAU_HI * rl + TAU_MID * rh) + TAU_MID * rl) + TAU_TAIL * r;
    let z = x * x;
    let p = 3.33331568548e-1
        + z * (1.33387994085e-1
            + z * (5.34112807005e-2 + z * (2.44301354525e-2 + z * (3.11992232697e-3 + z * 9.38540185543e-3))));
    let small = x * z * p;
    let y0 = x + small;
    let y = x + (small + e * (1.0 + y0 * y0));
    if q & 1 == 0 {
        y
    } else {
        -1.0 / y
    }
}

/// `atan a` for `a ∈ [0, 1]`: Cephes `atanf.c` — above tan(π/8) it uses
/// `π/4 + atan((a − 1)/(a + 1))`, then on |x| ≤ tan(π/8)
/// `atan x = x + x³·(−3.33329491539e-1 + x²·(1.99777106478e-1 + x²·(−1.38776856032e-1 + x²·8.05374449538e-2)))`.
fn atan_unit(a: f32) -> f32 {
    let (base, x) = if a > 0.414_213_56 { (FRAC_PI_4, (a - 1.0) / (a + 1.0)) } else { (0.0, a) };
    let z = x * x;
    base + (x + x
        * z
        * (-3.333_294_915_39e-1 + z * (1.997_771_064_78e-1 + z * (-1.387_768_560_32e-1 + z * 8.053_744_495_38e-2))))
}

/// `atan2(y, x)` in radians, in (−π, π], with libm's signs of zero (`atan2(±0, +0) = ±0`,
/// `atan2(±0, −0) = ±π`). Octant reduction to a ratio in [0, 1] and `atan_unit`.
/// Max error 3e-7 rad, 1.3 ulp of π (test `atan2_matches_f64`). NaN in, NaN out.
pub fn atan2(y: f32, x: f32) -> f32 {
    if x.is_nan() || y.is_nan() {
        return f32::NAN;
    }
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    // Both zero: 0; both infinite: 1 (π/4 as in libm).
    let r = if lo == hi {
        if hi == 0.0 {
            0.0
        } else {
            1.0
        }
    } else {
        lo / hi
    };
    let mut a = atan_unit(r);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x.is_sign_negative() {
        a = PI - a;
    }
    a.copysign(y)
}

/// `acos c` in radians for `c ∈ [−1, 1]` (NaN outside): `atan2(√((1 − c)(1 + c)), c)`.
/// Max error 3e-7 rad (test `acos_matches_f64`).
pub fn acos(c: f32) -> f32 {
    atan2(libm::sqrtf((1.0 - c) * (1.0 + c)), c)
}

/// `2^k` for `k ∈ [−126, 127]`, exactly.
#[inline]
fn pow2i(k: i32) -> f32 {
    f32::from_bits(((k + 127) as u32) << 23)
}

/// `log2 x` for finite `x > 0` (subnormals included): `x = m·2^k` with `m ∈ [√½, √2)`,
/// `ln m = 2·atanh s = 2s·(1 + s²/3 + s⁴/5 + s⁶/7 + s⁸/9)`, `s = (m − 1)/(m + 1)`, |s| ≤ 0.1716
/// (truncation 2e-9 relative).
fn log2(x: f32) -> f32 {
    let (x, k0) = if x < f32::MIN_POSITIVE { (x * 33_554_432.0, -25) } else { (x, 0) };
    let bits = x.to_bits();
    let mut k = k0 + ((bits >> 23) as i32 - 127);
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        k += 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    let ln_m = 2.0 * s * (1.0 + z * (1.0 / 3.0 + z * (0.2 + z * (1.0 / 7.0 + z * (1.0 / 9.0)))));
    k as f32 + ln_m * core::f32::consts::LOG2_E
}

/// `2^v`: `n = round(v)`, `f = v − n ∈ [−½, ½]` (exact), Cephes `exp2f.c`
/// `2^f = 1 + f·(6.931472028550421e-1 + f·(2.402264791363012e-1 + f·(5.550332471162809e-2 +
/// f·(9.618437357674640e-3 + f·(1.339887440266574e-3 + f·1.535336188319500e-4)))))`,
/// then `·2^n` in two exact steps (one rounding, also for subnormal results).
fn exp2(v: f32) -> f32 {
    if v.is_nan() {
        return v;
    }
    if v <= -150.0 {
        return 0.0;
    }
    if v >= 128.0 {
        return f32::INFINITY;
    }
    let n = libm::floorf(v + 0.5);
    let f = v - n;
    let p = 1.0
        + f * (6.931_472_028_550_421e-1
            + f * (2.402_264_791_363_012e-1
                + f * (5.550_332_471_162_809e-2
                    + f * (9.618_437_357_674_64e-3 + f * (1.339_887_440_266_574e-3 + f * 1.535_336_188_319_5e-4)))));
    let n = n as i32;
    let n1 = n / 2;
    p * pow2i(n1) * pow2i(n - n1)
}

/// `x^y` for `x ≥ 0` (the specular lobes' `(n·h)^e`): `exp2(y·log2 x)`, with libm's special
/// cases `x^0 = 1^y = 1`, `0^y = 0` (y > 0) or `+∞` (y < 0); negative `x` gives NaN.
/// Max relative error 2e-7·(1 + |y·log2 x|) (test `pow_matches_f64`).
pub fn pow(x: f32, y: f32) -> f32 {
    if y == 0.0 || x == 1.0 {
        return 1.0;
    }
    if x == 0.0 {
        return if y > 0.0 { 0.0 } else { f32::INFINITY };
    }
    if x < 0.0 || x.is_nan() || y.is_nan() {
        return f32::NAN;
    }
    if x == f32::INFINITY {
        return if y > 0.0 { f32::INFINITY } else { 0.0 };
    }
    exp2(y * log2(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic samples of `[lo, hi]`: an even grid plus the end points.
    fn grid(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f32> {
        (0..=n).map(move |i| (lo + (hi - lo) * i as f64 / n as f64) as f32)
    }

    fn ulp_err(got: f32, want: f64) -> f64 {
        let w = want as f32;
        let ulp = (f32::from_bits(w.abs().to_bits() + 1) - w.abs()) as f64;
        (got as f64 - want).abs() / ulp
    }

    #[test]
    fn sin_cos_turns_match_f64() {
        let mut worst = 0.0f64;
        for t in grid(-3.0, 3.0, 600_000).chain(grid(-1e4, 1e4, 100_000)) {
            let (s, c) = sin_cos_turns(t);
            let a = std::f64::consts::TAU * t as f64;
            worst = worst.max((s as f64 - a.sin()).abs()).max((c as f64 - a.cos()).abs());
        }
        assert!(worst <= 1.1e-7, "{worst:e}");
        // Exact at the quarter turns.
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25).0, 1.0);
        assert_eq!(sin_cos_turns(-0.5).1, -1.0);
        assert_eq!(sin_cos_turns(1e30), (0.0, 1.0));
        assert!(sin_turns(f32::NAN).is_nan() && cos_turns(f32::INFINITY).is_nan());
    }

    #[test]
    fn tan_turns_matches_f64() {
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        // The camera's range: fov in (0°, 180°) = (0, 1/4) turn.
        for t in grid(1e-6, 0.25 - 1e-6, 400_000) {
            let e = ulp_err(tan_turns(t), (std::f64::consts::TAU * t as f64).tan());
            if t <= 0.125 {
                lo = lo.max(e);
            } else {
                hi = hi.max(e);
            }
        }
        assert!(lo <= 1.4 && hi <= 1.9, "{lo} / {hi} ulp");
        assert_eq!(tan_turns(0.125), 1.0);
        assert_eq!(tan_turns(0.0), 0.0);
        assert!(tan_turns(f32::NAN).is_nan());
        // The tail of 2π.
        assert_eq!(TAU_TAIL, (std::f64::consts::TAU - TAU as f64) as f32);
        // From the field of view in degrees, fov/720 rounds once, like `to_radians() * 0.5`
        // before libm's `tanf`, which the camera used before: the same results up to 90°
        // (correctly rounded), within 2 ulp or better than that path above.
        for fov in [1.0f32, 30.0, 45.0, 60.0, 90.0, 120.0, 179.0, 179.9] {
            let want = (fov as f64).to_radians().mul_add(0.5, 0.0).tan();
            let (new, old) = (ulp_err(tan_turns(fov / 720.0), want), ulp_err(libm::tanf(fov.to_radians() * 0.5), want));
            assert!(new <= 2.0 || new <= old, "{fov}: {new} vs {old} ulp");
        }
    }

    #[test]
    fn atan2_matches_f64() {
        let mut worst = 0.0f64;
        for a in grid(-std::f64::consts::PI, std::f64::consts::PI, 200_000) {
            for r in [1e-3f64, 0.7, 1.0, 3.0, 1e4] {
                let (y, x) = ((r * (a as f64).sin()) as f32, (r * (a as f64).cos()) as f32);
                worst = worst.max((atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs());
            }
        }
        assert!(worst <= 3e-7, "{worst:e}");
        for (y, x) in [(0.0f32, 0.0f32), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (1.0, 0.0), (-1.0, -0.0), (0.0, -2.0)]
        {
            assert_eq!(atan2(y, x).to_bits(), libm::atan2f(y, x).to_bits(), "atan2({y}, {x})");
        }
        assert_eq!(atan2(f32::INFINITY, -f32::INFINITY), 3.0 * FRAC_PI_4);
        assert!(atan2(f32::NAN, 1.0).is_nan());
    }

    #[test]
    fn acos_matches_f64() {
        let mut worst = 0.0f64;
        for c in grid(-1.0, 1.0, 400_000) {
            worst = worst.max((acos(c) as f64 - (c as f64).acos()).abs());
        }
        assert!(worst <= 3e-7, "{worst:e}");
        assert_eq!(acos(1.0), 0.0);
        assert_eq!(acos(-1.0), PI);
        assert!(acos(1.5).is_nan());
    }

    #[test]
    fn pow_matches_f64() {
        let mut worst = 0.0f64;
        let xs = grid(0.0, 1.0, 20_000).chain(grid(1.0, 4.0, 2_000)).chain([1e-30, 1e-40, f32::MIN_POSITIVE]);
        for x in xs.filter(|&x| x > 0.0) {
            for y in [0.25f32, 0.5, 1.0, 2.0, 7.5, 32.0, 100.0, 1000.0, 12345.0, -1.5] {
                let want = (x as f64).powf(y as f64);
                let got = pow(x, y) as f64;
                let scale = 1.0 + (y as f64 * (x as f64).log2()).abs();
                if want.is_finite() && want < f32::MAX as f64 {
                    // Below f32's normal range add the spacing of subnormals (2^-149).
                    let err = (got - want).abs() - 1.5e-45;
                    assert!(err <= 2e-7 * scale * want, "pow({x}, {y}) = {got:e}, want {want:e}");
                    if want >= f32::MIN_POSITIVE as f64 {
                        worst = worst.max((got - want).abs() / want / scale);
                    }
                }
            }
        }
        assert!(worst <= 2e-7, "{worst:e}");
        assert_eq!(pow(0.0, 0.0), 1.0);
        assert_eq!(pow(0.0, 3.0), 0.0);
        assert_eq!(pow(0.0, -1.0), f32::INFINITY);
        assert_eq!(pow(1.0, f32::NAN), 1.0);
        assert_eq!(pow(0.5, 1.0), 0.5);
        assert_eq!(pow(0.25, 0.5), 0.5);
        assert!(pow(-1.0, 2.0).is_nan());
    }
}
