//! Ray–triangle intersection kernels run by the PEs.
//!
//! Every kernel implements the small [`Kernel`] trait: a per-ray [`Kernel::prepare`] step
//! (hoisted out of the triangle loop, like the PE's ray registers R26–R31 in GridRT) and a
//! per-triangle [`Kernel::intersect`] step. The co-processor is generic over the trait and
//! [`KernelKind`] picks the monomorphised instance at run time, so adding a kernel (Wald's
//! projection test, Hanika–Keller, fixed-point formats from seed 002) is one module, one
//! `impl Kernel` and one enum variant.
//!
//! Contract shared by all kernels:
//! - a returned `t` is strictly above the kernel's own conservative lower bound (at least
//!   `t > 0`), so a hit never lies behind the origin;
//! - `t_bound` is only an early-out: the kernel rejects hits clearly beyond it but may return
//!   a `t` slightly above it. The caller applies the exact acceptance rule on the returned
//!   `t` (`coproc::accept`), which keeps every kernel's answer independent of the bound it
//!   was given (needed for the brute-force equivalence test).
//! - degenerate triangles and rays parallel to the triangle plane return `None`;
//!   no kernel panics, whatever the input bits.

// The kernels write `!(x > y)` on purpose: it rejects NaN, which `x <= y` would let through.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod cramer;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod moller_trumbore;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod watertight;

use gridrt_shared::math::{Ray, Vec3};

/// Triangle vertices `a, b, c` as stored in PE memory (words 0..9 of a triangle record).
pub type Triangle = [Vec3; 3];

/// A ray–triangle intersection kernel.
pub trait Kernel {
    /// The selector of this kernel.
    const KIND: KernelKind;
    /// 32-bit words of per-triangle geometry the kernel reads from PE memory.
    const TRIANGLE_WORDS: usize;
    /// Floating-point operations of one full test (no early exit), for cost models.
    const FLOPS_PER_TEST: u32;
    /// Per-ray data computed once by [`Kernel::prepare`].
    type RayData: Copy;

    /// Per-ray setup. `ray` has passed [`Ray::is_valid`].
    fn prepare(ray: &Ray) -> Self::RayData;

    /// Tests one triangle; returns the hit distance `t` (see the module contract).
    fn intersect(ray: &Self::RayData, tri: &Triangle, t_bound: f32) -> Option<f32>;
}

/// Run-time selection of the intersection kernel every PE runs.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelKind {
    /// Woop, Benthin, Wald 2013 with pbrt-v4's conservative `t` bound (the default).
    #[default]
    Watertight,
    /// Möller and Trumbore 1997.
    MollerTrumbore,
    /// GridRT's PE program: Shirley's Cramer's-rule barycentric test (seed 004 §2.4).
    Cramer,
}

impl KernelKind {
    /// Every kernel, in a stable order.
    pub const ALL: [KernelKind; 3] = [Self::Watertight, Self::MollerTrumbore, Self::Cramer];

    /// Short name (for CLIs and reports).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Watertight => "watertight",
            Self::MollerTrumbore => "moller-trumbore",
            Self::Cramer => "cramer",
        }
    }

    /// Parses [`KernelKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Per-triangle geometry words of the kernel.
    pub const fn triangle_words(self) -> usize {
        match self {
            Self::Watertight => watertight::Watertight::TRIANGLE_WORDS,
            Self::MollerTrumbore => moller_trumbore::MollerTrumbore::TRIANGLE_WORDS,
            Self::Cramer => cramer::Cramer::TRIANGLE_WORDS,
        }
    }

    /// Floating-point operations of one full test.
    pub const fn flops_per_test(self) -> u32 {
        match self {
            Self::Watertight => watertight::Watertight::FLOPS_PER_TEST,
            Self::MollerTrumbore => moller_trumbore::MollerTrumbore::FLOPS_PER_TEST,
            Self::Cramer => cramer::Cramer::FLOPS_PER_TEST,
        }
    }

    /// Tests one triangle with this kernel, preparing the ray on the spot (convenience for
    /// references and tests; the co-processor hoists `prepare` out of its loops).
    pub fn intersect_once(self, ray: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32> {
        fn go<K: Kernel>(ray: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32> {
            K::intersect(&K::prepare(ray), tri, t_bound)
        }
        match self {
            Self::Watertight => go::<watertight::Watertight>(ray, tri, t_bound),
            Self::MollerTrumbore => go::<moller_trumbore::MollerTrumbore>(ray, tri, t_bound),
            Self::Cramer => go::<cramer::Cramer>(ray, tri, t_bound),
        }
    }
}

/// Geometric normal `(b − a) × (c − a)`, not normalised (the RayResult convention).
#[inline]
pub fn geometric_normal(tri: &Triangle) -> Vec3 {
    (tri[1] - tri[0]).cross(tri[2] - tri[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    /// Literal regression: axis-aligned ray onto the unit right triangle at z = 0.
    #[test]
    fn every_kernel_hits_unit_triangle_at_t_one() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let ray = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
        for k in KernelKind::ALL {
            assert_eq!(k.intersect_once(&ray, &tri, f32::INFINITY), Some(1.0), "{k:?}");
            // Reversed winding (det < 0) must hit too: all kernels are two-sided.
            let rev = [tri[0], tri[2], tri[1]];
            assert_eq!(k.intersect_once(&ray, &rev, f32::INFINITY), Some(1.0), "{k:?} reversed");
        }
    }

    #[test]
    fn every_kernel_rejects_behind_parallel_degenerate_and_beyond_bound() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let behind = Ray { origin: v(0.25, 0.25, 1.0), dir: v(0.0, 0.0, 1.0) };
        let parallel = Ray { origin: v(0.25, 0.25, 0.0), dir: v(1.0, 0.0, 0.0) };
        let degenerate = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0)];
        let towards = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
        let outside = Ray { origin: v(0.75, 0.75, -1.0), dir: v(0.0, 0.0, 1.0) };
        for k in KernelKind::ALL {
            assert_eq!(k.intersect_once(&behind, &tri, f32::INFINITY), None, "{k:?} behind");
            assert_eq!(k.intersect_once(&parallel, &tri, f32::INFINITY), None, "{k:?} parallel");
            assert_eq!(k.intersect_once(&towards, &degenerate, f32::INFINITY), None, "{k:?} degenerate");
            assert_eq!(k.intersect_once(&outside, &tri, f32::INFINITY), None, "{k:?} outside");
            assert_eq!(k.intersect_once(&towards, &tri, 0.5), None, "{k:?} bound");
        }
    }

    /// Random interior hits: every kernel agrees with an f64 plane intersection to a few ulp.
    #[test]
    fn every_kernel_matches_f64_reference_on_interior_hits() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x15EC7);
        for _ in 0..2000 {
            let mut p = || v(rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0));
            let tri = [p(), p(), p()];
            let o = p();
            let n = geometric_normal(&tri);
            if n.length() < 0.5 {
                continue;
            }
            // Aim at an interior point with barycentrics bounded away from the edges.
            let (b1, b2) = (rng.gen_range(0.1f32..0.45), rng.gen_range(0.1f32..0.45));
            let target = tri[0] + (tri[1] - tri[0]) * b1 + (tri[2] - tri[0]) * b2;
            let dir = target - o;
            let cos = (n.normalize().dot(dir.normalize())).abs();
            if cos < 0.05 {
                continue;
            }
            let ray = Ray { origin: o, dir };
            // f64 reference: t = n·(a − o) / n·d with n computed in f64.
            let d64 = |x: Vec3| [x.x as f64, x.y as f64, x.z as f64];
            let (a, b, c, o64, dd) = (d64(tri[0]), d64(tri[1]), d64(tri[2]), d64(o), d64(dir));
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let nn = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
            let t_ref = dot(nn, [a[0] - o64[0], a[1] - o64[1], a[2] - o64[2]]) / dot(nn, dd);
            for k in KernelKind::ALL {
                let t = k.intersect_once(&ray, &tri, f32::INFINITY);
                let t = t.unwrap_or_else(|| panic!("{k:?} missed an interior hit"));
                let rel = ((t as f64 - t_ref) / t_ref).abs();
                assert!(rel < 1e-4, "{k:?}: t {t} vs {t_ref} (rel {rel:e}, cos {cos})");
            }
        }
    }
}
