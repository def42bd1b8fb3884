//! The watertight test in `fixed64-q23` as the RTL co-processor computes it, bit for bit
//! (rtl/README.md §3; the HDL is `rtl/hdl/gridrt_isect_pipe.sv`, `gridrt_ray_setup.sv`, `gridrt_tri_loader.sv`).
//!
//! Woop, Benthin and Wald's watertight test (JCGT 2013) in Q23 fixed point, arranged so that a
//! pipeline issues one test per cycle with narrow multipliers:
//!
//! - **Frame coordinates** `Q(v, s+23) − Q(min, s+23)`, where [`to_fixed`] is the exact
//!   round-half-away-from-zero of `x·2^k` and `2^s` the frame scale (`FixedFrame::for_box`).
//!   A record stores the 9 coordinates as i32 ([`POISON`] where one does not fit) and a copy
//!   of the prim id (word 9), so one memory read serves a test ([`RECORD_WORDS`] = 10).
//! - **Ray setup** ([`setup`]): dominant axis `kz` (`max_dimension`), direction
//!   `Q(d, 23 − ⌊log2 |d_kz|⌋)` (the frame scale cancels), origin in frame units within
//!   ±2^33 raw, shear `trunc(−d·2^23 / dz)`.
//! - **Test** ([`intersect`]): the sheared x, y of each vertex rounded once (half up), so a
//!   shared edge has the same end points in both triangles; the edge functions, determinant
//!   and depth sum are exact integer products; the barycentric weights are cut to 34 bits by
//!   one common shift; `t` is the correctly rounded (RNE) f32 of the exact ratio. Lateral
//!   coordinates beyond ±64 frame units overflow (reported, a miss).
//! - No early-out bound: the kernel ignores `t_bound`; the caller's acceptance rule decides.
//!
//! Cost of one full test ([`WatertightQ23::OPS`]): translate (add 9), shear (mul 6, add 6),
//! edges (mul 6, add 3), sign tests (cmp 6), det (add 2, cmp 1), weights (add 2), depth (mul 3,
//! add 2), denominator (mul 1), division (div 1), front and range tests (cmp 3) → add 24,
//! mul 16, div 1, cmp 10.

use super::kernel::{Kernel, KernelKind, RecordStatus, Triangle};
use crate::numeric::{FixedFrame, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::{max_dimension, Ray};

/// Fractional bits of every fixed-point coordinate.
pub const FRAC: i32 = 23;
/// [`to_fixed`] fails for `|x·2^k| ≥ 2^HUGE_BITS`.
pub const HUGE_BITS: u32 = 54;
/// Largest stored vertex coordinate magnitude (raw): the i32 range without `i32::MIN`.
pub const VERTEX_MAX: i64 = i32::MAX as i64;
/// Ray origins need `|o| < 2^ORIGIN_BITS` (raw): within ±1024 frame units.
pub const ORIGIN_BITS: u32 = 33;
/// Sheared (lateral) vertex coordinates need `|x| < 2^LATERAL_BITS` (raw): ±64 frame units.
pub const LATERAL_BITS: u32 = 29;
/// The barycentric weights are cut to this many bits before the depth products.
pub const WEIGHT_BITS: u32 = 34;
/// Words of a record: 9 coordinates and a copy of the prim id.
pub const RECORD_WORDS: usize = 10;
/// Stored form of a coordinate that does not fit (`i32::MIN`).
pub const POISON: u32 = i32::MIN as u32;

/// `round_half_away(x · 2^k)` for a finite `x`; `None` when `|x·2^k| ≥ 2^54`.
pub fn to_fixed(x: f32, k: i32) -> Option<i64> {
    let bits = x.to_bits();
    let neg = bits >> 31 == 1;
    let field = ((bits >> 23) & 0xFF) as i32;
    let frac = (bits & 0x7F_FFFF) as u64;
    let (mant, e2) = if field == 0 { (frac, -149) } else { (frac | 0x80_0000, field - 150) };
    if mant == 0 {
        return Some(0);
    }
    let sh = e2.saturating_add(k);
    let mag: u64 = if sh >= 0 {
        let len = 64 - mant.leading_zeros() as i32;
        if len.saturating_add(sh) > HUGE_BITS as i32 {
            return None;
        }
        mant << sh
    } else if sh < -25 {
        0
    } else {
        let d = sh.unsigned_abs();
        (mant + (1u64 << (d - 1))) >> d
    };
    Some(if neg { -(mag as i64) } else { mag as i64 })
}

/// Floor of log2 of a finite nonzero f32's magnitude.
pub fn exponent_of(x: f32) -> i32 {
    let bits = x.to_bits() & 0x7FFF_FFFF;
    let field = (bits >> 23) as i32;
    if field == 0 {
        31 - bits.leading_zeros() as i32 - 149
    } else {
        field - 127
    }
}

/// The frame as the hardware holds it: the scale exponent `s` and `Q(min_a, s + 23)` per
/// axis (`None`: too large, every conversion against it fails).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Scale exponent (scale `2^s`).
    pub s: i32,
    /// `Q(min_a, s + 23)`.
    pub qm: [Option<i64>; 3],
}

impl Frame {
    /// The hardware frame of a model frame (`scale` is a power of two).
    pub fn of(f: &FixedFrame) -> Self {
        let (_, e) = libm::frexp(f.scale);
        let s = e - 1;
        Self { s, qm: f.origin.map(|m| to_fixed(m, s.saturating_add(FRAC))) }
    }

    /// Frame coordinate of a vertex component on `axis`: `Q(v) − Q(min)`, `None` when it
    /// does not fit the i32 storage (or a conversion is too large).
    pub fn vertex(&self, v: f32, axis: usize) -> Option<i32> {
        let x = to_fixed(v, self.s.saturating_add(FRAC))? - (*self.qm.get(axis)?)?;
        (x.abs() <= VERTEX_MAX).then_some(x as i32)
    }
}

/// The record of a triangle (load time): 9 frame coordinates (`POISON` where one does not
/// fit; all 0 when the quantised vertices are collinear) and `prim` in word 9.
pub fn record(frame: &Frame, tri: &Triangle, prim: u32) -> ([u32; RECORD_WORDS], RecordStatus) {
    let mut w = [0u32; RECORD_WORDS];
    let mut c = [[0i64; 3]; 3];
    let mut overflow = false;
    for (i, v) in tri.iter().enumerate() {
        for (a, x) in v.to_array().into_iter().enumerate() {
            match frame.vertex(x, a) {
                Some(q) => {
                    w[3 * i + a] = q as u32;
                    c[i][a] = q as i64;
                }
                None => {
                    w[3 * i + a] = POISON;
                    overflow = true;
                }
            }
        }
    }
    w[9] = prim;
    if overflow {
        return (w, RecordStatus::Overflow);
    }
    let e1 = [c[1][0] - c[0][0], c[1][1] - c[0][1], c[1][2] - c[0][2]].map(i128::from);
    let e2 = [c[2][0] - c[0][0], c[2][1] - c[0][1], c[2][2] - c[0][2]].map(i128::from);
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    if n == [0, 0, 0] {
        w[..9].fill(0);
        return (w, RecordStatus::Degenerate);
    }
    (w, RecordStatus::Ok)
}

/// Per-ray constants shared by every PE (the ray-setup block).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RaySetup {
    /// Dominant axis of the direction: the permutation moves it to z.
    pub kz: usize,
    /// Origin in frame units, world axis order.
    pub o: [i64; 3],
    /// Permuted direction `Q(d, 23 − E)`; `|d[2]| ∈ [2^23, 2^24)`.
    pub d: [i64; 3],
    /// Shear `trunc(−dx·2^23 / dz)`.
    pub sx: i64,
    /// Shear `trunc(−dy·2^23 / dz)`.
    pub sy: i64,
    /// `t_world = t_frame · 2^texp`.
    pub texp: i32,
}

/// Cyclic permutation moving axis `kz` to z (pbrt-v4's kx = kz + 1, ky = kx + 1).
pub fn permute<T: Copy>(kz: usize, v: [T; 3]) -> [T; 3] {
    match kz {
        0 => [v[1], v[2], v[0]],
        1 => [v[2], v[0], v[1]],
        _ => v,
    }
}

/// Ray setup; `None` when the origin lies outside ±1024 frame units (every test of the ray
/// then reports an overflow). `ray` must be valid (finite, nonzero direction).
pub fn setup(frame: &Frame, ray: &Ray) -> Option<RaySetup> {
    let kz = max_dimension(ray.dir);
    let dir = ray.dir.to_array();
    let e = exponent_of(dir[kz]);
    let d = permute(kz, dir.map(|c| to_fixed(c, FRAC - e).unwrap_or(0)));
    let mut o = [0i64; 3];
    for (a, c) in ray.origin.to_array().into_iter().enumerate() {
        let x = to_fixed(c, frame.s.saturating_add(FRAC))? - frame.qm[a]?;
        if x.abs() >= 1 << ORIGIN_BITS {
            return None;
        }
        o[a] = x;
    }
    if d[2] == 0 {
        return None;
    }
    Some(RaySetup { kz, o, d, sx: (-d[0] << FRAC) / d[2], sy: (-d[1] << FRAC) / d[2], texp: -frame.s - e })
}

/// Result of one test.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Test {
    /// No hit.
    Miss,
    /// A hit at world distance `t` (f32 bits, positive, finite).
    Hit(u32),
    /// A value left its range: reported, counted as a miss.
    Overflow,
}

fn bitlen(x: u128) -> u32 {
    128 - x.leading_zeros()
}

/// One ray–triangle test on a record (the PE pipeline).
pub fn intersect(r: &RaySetup, rec: &[u32; RECORD_WORDS]) -> Test {
    if rec[..9].contains(&POISON) {
        return Test::Overflow;
    }
    let v = |i: usize| permute(r.kz, [0, 1, 2].map(|a| rec[3 * i + a] as i32 as i64 - r.o[a]));
    let (a, b, c) = (v(0), v(1), v(2));
    let shear = |p: [i64; 3]| (p[0] + ((r.sx * p[2] + (1 << 22)) >> FRAC), p[1] + ((r.sy * p[2] + (1 << 22)) >> FRAC));
    let ((ax, ay), (bx, by), (cx, cy)) = (shear(a), shear(b), shear(c));
    if [ax, ay, bx, by, cx, cy].iter().any(|x| x.abs() >= 1 << LATERAL_BITS) {
        return Test::Overflow;
    }
    let e = [bx * cy - by * cx, cx * ay - cy * ax, ax * by - ay * bx];
    if e.iter().any(|&x| x < 0) && e.iter().any(|&x| x > 0) {
        return Test::Miss;
    }
    let det: i64 = e.iter().sum();
    if det == 0 {
        return Test::Miss;
    }
    let (e, det) = if det < 0 { (e.map(|x| -x), -det) } else { (e, det) };
    let shift = bitlen(det as u128).saturating_sub(WEIGHT_BITS);
    let w = e.map(|x| x >> shift);
    let det_w: i64 = w.iter().sum();
    let n = w[0] as i128 * a[2] as i128 + w[1] as i128 * b[2] as i128 + w[2] as i128 * c[2] as i128;
    let n = if r.d[2] < 0 { -n } else { n };
    if n <= 0 {
        return Test::Miss;
    }
    let den = det_w as u128 * r.d[2].unsigned_abs() as u128;
    let t = ratio_to_f32(n as u128, den, r.texp);
    if t == 0 || t == 0x7F80_0000 {
        return Test::Miss;
    }
    Test::Hit(t)
}

/// Correctly rounded (to nearest, ties to even) f32 bits of `num/den · 2^e` for positive
/// `num < 2^70`, `den < 2^58`: the PE's divider and rounder.
pub fn ratio_to_f32(num: u128, den: u128, e: i32) -> u32 {
    let (ln, ld) = (bitlen(num) as i32, bitlen(den) as i32);
    let nn = num << (70 - ln);
    let dn = den << (58 - ld);
    let z = nn << 14;
    let q = z / dn;
    let sticky = !z.is_multiple_of(dn);
    round_to_f32(q as u64, ln - ld - 26 + e, sticky)
}

/// RNE f32 bits of `(sig + δ)·2^exp`, `0 < δ < 1` when `sticky` (else δ = 0); `sig ≥ 2^24`.
pub fn round_to_f32(sig: u64, exp: i32, sticky: bool) -> u32 {
    let p = 64 - sig.leading_zeros() as i32;
    let e = p - 1 + exp;
    if e > 127 {
        return 0x7F80_0000;
    }
    // Bits to drop: down to 24 significant bits, or to the subnormal grid 2^-149.
    let drop = if e >= -126 { p - 24 } else { -149 - exp };
    let (mant, half, rest) = if drop >= 64 {
        (0u64, false, true)
    } else {
        let mant = sig >> drop;
        let half = drop > 0 && (sig >> (drop - 1)) & 1 == 1;
        let rest = drop > 1 && sig & ((1u64 << (drop - 1)) - 1) != 0;
        (mant, half, rest)
    };
    let mant = mant + (half && (rest || sticky || mant & 1 == 1)) as u64;
    if e >= -126 {
        // Normal: mant in [2^23, 2^24]; a carry to 2^24 bumps the exponent.
        let (mant, e) = if mant >> 24 == 1 { (mant >> 1, e + 1) } else { (mant, e) };
        if e > 127 {
            return 0x7F80_0000;
        }
        (((e + 127) as u32) << 23) | (mant as u32 & 0x7F_FFFF)
    } else {
        // Subnormal, or rounded up to the smallest normal (the same count of 2^-149).
        mant as u32
    }
}

/// The kernel (module doc).
#[derive(Debug, Clone, Copy)]
pub struct WatertightQ23;

impl Kernel for WatertightQ23 {
    const KIND: KernelKind = KernelKind::Watertight;
    const FORMAT: NumberFormat = NumberFormat::Fixed64Q23;
    const RECORD_WORDS: usize = RECORD_WORDS;
    const USES_IMAGE: bool = false;
    const PRIM_IN_RECORD: bool = true;
    const TESTS_PRIMITIVES: bool = false;
    const OPS: OpCount = OpCount { add: 24, mul: 16, div: 1, cmp: 10 };
    type RayData = RaySetup;

    #[inline]
    fn prepare(ray: &Ray, frame: &FixedFrame) -> Result<RaySetup, Overflow> {
        setup(&Frame::of(frame), ray).ok_or(Overflow)
    }

    fn precompute(tri: &Triangle, frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        let (words, status) = record(&Frame::of(frame), tri, 0);
        for (o, w) in out.iter_mut().zip(words) {
            *o = w;
        }
        status
    }

    #[inline]
    fn intersect(r: &RaySetup, rec: &[u32], _t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(rec) = rec.get(..RECORD_WORDS).and_then(|w| <&[u32; RECORD_WORDS]>::try_from(w).ok()) else {
            return Ok(None);
        };
        match intersect(r, rec) {
            Test::Hit(t) => Ok(Some(f32::from_bits(t))),
            Test::Miss => Ok(None),
            Test::Overflow => Err(Overflow),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact;
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn frame() -> Frame {
        Frame::of(&FixedFrame::for_box([-4.0; 3], [4.0; 3], NumberFormat::Fixed64Q23).unwrap())
    }

    fn test(f: &Frame, ray: &Ray, tri: &Triangle) -> Test {
        let (rec, _) = record(f, tri, 0);
        setup(f, ray).map_or(Test::Overflow, |r| intersect(&r, &rec))
    }

    #[test]
    fn to_fixed_rounds_half_away_from_zero_and_flags_huge_values() {
        assert_eq!(to_fixed(1.5, 0), Some(2));
        assert_eq!(to_fixed(-1.5, 0), Some(-2));
        assert_eq!(to_fixed(2.5, 0), Some(3));
        assert_eq!(to_fixed(0.499_999_97, 0), Some(0));
        assert_eq!(to_fixed(1.0, 23), Some(1 << 23));
        assert_eq!(to_fixed(f32::from_bits(1), 149), Some(1));
        assert_eq!(to_fixed(f32::from_bits(1), 148), Some(1)); // 0.5 → away from zero
        assert_eq!(to_fixed(f32::from_bits(1), 147), Some(0));
        assert_eq!(to_fixed(1.0, 53), Some(1 << 53));
        assert_eq!(to_fixed(1.0, 54), None);
        assert_eq!(to_fixed(-0.0, 200), Some(0));
    }

    #[test]
    fn round_to_f32_matches_the_float_conversion() {
        // Exact f64 inputs, one rounding to f32.
        for &(sig, exp) in
            &[(0x2FF_FFFFu64, 0), (0x300_0001, -3), (0x200_0000, -175), (0x3FF_FFFF, 101), (0x2AB_CDEF, -160)]
        {
            let want = ((sig as f64) * libm::ldexp(1.0, exp)) as f32;
            assert_eq!(round_to_f32(sig, exp, false), want.to_bits(), "{sig:x} {exp}");
        }
        assert_eq!(round_to_f32(0x3FF_FFFF, 103, false), 0x7F80_0000);
    }

    #[test]
    fn ratio_is_correctly_rounded() {
        assert_eq!(ratio_to_f32(1, 1, 0), 1.0f32.to_bits());
        assert_eq!(ratio_to_f32(1, 3, 0), (1.0f32 / 3.0).to_bits());
        assert_eq!(ratio_to_f32(10, 4, -1), 1.25f32.to_bits());
        assert_eq!(ratio_to_f32(2, 3, -149), 1); // 2/3 of the smallest subnormal → it
        assert_eq!(ratio_to_f32(1, 3, -149), 0); // 1/3 of it → 0
    }

    /// Woop et al.'s property in this arithmetic: rays through the shared diagonal of a quad
    /// never slip between its two triangles.
    #[test]
    fn rays_through_a_shared_edge_never_slip_through() {
        let f = frame();
        let mut rng = ChaCha8Rng::seed_from_u64(0x3A7E);
        let (a, b, c, d) = (
            Vec3::new(-1.3, -0.7, 0.4),
            Vec3::new(1.1, -0.9, -0.2),
            Vec3::new(0.9, 1.2, 0.3),
            Vec3::new(-1.2, 1.0, -0.1),
        );
        for _ in 0..20_000 {
            let s: f32 = rng.gen_range(0.0..1.0);
            let target = a + (c - a) * s;
            let origin = Vec3::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0), rng.gen_range(2.0..5.0));
            let ray = Ray { origin, dir: target - origin };
            let hit = |t: Triangle| matches!(test(&f, &ray, &t), Test::Hit(_));
            assert!(hit([a, b, c]) || hit([a, c, d]), "slipped through at s = {s}");
        }
    }

    /// Interior hits agree with the f64 plane intersection to the frame's resolution.
    #[test]
    fn interior_hits_match_the_f64_reference() {
        let f = frame();
        let mut rng = ChaCha8Rng::seed_from_u64(0x15EC7);
        let mut checked = 0;
        for _ in 0..5000 {
            let mut p = || Vec3::new(rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0));
            let tri = [p(), p(), p()];
            let o = p();
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            let (b1, b2) = (rng.gen_range(0.1f32..0.45), rng.gen_range(0.1f32..0.45));
            let dir = tri[0] + (tri[1] - tri[0]) * b1 + (tri[2] - tri[0]) * b2 - o;
            if n.length() < 0.5 || n.normalize().dot(dir.normalize()).abs() < 0.05 {
                continue;
            }
            let ray = Ray { origin: o, dir };
            let t_ref = exact::t_f64(&ray, &tri);
            let Test::Hit(t) = test(&f, &ray, &tri) else { panic!("missed an interior hit") };
            let t = f32::from_bits(t) as f64;
            assert!(((t - t_ref) / t_ref).abs() < 2e-5, "t {t} vs {t_ref}");
            checked += 1;
        }
        assert!(checked > 2500, "{checked}");
    }
}
