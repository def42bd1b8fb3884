//! Number formats of the intersection kernels: `f32` and two fixed-point formats.
//!
//! Sources: the ray–triangle study (Andrade Guerra 2020: every FPGA kernel in fixed point with 64-bit
//! intermediates and about 23 fractional bits, the scene scaled into a positive box);
//! J. Hanika, A. Keller, "Towards Hardware Ray Tracing using Fixed Point Arithmetic", IEEE
//! Symposium on Interactive Ray Tracing 2007 (scene normalised into a positive box so that
//! the ranges of every intermediate can be bounded).
//!
//! # Formats
//!
//! | [`NumberFormat`] | name | storage | intermediates | resolution | box |
//! |---|---|---|---|---|---|
//! | `F32` | `f32` | f32 | f32 | 24-bit mantissa | world coordinates |
//! | `Fixed64Q23` | `fixed64-q23` | i32, Q8.23 | i64, Q40.23 | 2⁻²³ | scene box → [0, 16] |
//! | `Fixed32Q16` | `fixed32-q16` | i32, Q15.16 | i32, Q15.16 | 2⁻¹⁶ | scene box → [0, 4] |
//!
//! `Fixed64Q23` is Andrade Guerra's (2020) choice. `Fixed32Q16` is what a small FPGA would pick: one
//! 32-bit datapath, 32×32→64 multiplies (one DSP cascade) rounded straight back to 32 bits.
//!
//! # The fixed-point frame ([`FixedFrame`])
//!
//! Fixed-point kernels work in frame coordinates `X = (x − box.min) · s`, with `s` the largest
//! power of two that maps the scene box's largest extent into `[0, BOX]` (Hanika–Keller's
//! positive box; a power of two so that the scaling itself is exact). Ray directions are
//! scaled by the same `s` and then by a per-ray power of two `2^-j` so that their largest
//! component lies in `[1, 2)`; the kernel's `t` is then `t_world · 2^j`, converted back
//! exactly. Because the frame is anchored at the box, a translated scene gives the same
//! frame coordinates up to the f32 rounding of its inputs: fixed point has no float-style
//! error growth with distance from the world origin.
//!
//! # Overflow is detected, never wrapped ([`Fx`])
//!
//! Every fixed-point operation is checked. A result outside the format's range (i32 for
//! `Fixed32Q16`, i64 for `Fixed64Q23`), a division by zero, or an unrepresentable input
//! becomes *poison*, which propagates through later operations like a NaN and fails every
//! comparison. Kernels check their decision values with [`Fx::ok`] and return
//! [`Overflow`]; the co-processor counts these (`CoprocStats::overflows`) and treats the test
//! as a miss that is reported, not as a silent wrong answer.
//!
//! Rounding: products are rounded to nearest (ties up) after the full-width multiply;
//! quotients truncate toward zero (Andrade Guerra 2020, as C and Rust integer division do).

use core::marker::PhantomData;
use core::ops::{Add, Div, Mul, Neg, Sub};

/// Run-time selection of the number format the kernels compute in.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum NumberFormat {
    /// IEEE-754 single precision (the default; the kernels of the scene image as is).
    #[default]
    F32,
    /// Fixed point, Q8.23 storage in i32, 64-bit intermediates (Andrade Guerra 2020).
    Fixed64Q23,
    /// Fixed point, Q15.16 in i32 for storage and every intermediate (a small FPGA).
    Fixed32Q16,
}

impl NumberFormat {
    /// Every format, in a stable order.
    pub const ALL: [NumberFormat; 3] = [Self::F32, Self::Fixed64Q23, Self::Fixed32Q16];

    /// Short name (for CLIs and reports).
    pub const fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::Fixed64Q23 => "fixed64-q23",
            Self::Fixed32Q16 => "fixed32-q16",
        }
    }

    /// Parses [`NumberFormat::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// True for the fixed-point formats.
    pub const fn is_fixed(self) -> bool {
        !matches!(self, Self::F32)
    }

    /// Fractional bits (0 for f32).
    pub const fn frac_bits(self) -> u32 {
        match self {
            Self::F32 => 0,
            Self::Fixed64Q23 => Q23::FRAC,
            Self::Fixed32Q16 => Q16::FRAC,
        }
    }

    /// Size of the frame box in fixed-point units (the scene's largest extent maps into
    /// `[0, box_units]`); 0 for f32.
    pub const fn box_units(self) -> f64 {
        match self {
            Self::F32 => 0.0,
            Self::Fixed64Q23 => Q23::BOX_UNITS,
            Self::Fixed32Q16 => Q16::BOX_UNITS,
        }
    }
}

/// A fixed-point operation left the format's range (or divided by zero). Reported, never
/// wrapped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Overflow;

impl core::fmt::Display for Overflow {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("fixed-point overflow")
    }
}

/// Operation count of one full test (no early exit): the basis of the cycle model
/// (`timing::test_cycles`). Negations and absolute values are free (sign-bit logic);
/// `cmp` counts comparisons and sign tests of computed values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct OpCount {
    /// Additions and subtractions.
    pub add: u16,
    /// Multiplications (fixed point: including the rounding shift; FMA counts as mul + add).
    pub mul: u16,
    /// Divisions and reciprocals.
    pub div: u16,
    /// Comparisons.
    pub cmp: u16,
}

impl OpCount {
    /// All operations.
    pub const fn total(&self) -> u32 {
        self.add as u32 + self.mul as u32 + self.div as u32 + self.cmp as u32
    }
}

/// The fixed-point frame: frame coordinates are `(x − origin) · scale` (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedFrame {
    /// World point mapped to 0 (the scene box's minimum corner).
    pub origin: [f32; 3],
    /// World → frame scale, a power of two.
    pub scale: f64,
}

impl Default for FixedFrame {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl FixedFrame {
    /// Frame coordinates = world coordinates.
    pub const IDENTITY: FixedFrame = FixedFrame { origin: [0.0; 3], scale: 1.0 };

    /// Hanika–Keller's positive box: `min` goes to 0 and the largest extent is scaled by the
    /// largest power of two that keeps it ≤ `format.box_units()`. The extent is the largest
    /// `fl32(max − min)`, as the co-processor computes it from a FRAME packet (SPEC §4.6).
    /// `None` for a non-finite or inverted box; a box of zero extent gets scale 1. For f32
    /// the frame is unused and [`FixedFrame::IDENTITY`] is returned.
    pub fn for_box(min: [f32; 3], max: [f32; 3], format: NumberFormat) -> Option<Self> {
        if !format.is_fixed() {
            return Some(Self::IDENTITY);
        }
        if min.iter().chain(max.iter()).any(|c| !c.is_finite()) || (0..3).any(|a| max[a] < min[a]) {
            return None;
        }
        // The extent as the co-processor computes it from a FRAME box: f32 subtractions.
        let extent = (0..3).map(|a| max[a] - min[a]).fold(0.0f32, f32::max);
        if extent <= 0.0 {
            return Some(Self { origin: min, scale: 1.0 });
        }
        // The largest 2^s with 2^s · extent ≤ units: s = log2(units) − ⌈log2 extent⌉
        // (an infinite extent counts as 2^128).
        let (_, units_exp) = libm::frexp(format.box_units());
        let units_log2 = units_exp - 1;
        Some(Self { origin: min, scale: libm::ldexp(1.0, units_log2 - ceil_log2(extent)) })
    }

    /// Frame coordinate of world point `p` (exact in f64 for f32 inputs of similar exponent;
    /// rounded once otherwise).
    #[inline]
    pub fn point(&self, p: [f32; 3]) -> [f64; 3] {
        [
            (p[0] as f64 - self.origin[0] as f64) * self.scale,
            (p[1] as f64 - self.origin[1] as f64) * self.scale,
            (p[2] as f64 - self.origin[2] as f64) * self.scale,
        ]
    }

    /// Frame direction of world direction `d` normalised by a power of two so that its
    /// largest component lies in `[1, 2)`, and the factor `k` with `t_frame = t_world · k`.
    /// `None` for a zero or non-finite direction.
    #[inline]
    pub fn direction(&self, d: [f32; 3]) -> Option<([f64; 3], f64)> {
        let ds = [d[0] as f64 * self.scale, d[1] as f64 * self.scale, d[2] as f64 * self.scale];
        let m = ds[0].abs().max(ds[1].abs()).max(ds[2].abs());
        if !(m > 0.0 && m.is_finite()) {
            return None;
        }
        // m = f·2^e, f ∈ [0.5, 1): m·2^(1−e) ∈ [1, 2).
        let (_, e) = libm::frexp(m);
        let norm = libm::ldexp(1.0, 1 - e);
        // t_frame: P = O + t·ds = O + (t / norm)·(ds·norm), so t_frame = t_world / norm.
        Some(([ds[0] * norm, ds[1] * norm, ds[2] * norm], 1.0 / norm))
    }
}

/// `⌈log2 x⌉` of a positive f32 (128 for +∞), from its bits.
fn ceil_log2(x: f32) -> i32 {
    let bits = x.to_bits() & 0x7FFF_FFFF;
    let field = (bits >> 23) as i32;
    let frac = bits & 0x7F_FFFF;
    if field == 0xFF {
        128
    } else if field == 0 {
        // Subnormal: floor(log2) is the top set bit − 149; exact powers of two stay.
        let floor = 31 - bits.leading_zeros() as i32 - 149;
        floor + !bits.is_power_of_two() as i32
    } else {
        field - 127 + (frac != 0) as i32
    }
}

/// A fixed-point format (implemented by [`Q23`] and [`Q16`]).
pub trait FixedFormat: Copy + core::fmt::Debug + 'static {
    /// The run-time selector.
    const FORMAT: NumberFormat;
    /// Fractional bits.
    const FRAC: u32;
    /// True: intermediates are 64-bit; false: every value must fit 32 bits.
    const WIDE: bool;
    /// Frame box size in units (module doc).
    const BOX_UNITS: f64;
}

/// Seed 002's format: Q8.23 storage, 64-bit intermediates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Q23;
impl FixedFormat for Q23 {
    const FORMAT: NumberFormat = NumberFormat::Fixed64Q23;
    const FRAC: u32 = 23;
    const WIDE: bool = true;
    const BOX_UNITS: f64 = 16.0;
}

/// A small FPGA's format: Q15.16 everywhere (32-bit datapath).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Q16;
impl FixedFormat for Q16 {
    const FORMAT: NumberFormat = NumberFormat::Fixed32Q16;
    const FRAC: u32 = 16;
    const WIDE: bool = false;
    const BOX_UNITS: f64 = 4.0;
}

/// Raw value of poison (overflowed) numbers. Valid values are in `[−MAX, MAX]`.
const POISON: i64 = i64::MIN;

/// A checked fixed-point number of format `Q` (module doc: poison semantics).
#[derive(Clone, Copy)]
pub struct Fx<Q> {
    raw: i64,
    _q: PhantomData<Q>,
}

impl<Q> core::fmt::Debug for Fx<Q> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.raw == POISON {
            f.write_str("Fx(overflow)")
        } else {
            write!(f, "Fx(raw {})", self.raw)
        }
    }
}

impl<Q> PartialEq for Fx<Q> {
    /// Poison equals nothing, itself included (like NaN).
    #[inline(always)]
    fn eq(&self, o: &Self) -> bool {
        self.raw == o.raw && self.raw != POISON
    }
}

impl<Q: FixedFormat> Fx<Q> {
    /// Largest raw magnitude of the format's intermediates.
    pub const MAX_RAW: i64 = if Q::WIDE { i64::MAX } else { i32::MAX as i64 };
    /// Zero.
    pub const ZERO: Self = Self::from_raw_unchecked(0);
    /// One.
    pub const ONE: Self = Self::from_raw_unchecked(1 << Q::FRAC);
    /// The poison value.
    pub const OVERFLOW: Self = Self::from_raw_unchecked(POISON);

    const fn from_raw_unchecked(raw: i64) -> Self {
        Self { raw, _q: PhantomData }
    }

    /// From a raw value held in a wider integer: poison when outside the format's range.
    #[inline(always)]
    fn fit(v: i128) -> Self {
        if v > Self::MAX_RAW as i128 || v < -(Self::MAX_RAW as i128) {
            Self::OVERFLOW
        } else {
            Self::from_raw_unchecked(v as i64)
        }
    }

    /// From a raw value (poison when out of range).
    #[inline]
    pub fn from_raw(raw: i64) -> Self {
        Self::fit(raw as i128)
    }

    /// The raw integer (`value · 2^FRAC`); `i64::MIN` for poison.
    #[inline]
    pub fn raw(self) -> i64 {
        self.raw
    }

    /// True for an overflowed value.
    #[inline(always)]
    pub fn is_poison(self) -> bool {
        self.raw == POISON
    }

    /// `Ok(self)` unless poison.
    #[inline(always)]
    pub fn ok(self) -> Result<Self, Overflow> {
        if self.is_poison() {
            Err(Overflow)
        } else {
            Ok(self)
        }
    }

    /// Rounds `x · 2^FRAC` to nearest; poison for NaN, ±∞ or out of range.
    #[inline]
    pub fn from_f64(x: f64) -> Self {
        let s = x * (1u64 << Q::FRAC) as f64;
        // `|s| < 2^63` is false for NaN too.
        if s.is_nan() || s.abs() >= 9.223_372_036_854_775e18 {
            return Self::OVERFLOW;
        }
        Self::fit(libm::round(s) as i64 as i128)
    }

    /// The value as f64 (NaN for poison).
    #[inline]
    pub fn to_f64(self) -> f64 {
        if self.is_poison() {
            f64::NAN
        } else {
            self.raw as f64 / (1u64 << Q::FRAC) as f64
        }
    }

    /// Decodes a stored i32 word; `i32::MIN` is the stored form of poison.
    #[inline(always)]
    pub fn from_word(w: u32) -> Self {
        let v = w as i32;
        if v == i32::MIN {
            Self::OVERFLOW
        } else {
            Self::from_raw_unchecked(v as i64)
        }
    }

    /// Encodes for storage as an i32 word; values that do not fit 32 bits (and poison) are
    /// stored as poison (`i32::MIN`) and reported by the caller.
    #[inline]
    pub fn to_word(self) -> Result<u32, Overflow> {
        if self.is_poison() || self.raw > i32::MAX as i64 || self.raw < -(i32::MAX as i64) {
            Err(Overflow)
        } else {
            Ok(self.raw as i32 as u32)
        }
    }

    /// Absolute value (poison stays poison).
    #[inline(always)]
    pub fn abs(self) -> Self {
        if self.raw < 0 && !self.is_poison() {
            Self::from_raw_unchecked(-self.raw)
        } else {
            self
        }
    }

    /// True when strictly positive (false for poison).
    #[inline(always)]
    pub fn is_pos(self) -> bool {
        self.raw > 0
    }

    /// True when strictly negative (false for poison).
    #[inline(always)]
    pub fn is_neg(self) -> bool {
        self.raw < 0 && !self.is_poison()
    }

    /// True when zero.
    #[inline(always)]
    pub fn is_zero(self) -> bool {
        self.raw == 0
    }

    /// The largest valid value.
    #[inline(always)]
    pub fn max_value() -> Self {
        Self::from_raw_unchecked(Self::MAX_RAW)
    }
}

impl<Q: FixedFormat> Add for Fx<Q> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        if self.is_poison() || o.is_poison() {
            return Self::OVERFLOW;
        }
        Self::fit(self.raw as i128 + o.raw as i128)
    }
}

impl<Q: FixedFormat> Sub for Fx<Q> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        if self.is_poison() || o.is_poison() {
            return Self::OVERFLOW;
        }
        Self::fit(self.raw as i128 - o.raw as i128)
    }
}

impl<Q: FixedFormat> Neg for Fx<Q> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        // Valid values are symmetric (|raw| ≤ MAX_RAW), so negation never overflows.
        if self.is_poison() {
            self
        } else {
            Self::from_raw_unchecked(-self.raw)
        }
    }
}

impl<Q: FixedFormat> Mul for Fx<Q> {
    type Output = Self;
    /// Full-width product, rounded to nearest (ties up) back to `FRAC` bits, range-checked.
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        if self.is_poison() || o.is_poison() {
            return Self::OVERFLOW;
        }
        let half = 1i64 << (Q::FRAC - 1);
        if Q::WIDE {
            let p = self.raw as i128 * o.raw as i128;
            Self::fit((p + half as i128) >> Q::FRAC)
        } else {
            // |raw| < 2^31 for a 32-bit format: the product fits i64.
            let p = self.raw * o.raw;
            Self::fit(((p + half) >> Q::FRAC) as i128)
        }
    }
}

impl<Q: FixedFormat> Div for Fx<Q> {
    type Output = Self;
    /// `(a · 2^FRAC) / b`, truncated toward zero; division by zero is poison.
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        if self.is_poison() || o.is_poison() || o.raw == 0 {
            return Self::OVERFLOW;
        }
        if Q::WIDE {
            Self::fit(((self.raw as i128) << Q::FRAC) / o.raw as i128)
        } else {
            Self::fit((((self.raw) << Q::FRAC) / o.raw) as i128)
        }
    }
}

impl<Q: FixedFormat> PartialOrd for Fx<Q> {
    /// Poison is unordered (every comparison with it is false), like NaN.
    #[inline(always)]
    fn partial_cmp(&self, o: &Self) -> Option<core::cmp::Ordering> {
        if self.is_poison() || o.is_poison() {
            None
        } else {
            Some(self.raw.cmp(&o.raw))
        }
    }
}

/// A point or vector of three fixed-point numbers.
pub type Fx3<Q> = [Fx<Q>; 3];

/// Frame coordinates of an f32 point, quantised (poison components when out of range).
#[inline]
pub fn fx_point<Q: FixedFormat>(frame: &FixedFrame, p: [f32; 3]) -> Fx3<Q> {
    frame.point(p).map(Fx::from_f64)
}

/// `a − b` per component.
#[inline(always)]
pub fn fx_sub<Q: FixedFormat>(a: Fx3<Q>, b: Fx3<Q>) -> Fx3<Q> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Cross product.
#[inline(always)]
pub fn fx_cross<Q: FixedFormat>(a: Fx3<Q>, b: Fx3<Q>) -> Fx3<Q> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Dot product.
#[inline(always)]
pub fn fx_dot<Q: FixedFormat>(a: Fx3<Q>, b: Fx3<Q>) -> Fx<Q> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A ray in frame coordinates: origin, normalised direction, and the conversion factor
/// `t_world = t_frame · inv_k` (a power of two).
#[derive(Debug, Clone, Copy)]
pub struct FxRay<Q> {
    /// Origin in frame coordinates.
    pub o: Fx3<Q>,
    /// Direction in frame units, largest component in `[1, 2)`.
    pub d: Fx3<Q>,
    /// `t_world = t_frame · inv_k` (a power of two).
    pub inv_k: f64,
    /// `k`: `t_frame = t_world · k`.
    pub k: f64,
}

impl<Q: FixedFormat> FxRay<Q> {
    /// Converts a world ray into frame coordinates; overflow when its origin lies outside
    /// the format's range (or the direction is zero / not finite).
    #[inline]
    pub fn new(frame: &FixedFrame, origin: [f32; 3], dir: [f32; 3]) -> Result<Self, Overflow> {
        let o = fx_point::<Q>(frame, origin);
        let (d, k) = frame.direction(dir).ok_or(Overflow)?;
        let d = d.map(Fx::<Q>::from_f64);
        for c in o.iter().chain(d.iter()) {
            c.ok()?;
        }
        Ok(Self { o, d, inv_k: 1.0 / k, k })
    }

    /// The kernel's range cut for a world bound `t_bound`: `t_bound · k`, capped at a quarter
    /// of the format's range (hits further away are far outside any frame box: they are
    /// culled as misses without dividing, so they cannot overflow).
    #[inline]
    pub fn bound(&self, t_bound: f32) -> Fx<Q> {
        let cap = Fx::<Q>::max_value().to_f64() * 0.25;
        let b = t_bound as f64 * self.k;
        // NaN bounds cull everything (no hit can be accepted against a NaN limit).
        if b.is_nan() {
            return Fx::ZERO;
        }
        Fx::from_f64(b.min(cap))
    }

    /// World `t` of a frame `t`; `None` when it is not a finite f32 (a ray with a tiny
    /// direction can hit beyond f32's range: such a hit can never be accepted).
    #[inline]
    pub fn world_t(&self, t: Fx<Q>) -> Option<f32> {
        let w = (t.to_f64() * self.inv_k) as f32;
        (w.is_finite() && w > 0.0).then_some(w)
    }
}

/// True when `num / den > bound` for `den > 0`, decided without dividing; an overflowing
/// `bound · den` means the product exceeds every representable `num`, so: not beyond.
#[inline(always)]
pub fn beyond<Q: FixedFormat>(num: Fx<Q>, den: Fx<Q>, bound: Fx<Q>) -> bool {
    match (bound * den).ok() {
        Ok(lim) => num > lim,
        Err(_) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type A = Fx<Q23>;
    type B = Fx<Q16>;

    #[test]
    fn fixed_arithmetic_rounds_products_and_truncates_quotients() {
        let x = A::from_f64(1.5);
        let y = A::from_f64(-2.25);
        assert_eq!((x * y).to_f64(), -3.375);
        assert_eq!((x + y).to_f64(), -0.75);
        assert_eq!((y / x).to_f64(), -1.5);
        // 1/3 truncates toward zero at 2^-23.
        let third = A::ONE / A::from_f64(3.0);
        assert_eq!(third.raw(), (1i64 << 23) / 3);
        // Rounding of a product: 2^-23 · 0.5 rounds up to 2^-23.
        let tiny = A::from_raw(1);
        assert_eq!((tiny * A::from_f64(0.5)).raw(), 1);
        assert_eq!((tiny * A::from_f64(0.25)).raw(), 0);
    }

    #[test]
    fn overflow_is_poison_not_wrap() {
        // Q15.16: 200 · 200 = 40000 > 32767.
        let big = B::from_f64(200.0);
        let p = big * big;
        assert!(p.is_poison());
        assert_eq!(p.ok(), Err(Overflow));
        // Poison propagates and compares false both ways.
        let q = p + B::ONE;
        assert!(q.is_poison());
        assert_eq!(q.partial_cmp(&B::ZERO), None);
        // Sums overflow too; division by zero is poison.
        assert!((B::from_f64(30000.0) + B::from_f64(30000.0)).is_poison());
        assert!((B::ONE / B::ZERO).is_poison());
        // Out-of-range and NaN inputs.
        assert!(B::from_f64(40000.0).is_poison());
        assert!(A::from_f64(f64::NAN).is_poison());
        assert!(A::from_f64(1e30).is_poison());
        // 64-bit intermediates hold what 32 bits cannot, but storage is still 32-bit.
        let w = A::from_f64(300.0);
        assert!(!w.is_poison());
        assert_eq!(w.to_word(), Err(Overflow));
        assert_eq!(A::from_word(A::from_f64(-1.25).to_word().unwrap()).to_f64(), -1.25);
        assert!(A::from_word(i32::MIN as u32).is_poison());
    }

    #[test]
    fn frame_is_a_power_of_two_box_and_directions_normalise_exactly() {
        let f = FixedFrame::for_box([-1.0, 2.0, 0.0], [2.0, 3.0, 0.5], NumberFormat::Fixed64Q23).unwrap();
        // Extent 3 → 16/3 = 5.33 → scale 4.
        assert_eq!(f.scale, 4.0);
        assert_eq!(f.point([2.0, 2.0, 0.5]), [12.0, 0.0, 2.0]);
        let (d, k) = f.direction([0.1, -3.0, 0.0]).unwrap();
        assert!(d[1].abs() >= 1.0 && d[1].abs() < 2.0);
        // t_frame = t_world·k: one world unit of t moves d[1]·k = −3·4 frame units.
        assert_eq!(d[1] * k, -3.0 * 4.0);
        assert_eq!(FixedFrame::for_box([0.0; 3], [f32::NAN, 1.0, 1.0], NumberFormat::Fixed32Q16), None);
        assert_eq!(FixedFrame::for_box([0.0; 3], [1.0; 3], NumberFormat::F32), Some(FixedFrame::IDENTITY));
    }
}
