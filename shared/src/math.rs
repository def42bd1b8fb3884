//! Robust numerics shared by every side (pbrt-v4 style: small named primitives, each citing
//! its source). Everything is `no_std`; FMA comes from `libm`.

pub use glam::Vec3;

/// Machine epsilon of `f32` as pbrt defines it (half an ulp of 1.0).
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// Conservative bound on the relative error of `n` chained floating-point operations:
/// γ(n) = nε / (1 − nε) (Higham, *Accuracy and Stability of Numerical Algorithms*, §3.1;
/// pbrt-v4 `gamma`).
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPSILON) / (1.0 - n as f32 * MACHINE_EPSILON)
}

/// `a*b - c*d` with an error of at most 1.5 ulp, using FMA to recover the rounding error of
/// `c*d` (Kahan's algorithm; pbrt-v4 `DifferenceOfProducts`).
#[inline]
pub fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let dop = libm::fmaf(a, b, -cd);
    let err = libm::fmaf(-c, d, cd);
    dop + err
}

/// Next representable `f32` above `v` (toward +∞); `+∞` and NaN are returned unchanged.
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// Next representable `f32` below `v` (toward −∞).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    -next_float_up(-v)
}

/// Index of the largest-magnitude component (ties → lowest index).
#[inline]
pub fn max_dimension(v: Vec3) -> usize {
    let a = v.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// A ray `origin + t·dir`. The direction need not be normalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub dir: Vec3,
}

impl Ray {
    /// True when origin and direction are finite and the direction is non-zero.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite() && self.dir.is_finite() && self.dir != Vec3::ZERO
    }
    /// Point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// Slab test (Kay–Kajiya; robust form of Williams et al. 2005 with pbrt-v4's
    /// `1 + 2γ(3)` widening of t_far so that rounding never loses a grazing hit).
    ///
    /// Zero direction components give ±∞ reciprocals; an origin exactly on a slab plane gives
    /// 0·∞ = NaN, which the `max`/`min` ordering below discards instead of propagating.
    /// Returns the parameter interval `[t0, t1]` clipped to `[t_min, t_max]`, or `None`.
    pub fn clip(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for axis in 0..3 {
            let inv = 1.0 / ray.dir[axis];
            let mut t_near = (self.min[axis] - ray.origin[axis]) * inv;
            let mut t_far = (self.max[axis] - ray.origin[axis]) * inv;
            if t_near > t_far {
                core::mem::swap(&mut t_near, &mut t_far);
            }
            t_far *= 1.0 + 2.0 * gamma(3);
            // NaN comparisons are false, so a NaN bound leaves t0/t1 untouched.
            if t_near > t0 {
                t0 = t_near;
            }
            if t_far < t1 {
                t1 = t_far;
            }
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// Diagonal vector `max - min`.
    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }
    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_of_products_beats_naive_on_cancellation() {
        // a*b and c*d agree in all but the last bits; the exact result is 2^-46 (checked in f64).
        let (a, b, c, d) = (1.0 + f32::EPSILON, 1.0 - f32::EPSILON, 1.0f32, 1.0f32);
        let exact = (a as f64) * (b as f64) - (c as f64) * (d as f64);
        assert_eq!(difference_of_products(a, b, c, d) as f64, exact);
        assert_ne!((a * b - c * d) as f64, exact);
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert!(next_float_down(1.0) < 1.0);
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn slab_clip_handles_axis_parallel_rays_on_slab_planes() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        // Origin exactly on the x = 0 plane, direction along z: 0 * inf = NaN in x.
        let r = Ray { origin: Vec3::new(0.0, 0.5, -1.0), dir: Vec3::new(0.0, 0.0, 1.0) };
        let (t0, t1) = b.clip(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t0, 1.0);
        assert!(t1 >= 2.0);
        let miss = Ray { origin: Vec3::new(2.0, 0.5, -1.0), dir: Vec3::new(0.0, 0.0, 1.0) };
        assert_eq!(b.clip(&miss, 0.0, f32::INFINITY), None);
    }

    #[test]
    fn gamma_matches_pbrt_definition() {
        assert!((gamma(3) - 3.0 * MACHINE_EPSILON / (1.0 - 3.0 * MACHINE_EPSILON)).abs() < 1e-12);
    }
}
