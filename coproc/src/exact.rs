//! The exact reference: f64 ray–triangle intersection with exact orientation predicates.
//!
//! Sources: J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast Robust
//! Geometric Predicates", Discrete & Computational Geometry 18, 1997 (error-free
//! transformations, nonoverlapping expansions, `GROW-EXPANSION`, `SCALE-EXPANSION`, the
//! orient3d error bound); T. J. Dekker, "A floating-point technique for extending the
//! available precision", Numer. Math. 18, 1971 (`split`, `two_product` without FMA).
//!
//! Inputs are f32, so every coordinate is exact in f64, and the predicates below are exact
//! for *all* f32 inputs: their values are degree-3 polynomials of f32 differences, whose
//! expansion components stay far from f64 overflow (< 2^400) and underflow.
//!
//! Hit/miss is decided on the *exact* ray `o + t·d` (the f32 values, not a rounded version)
//! and the closed triangle:
//!
//! - `s_i = sign( d · ((v_j − o) × (v_k − o)) )` for the edges (j, k) = (1, 2), (2, 0), (0, 1)
//!   — the signs of Plücker/Woop et al.'s edge functions, computed exactly;
//! - the line meets the closed triangle iff the `s_i` are not of mixed sign and not all 0
//!   (all 0: the ray lies in the triangle's plane — a miss, as in every kernel);
//! - then `d·N = s_0 + s_1 + s_2` has the common sign σ, and the hit is in front (t > 0) iff
//!   `sign((v_0 − o)·N) = orient3d(v_0, v_1, v_2, o) = σ`.
//!
//! A ray through an edge or a vertex (some `s_i = 0`) hits *every* triangle sharing it:
//! this is what the watertightness tests count against. The distance `t` itself is computed
//! in f64 (`((v_0 − o)·N) / (d·N)`, with the f32 differences exact in f64), accurate to a few
//! f64 ulps unless the ray grazes the plane.
//!
//! Every predicate first evaluates in f64 with Shewchuk's orient3d error bound
//! `(7 + 56ε)ε · permanent` and falls back to exact expansion arithmetic only when the sign
//! is uncertain, so the common case costs about as much as an f64 test.

use crate::isect::kernel::Triangle;
use gridrt_shared::math::Ray;

/// f64 machine epsilon as Shewchuk defines it (2^-53).
const EPS: f64 = f64::EPSILON * 0.5;
/// Shewchuk's orient3d static error bound factor `(7 + 56ε)ε`.
const O3D_ERRBOUND: f64 = (7.0 + 56.0 * EPS) * EPS;
/// Dekker's splitter `2^27 + 1`.
const SPLITTER: f64 = 134_217_729.0;

// ------------------------------------------------------------ error-free transforms

/// `a + b = s + e` exactly (Knuth's TwoSum).
#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// `a − b = s + e` exactly.
#[inline(always)]
fn two_diff(a: f64, b: f64) -> (f64, f64) {
    let s = a - b;
    let bv = a - s;
    let av = s + bv;
    (s, (a - av) + (bv - b))
}

/// Dekker's split of `a` into two 26-bit halves `hi + lo = a`.
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = SPLITTER * a;
    let big = c - a;
    let hi = c - big;
    (hi, a - hi)
}

/// `a · b = p + e` exactly (Dekker's TwoProduct, no FMA needed).
#[inline(always)]
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let err = p - ah * bh - al * bh - ah * bl;
    (p, al * bl - err)
}

// ------------------------------------------------------------ expansions

/// Capacity of an expansion: a 3×3 determinant of exact differences needs at most 192
/// components (2·2·2 per product term, ×2 per 2×2 minor, ×3 terms).
const CAP: usize = 256;

/// A nonoverlapping expansion (Shewchuk §2): components in increasing magnitude, no zeros;
/// the value is their exact sum.
#[derive(Clone, Copy)]
struct Expansion {
    c: [f64; CAP],
    n: usize,
}

impl Expansion {
    const ZERO: Expansion = Expansion { c: [0.0; CAP], n: 0 };

    /// The exact difference `a − b`.
    fn diff(a: f64, b: f64) -> Self {
        let (s, e) = two_diff(a, b);
        let mut x = Self::ZERO;
        x.push(e);
        x.push(s);
        x
    }

    #[inline(always)]
    fn push(&mut self, v: f64) {
        // Zero elimination; CAP bounds every expansion built in this module, so the guard
        // never drops a component (it only keeps the code panic-free).
        if v != 0.0 && self.n < CAP {
            self.c[self.n] = v;
            self.n += 1;
        }
    }

    /// Shewchuk's GROW-EXPANSION with zero elimination, in place: `self += b`. The output
    /// index never passes the input index, so one buffer suffices.
    fn grow(&mut self, b: f64) {
        let mut q = b;
        let mut k = 0;
        for i in 0..self.n {
            let (s, h) = two_sum(q, self.c[i]);
            if h != 0.0 {
                self.c[k] = h;
                k += 1;
            }
            q = s;
        }
        self.n = k;
        self.push(q);
    }

    /// EXPANSION-SUM: `self + other` (one GROW per component of `other`).
    fn add(&self, other: &Self) -> Self {
        let mut acc = *self;
        for &b in &other.c[..other.n] {
            acc.grow(b);
        }
        acc
    }

    fn neg(&self) -> Self {
        let mut out = *self;
        for v in &mut out.c[..out.n] {
            *v = -*v;
        }
        out
    }

    /// Shewchuk's SCALE-EXPANSION with zero elimination: `self · b`.
    fn scale(&self, b: f64) -> Self {
        let mut out = Self::ZERO;
        if self.n == 0 || b == 0.0 {
            return out;
        }
        let (mut q, h) = two_product(self.c[0], b);
        out.push(h);
        for &e in &self.c[1..self.n] {
            let (p1, p0) = two_product(e, b);
            let (s, h) = two_sum(q, p0);
            out.push(h);
            let (s2, h2) = two_sum(p1, s);
            out.push(h2);
            q = s2;
        }
        out.push(q);
        out
    }

    /// `self · other` (sum of scalings).
    fn mul(&self, other: &Self) -> Self {
        let mut acc = Self::ZERO;
        for &b in &other.c[..other.n] {
            let part = self.scale(b);
            for &p in &part.c[..part.n] {
                acc.grow(p);
            }
        }
        acc
    }

    /// Sign of the exact value: that of the largest component.
    fn sign(&self) -> i8 {
        match self.n {
            0 => 0,
            n if self.c[n - 1] > 0.0 => 1,
            _ => -1,
        }
    }
}

/// Sign of the 3×3 determinant whose entry (i, j) is the exact difference
/// `m[i][j].0 − m[i][j].1` of two f64 values: an f64 evaluation with Shewchuk's orient3d
/// error bound, then exact expansion arithmetic when the bound does not settle the sign.
fn det3_sign(m: [[(f64, f64); 3]; 3]) -> i8 {
    let r = m.map(|row| row.map(|(a, b)| a - b));
    let m12 = r[1][1] * r[2][2] - r[1][2] * r[2][1];
    let m02 = r[1][0] * r[2][2] - r[1][2] * r[2][0];
    let m01 = r[1][0] * r[2][1] - r[1][1] * r[2][0];
    let det = r[0][0] * m12 - r[0][1] * m02 + r[0][2] * m01;
    let a = r.map(|row| row.map(f64::abs));
    let permanent = a[0][0] * (a[1][1] * a[2][2] + a[1][2] * a[2][1])
        + a[0][1] * (a[1][0] * a[2][2] + a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] + a[1][1] * a[2][0]);
    let bound = O3D_ERRBOUND * permanent;
    if det > bound {
        return 1;
    }
    if -det > bound {
        return -1;
    }
    if permanent == 0.0 {
        return 0;
    }
    det3_sign_exact(m)
}

/// The exact fallback of [`det3_sign`].
fn det3_sign_exact(m: [[(f64, f64); 3]; 3]) -> i8 {
    let e = m.map(|row| row.map(|(a, b)| Expansion::diff(a, b)));
    let minor = |i: usize, j: usize, k: usize, l: usize| e[i][j].mul(&e[k][l]).add(&e[i][l].mul(&e[k][j]).neg());
    let m12 = minor(1, 1, 2, 2);
    let m02 = minor(1, 0, 2, 2);
    let m01 = minor(1, 0, 2, 1);
    let det = e[0][0].mul(&m12).add(&e[0][1].mul(&m02).neg()).add(&e[0][2].mul(&m01));
    det.sign()
}

#[inline(always)]
fn f64s(v: gridrt_shared::math::Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// Exact sign of `orient3d(a, b, c, d) = (a − d) · ((b − d) × (c − d))`: positive when `d`
/// lies below the plane through `a, b, c` seen counter-clockwise (Shewchuk's convention).
pub fn orient3d(a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3]) -> i8 {
    let p = |x: [f32; 3]| core::array::from_fn(|i| (x[i] as f64, d[i] as f64));
    det3_sign([p(a), p(b), p(c)])
}

/// Exact sign of the edge function of edge `(a, b)` for the ray: `d · ((a − o) × (b − o))`.
pub fn edge_sign(ray: &Ray, a: [f32; 3], b: [f32; 3]) -> i8 {
    let o = ray.origin.to_array();
    let d = ray.dir.to_array();
    let rel = |x: [f32; 3]| core::array::from_fn(|i| (x[i] as f64, o[i] as f64));
    let dir = core::array::from_fn(|i| (d[i] as f64, 0.0));
    det3_sign([rel(a), rel(b), dir])
}

/// Exact classification of a ray against a closed triangle (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Classification {
    /// The ray's line misses the closed triangle, or lies in its plane (degenerate
    /// triangles included).
    Miss,
    /// The line crosses the triangle at or behind the origin (`t ≤ 0`).
    Behind,
    /// A hit in front of the origin.
    Hit {
        /// Distance in f64 (module doc).
        t: f64,
        /// The ray passes exactly through an edge or a vertex.
        on_edge: bool,
    },
}

/// Classifies `ray` against `tri` exactly (module doc). Non-finite inputs are a miss.
pub fn classify(ray: &Ray, tri: &Triangle) -> Classification {
    if !ray.is_valid() || tri.iter().any(|v| !v.is_finite()) {
        return Classification::Miss;
    }
    let v = tri.map(|p| p.to_array());
    let s = [edge_sign(ray, v[1], v[2]), edge_sign(ray, v[2], v[0]), edge_sign(ray, v[0], v[1])];
    let (pos, neg) = (s.iter().any(|&x| x > 0), s.iter().any(|&x| x < 0));
    if pos == neg {
        // Mixed signs (outside), or all zero (ray in the plane).
        return Classification::Miss;
    }
    let sigma = if pos { 1 } else { -1 };
    // (v0 − o)·N = det[v0 − o; v1 − o; v2 − o] = orient3d(v0, v1, v2, o).
    if orient3d(v[0], v[1], v[2], ray.origin.to_array()) != sigma {
        return Classification::Behind;
    }
    Classification::Hit { t: t_f64(ray, tri), on_edge: s.contains(&0) }
}

/// `t` of the ray's intersection with the triangle's plane in f64 (NaN when parallel).
pub fn t_f64(ray: &Ray, tri: &Triangle) -> f64 {
    let (o, d) = (f64s(ray.origin), f64s(ray.dir));
    let v = tri.map(f64s);
    let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
    let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let w = [v[0][0] - o[0], v[0][1] - o[1], v[0][2] - o[2]];
    (w[0] * n[0] + w[1] * n[1] + w[2] * n[2]) / (d[0] * n[0] + d[1] * n[1] + d[2] * n[2])
}

/// `t` of an exact hit in front of the origin, else `None`.
pub fn intersect(ray: &Ray, tri: &Triangle) -> Option<f64> {
    match classify(ray, tri) {
        Classification::Hit { t, .. } => Some(t),
        _ => None,
    }
}

/// The nearest exact hit with `t < t_max` over `(id, triangle)` pairs (ties → lowest id).
pub fn closest_hit<I: IntoIterator<Item = (u32, Triangle)>>(ray: &Ray, tris: I, t_max: f64) -> Option<(f64, u32)> {
    let mut best: Option<(f64, u32)> = None;
    for (id, tri) in tris {
        if let Some(t) = intersect(ray, &tri) {
            if t < t_max && best.is_none_or(|(bt, bid)| t < bt || (t == bt && id < bid)) {
                best = Some((t, id));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn error_free_transforms_are_exact() {
        let (s, e) = two_sum(1.0, 1e-20);
        assert_eq!((s, e), (1.0, 1e-20));
        let a = 1.0 + f64::EPSILON;
        let (p, e) = two_product(a, a);
        // (1 + ε)² = 1 + 2ε + ε²: the error term is ε².
        assert_eq!(p, 1.0 + 2.0 * f64::EPSILON);
        assert_eq!(e, f64::EPSILON * f64::EPSILON);
    }

    #[test]
    fn orient3d_decides_coplanar_points_that_f64_gets_wrong() {
        // Points on the plane x + y + z = 1 with f32 coordinates: exactly coplanar (0) only if
        // the sum is exactly 1 in real arithmetic; nudging d by one f32 ulp flips the sign.
        let a = [1.0, 0.0, 0.0];
        let b = [0.0, 1.0, 0.0];
        let c = [0.0, 0.0, 1.0];
        let d = [0.25f32, 0.25, 0.5];
        assert_eq!(orient3d(a, b, c, d), 0);
        let up = [0.25f32, 0.25, 0.5 + f32::EPSILON * 0.5];
        let down = [0.25f32, 0.25, 0.5 - f32::EPSILON * 0.25];
        assert_eq!(orient3d(a, b, c, up), -orient3d(a, b, c, down));
        assert_ne!(orient3d(a, b, c, up), 0);
        // Translated by 2^20 (still exact in f32): f64 cancels, the expansions still decide.
        let off = 1_048_576.0f32;
        let t = |p: [f32; 3]| [p[0] + off, p[1] + off, p[2]];
        assert_eq!(orient3d(t(a), t(b), t(c), t(d)), 0);
        assert_eq!(orient3d(t(a), t(b), t(c), t(up)), orient3d(a, b, c, up));
    }

    /// The exact sign agrees with a brute-force i128 evaluation on random small-integer
    /// inputs scaled by powers of two (where i128 is exact), including many degenerate ones.
    #[test]
    fn det3_sign_matches_integer_arithmetic() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xE8AC7);
        for _ in 0..20_000 {
            let k: i32 = rng.gen_range(-30..30);
            let scale = 2f64.powi(k);
            let mut ints = [[(0i64, 0i64); 3]; 3];
            for row in &mut ints {
                for e in row.iter_mut() {
                    *e = (rng.gen_range(-8..8), rng.gen_range(-8..8));
                }
            }
            // Make ~half of the cases singular: row 2 = row 0 + row 1 (in differences).
            if rng.gen_bool(0.5) {
                let (r0, r1) = (ints[0], ints[1]);
                for (j, e) in ints[2].iter_mut().enumerate() {
                    *e = ((r0[j].0 - r0[j].1) + (r1[j].0 - r1[j].1), 0);
                }
            }
            let d = ints.map(|row| row.map(|(a, b)| (a - b) as i128));
            let det = d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
                - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0])
                + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
            let m = ints.map(|row| row.map(|(a, b)| (a as f64 * scale, b as f64 * scale)));
            assert_eq!(det3_sign(m) as i128, det.signum());
            assert_eq!(det3_sign_exact(m) as i128, det.signum());
        }
    }

    #[test]
    fn rays_through_a_shared_edge_hit_both_triangles_exactly() {
        let a = Vec3::new(0.0, 0.0, 0.0);
        let b = Vec3::new(1.0, 0.0, 0.0);
        let c = Vec3::new(1.0, 1.0, 0.0);
        let d = Vec3::new(0.0, 1.0, 0.0);
        let t1 = [a, b, c];
        let t2 = [a, c, d];
        // Straight down through the diagonal point (0.5, 0.5): on the shared edge.
        let ray = Ray { origin: Vec3::new(0.5, 0.5, 2.0), dir: Vec3::new(0.0, 0.0, -1.0) };
        assert_eq!(classify(&ray, &t1), Classification::Hit { t: 2.0, on_edge: true });
        assert_eq!(classify(&ray, &t2), Classification::Hit { t: 2.0, on_edge: true });
        // Behind, in-plane and miss.
        let back = Ray { origin: Vec3::new(0.5, 0.25, -2.0), dir: Vec3::new(0.0, 0.0, -1.0) };
        assert_eq!(classify(&back, &t1), Classification::Behind);
        let flat = Ray { origin: Vec3::new(-1.0, 0.5, 0.0), dir: Vec3::new(1.0, 0.0, 0.0) };
        assert_eq!(classify(&flat, &t1), Classification::Miss);
        let off = Ray { origin: Vec3::new(2.0, 0.5, 2.0), dir: Vec3::new(0.0, 0.0, -1.0) };
        assert_eq!(classify(&off, &t1), Classification::Miss);
        // NaN never hits.
        let nan = Ray { origin: Vec3::new(f32::NAN, 0.5, 2.0), dir: Vec3::new(0.0, 0.0, -1.0) };
        assert_eq!(classify(&nan, &t1), Classification::Miss);
        assert_eq!(closest_hit(&ray, [(7, t2), (3, t1)], f64::INFINITY), Some((2.0, 3)));
    }
}
