//! The arithmetic of the RTL's intersection datapath, bit for bit (rtl/README.md §3).
//!
//! This is the executable specification the HDL implements: every function here has one
//! hardware block, and the co-simulation tests compare the two word for word. It is the
//! watertight test of Woop, Benthin and Wald (JCGT 2013) in Q23 fixed point, arranged so that
//! a pipeline can issue one test per cycle with narrow multipliers:
//!
//! - f32 → fixed conversion is exact (`to_fixed`: round half away from zero of `x·2^k`);
//!   frame coordinates are `Q(v) − Q(box_min)`.
//! - The shear is rounded once per vertex (half up), so a shared edge gets the same sheared
//!   end points in both triangles: watertight by construction.
//! - Edge functions, determinant and the hit depth are exact integer products; only the
//!   barycentric weights are truncated to 34 bits (one common shift per test).
//! - `t` is the correctly rounded (RNE) f32 of an exact rational: one division per test.
//! - No early-out bound: the caller's acceptance rule decides (SPEC.md §4.3).

use gridrt_coproc::isect::Triangle;
use gridrt_coproc::FixedFrame;
use gridrt_shared::math::{max_dimension, Ray};

/// Fractional bits of every fixed-point coordinate.
pub const FRAC: i32 = 23;
/// `to_fixed` fails for `|x·2^k| ≥ 2^HUGE_BITS`.
pub const HUGE_BITS: u32 = 54;
/// Largest stored vertex coordinate magnitude (raw): the i32 range without `i32::MIN`.
pub const VERTEX_MAX: i64 = i32::MAX as i64;
/// Ray origins need `|O| < 2^ORIGIN_BITS` (raw), i.e. within ±1024 frame units.
pub const ORIGIN_BITS: u32 = 33;
/// Sheared (lateral) vertex coordinates need `|x| < 2^LATERAL_BITS` (raw, ±64 frame units).
pub const LATERAL_BITS: u32 = 29;
/// Barycentric weights are cut to this many bits before the depth products.
pub const WEIGHT_BITS: u32 = 34;
/// Words of a record: 9 coordinates and a copy of the prim id (one memory read per test).
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
    let sh = e2 + k;
    let mag: u64 = if sh >= 0 {
        let len = 64 - mant.leading_zeros() as i32;
        if len + sh > HUGE_BITS as i32 {
            return None;
        }
        mant << sh
    } else if sh < -40 {
        0
    } else {
        let d = (-sh) as u32;
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

/// The frame as the hardware holds it: the scale exponent `s` (scale `2^s`) and the
/// converted box minimum `Q(min, s + 23)` per axis (`None`: too large, every conversion
/// against it fails).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Scale exponent.
    pub s: i32,
    /// `Q(min_a, s + 23)`.
    pub qm: [Option<i64>; 3],
}

impl Frame {
    /// The hardware frame of a model frame (`scale` is a power of two).
    pub fn of(f: &FixedFrame) -> Self {
        let (_, e) = libm::frexp(f.scale);
        let s = e - 1;
        Self { s, qm: f.origin.map(|m| to_fixed(m, s + FRAC)) }
    }

    /// The frame of a box as the FRAME packet computes it: extent = the largest
    /// `fl32(max − min)`, `s = 4 − ⌈log2 extent⌉` (16 frame units, Q23's box), `s = 0`
    /// for a zero extent. `None` for a non-finite or inverted box.
    pub fn for_box(min: [f32; 3], max: [f32; 3]) -> Option<FixedFrame> {
        if min.iter().chain(max.iter()).any(|c| !c.is_finite()) || (0..3).any(|a| max[a] < min[a]) {
            return None;
        }
        let extent = (0..3).map(|a| max[a] - min[a]).fold(0.0f32, f32::max);
        let s = if extent == 0.0 {
            0
        } else if extent.is_infinite() {
            4 - 128
        } else {
            let pow2 = extent.to_bits() & 0x7F_FFFF == 0
                || (extent.to_bits() >> 23 == 0 && extent.to_bits().is_power_of_two());
            let e = exponent_of(extent);
            4 - if pow2 { e } else { e + 1 }
        };
        Some(FixedFrame { origin: min, scale: libm::ldexp(1.0, s) })
    }

    /// Frame coordinate of a vertex component on `axis`: `Q(v) − Q(min)`, `None` when it
    /// does not fit the i32 storage (or either conversion is too large).
    pub fn vertex(&self, v: f32, axis: usize) -> Option<i32> {
        let x = to_fixed(v, self.s + FRAC)? - self.qm[axis]?;
        (x.abs() <= VERTEX_MAX).then_some(x as i32)
    }
}

/// The 10-word record of a triangle (load time): 9 frame coordinates (`POISON` where one
/// does not fit; all zero for a triangle whose quantised vertices are collinear) and the
/// prim id. Returns the record and whether it overflowed / is degenerate.
pub fn record(frame: &Frame, tri: &Triangle, prim: u32) -> ([u32; RECORD_WORDS], RecordKind) {
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
        return (w, RecordKind::Overflow);
    }
    let e1 = [c[1][0] - c[0][0], c[1][1] - c[0][1], c[1][2] - c[0][2]].map(i128::from);
    let e2 = [c[2][0] - c[0][0], c[2][1] - c[0][1], c[2][2] - c[0][2]].map(i128::from);
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    if n == [0, 0, 0] {
        w[..9].fill(0);
        return (w, RecordKind::Degenerate);
    }
    (w, RecordKind::Ok)
}

/// What [`record`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordKind {
    /// Usable.
    Ok,
    /// Collinear quantised vertices: stored as a point, never hits.
    Degenerate,
    /// A coordinate does not fit: every test reports an overflow.
    Overflow,
}

/// Per-ray constants shared by every PE (the ray-setup block).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RaySetup {
    /// Dominant axis of the direction (`max_dimension`): 0, 1 or 2 → permutation.
    pub kz: usize,
    /// Origin in frame units (world axis order; the PE permutes `v − o`).
    pub o: [i64; 3],
    /// Permuted direction `Q(d, 23 − E)`; `|dz| ∈ [2^23, 2^24)`.
    pub d: [i64; 3],
    /// Shear `trunc(−d·2^23 / dz)` for x and y.
    pub sx: i64,
    /// See `sx`.
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
    let d = dir.map(|c| to_fixed(c, FRAC - e).unwrap_or(0));
    let mut o = [0i64; 3];
    for (a, c) in ray.origin.to_array().into_iter().enumerate() {
        let x = to_fixed(c, frame.s + FRAC)? - frame.qm[a]?;
        if x.abs() >= 1 << ORIGIN_BITS {
            return None;
        }
        o[a] = x;
    }
    let d = permute(kz, d);
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
    let shear = |p: [i64; 3]| {
        let x = p[0] + ((r.sx * p[2] + (1 << 22)) >> FRAC);
        let y = p[1] + ((r.sy * p[2] + (1 << 22)) >> FRAC);
        (x, y)
    };
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
    let r_shift = bitlen(det as u128).saturating_sub(WEIGHT_BITS);
    let w = e.map(|x| x >> r_shift);
    let det_w: i64 = w.iter().sum();
    let n: i128 = w[0] as i128 * a[2] as i128 + w[1] as i128 * b[2] as i128 + w[2] as i128 * c[2] as i128;
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
    let sticky = z % dn != 0;
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
    let up = half && (rest || sticky || mant & 1 == 1);
    let mant = mant + up as u64;
    if e >= -126 {
        // Normal: mant in [2^23, 2^24]; a carry to 2^24 bumps the exponent.
        let (mant, e) = if mant >> 24 == 1 { (mant >> 1, e + 1) } else { (mant, e) };
        if e > 127 {
            return 0x7F80_0000;
        }
        (((e + 127) as u32) << 23) | (mant as u32 & 0x7F_FFFF)
    } else {
        // Subnormal (or rounded up to the smallest normal: the encoding is the same count).
        mant as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::math::Vec3;

    #[test]
    fn to_fixed_rounds_half_away_and_flags_huge() {
        assert_eq!(to_fixed(1.5, 0), Some(2));
        assert_eq!(to_fixed(-1.5, 0), Some(-2));
        assert_eq!(to_fixed(2.5, 0), Some(3));
        assert_eq!(to_fixed(0.49999997, 0), Some(0));
        assert_eq!(to_fixed(1.0, 23), Some(1 << 23));
        assert_eq!(to_fixed(f32::from_bits(1), 149), Some(1));
        assert_eq!(to_fixed(f32::from_bits(1), 148), Some(1)); // 0.5 → away
        assert_eq!(to_fixed(f32::from_bits(1), 147), Some(0));
        assert_eq!(to_fixed(1.0, 53), Some(1 << 53));
        assert_eq!(to_fixed(1.0, 54), None);
        assert_eq!(to_fixed(-0.0, 200), Some(0));
    }

    #[test]
    fn round_to_f32_matches_float_conversion() {
        // Integers with sticky bits, checked against f64 → f32 (exact f64 input, one rounding).
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
        assert_eq!(ratio_to_f32(2, 3, -149), 1); // 2/3 ulp → 1 ulp
        assert_eq!(ratio_to_f32(1, 3, -149), 0); // 1/3 ulp → 0
    }

    #[test]
    fn unit_triangle_is_hit_at_t_one() {
        let f = Frame::of(&Frame::for_box([-4.0; 3], [4.0; 3]).unwrap());
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let (rec, kind) = record(&f, &tri, 7);
        assert_eq!(kind, RecordKind::Ok);
        let ray = Ray { origin: Vec3::new(0.25, 0.25, -1.0), dir: Vec3::new(0.0, 0.0, 1.0) };
        let r = setup(&f, &ray).unwrap();
        assert_eq!(intersect(&r, &rec), Test::Hit(1.0f32.to_bits()));
        let back = Ray { origin: Vec3::new(0.25, 0.25, 1.0), dir: Vec3::new(0.0, 0.0, 0.5) };
        assert_eq!(intersect(&setup(&f, &back).unwrap(), &rec), Test::Miss);
    }
}

#[cfg(test)]
mod properties {
    use super::*;
    use gridrt_coproc::{Intersector, KernelKind, NumberFormat};
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn frame() -> Frame {
        Frame::of(&Frame::for_box([-4.0; 3], [4.0; 3]).unwrap())
    }

    fn test(f: &Frame, ray: &Ray, tri: &Triangle) -> Test {
        let (rec, _) = record(f, tri, 0);
        setup(f, ray).map_or(Test::Overflow, |r| intersect(&r, &rec))
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

    /// Interior hits agree with the f64 plane intersection to f32 precision, and with the
    /// model's fixed64-q23 watertight kernel to its 2^-23 frame resolution.
    #[test]
    fn interior_hits_match_the_f64_reference() {
        let f = frame();
        let model = Intersector::new(
            KernelKind::Watertight,
            NumberFormat::Fixed64Q23,
            gridrt_coproc::FixedFrame::for_box([-4.0; 3], [4.0; 3], NumberFormat::Fixed64Q23).unwrap(),
        );
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
            let t_ref = gridrt_coproc::exact::t_f64(&ray, &tri);
            let Test::Hit(t) = test(&f, &ray, &tri) else { panic!("missed an interior hit") };
            let t = f32::from_bits(t) as f64;
            assert!(((t - t_ref) / t_ref).abs() < 2e-5, "t {t} vs {t_ref}");
            let tm = model.intersect_tri(&ray, &tri, f32::INFINITY).unwrap().unwrap() as f64;
            assert!(((t - tm) / t_ref).abs() < 1e-5, "t {t} vs model {tm}");
            checked += 1;
        }
        assert!(checked > 2500, "{checked}");
    }
}
