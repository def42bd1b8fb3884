//! Ray–triangle intersection kernels run by the PEs, in every number format.
//!
//! | kernel (`--isect NAME`) | module | source | record (bytes/triangle) |
//! |---|---|---|---|
//! | `watertight` (default) | [`watertight`] | Woop, Benthin, Wald, JCGT 2013; pbrt-v4 | the 9 vertex words: 36 |
//! | `moller-trumbore` | [`moller_trumbore`] | Möller, Trumbore, JGT 1997 | the 9 vertex words: 36 |
//! | `wald` | [`wald`] | Wald, PhD thesis 2004, §7.1 ("TriAccel") | 1 axis word + 9 precomputed: 40 |
//! | `hanika-keller` | [`hanika_keller`] | Hanika, Keller, RT 2007 | 1 axis word + 9 precomputed: 40 |
//! | `cramer` | [`cramer`] | Shirley, as GridRT's PE program | the 9 vertex words: 36 |
//!
//! Every kernel runs in every [`NumberFormat`]: `f32` (the plain type) and the fixed-point
//! formats (the `…Fx<Q>` type, generic over [`FixedFormat`](crate::numeric::FixedFormat)).
//! Bytes per triangle are the kernel's record; every kernel additionally has the prim id and
//! material words of the scene image (8 B), used only for the result.
//!
//! [`kernel`] holds the [`Kernel`] trait every kernel implements; [`vertex`] the vertex record
//! (watertight, Möller–Trumbore, Cramer) and [`projection`] the projection record (Wald,
//! Hanika–Keller), each with the `Kernel` impls for a test that is a function of its record
//! alone, so a kernel module holds its algorithm and its costs and no plumbing. This module
//! dispatches at run time (`with_kernel!`, [`Intersector`]).
//!
//! # Where the per-triangle records live (PE memory accounting)
//!
//! The scene image format (SPEC §5.4) is the same for every kernel: 11 words per triangle,
//! the 9 vertex floats first. A kernel whose record *is* those 9 floats (`f32` watertight,
//! Möller–Trumbore, Cramer: [`Kernel::USES_IMAGE`]) reads the image directly. Every other
//! (kernel, format) pair reads a record table that the co-processor model precomputes at
//! LOAD time with [`Kernel::precompute`] and stores in the same PE memory, right after the
//! image. The table is charged against `pe_mem_words`: a LOAD fails with `PeMemoryOverflow`
//! unless `image words + T · RECORD_WORDS ≤ pe_mem_words` (see
//! [`KernelKind::pe_words_needed`]). A hardware design would have the host precompute and
//! stream the same records; the memory cost is the same, and the scene image stays stable.
//!
//! # Contract shared by all kernels
//!
//! - a returned `t` is strictly above the kernel's own conservative lower bound (at least
//!   `t > 0`), so a hit never lies behind the origin;
//! - `t_bound` is only an early-out: the kernel rejects hits clearly beyond it but may return
//!   a `t` slightly above it. The caller applies the exact acceptance rule on the returned
//!   `t` (`coproc::accept`), which keeps every kernel's answer independent of the bound it
//!   was given (needed for the brute-force equivalence test).
//! - degenerate triangles and rays parallel to the triangle plane are misses;
//!   no kernel panics, whatever the input bits;
//! - a fixed-point range overflow is returned as `Err(Overflow)`, never as a wrong hit or a
//!   silent miss (the co-processor counts it).
//!
//! Link data reaches a kernel only as a record slice that `crate::coproc` cut out of PE
//! memory with checked offsets; the kernel takes its fixed-size words with `get` (a short
//! record is a miss). The kernels' own arithmetic (float, and fixed point with its explicit
//! overflow checks) is the hot path and is not under the crate's `indexing_slicing` /
//! `arithmetic_side_effects` denial, which covers the code that parses link data.

// The kernels write `!(x > y)` on purpose: it rejects NaN, which `x <= y` would let through.
// `analytic`: the analytic primitives of the scene image (sphere, cylinder, cone, disk, square).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod analytic;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod cramer;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod hanika_keller;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod moller_trumbore;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod wald;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod watertight;
pub mod watertight_q23;

pub mod kernel;
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod projection;
pub mod vertex;

pub use kernel::{Kernel, KernelKind, RecordStatus, Triangle, MAX_RECORD_WORDS};

use crate::numeric::{FixedFrame, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::{Ray, Vec3};

/// Runs `$body` with `$K` bound to the kernel type of (`$kind`, `$format`).
macro_rules! with_kernel {
    ($kind:expr, $format:expr, $K:ident => $body:expr) => {{
        use $crate::isect::{cramer, hanika_keller, moller_trumbore, wald, watertight, watertight_q23, KernelKind};
        use $crate::numeric::{NumberFormat, Q16, Q23};
        match ($kind, $format) {
            (KernelKind::Watertight, NumberFormat::F32) => {
                type $K = watertight::Watertight;
                $body
            }
            (KernelKind::Watertight, NumberFormat::Fixed64Q23) => {
                type $K = watertight_q23::WatertightQ23;
                $body
            }
            (KernelKind::Watertight, NumberFormat::Fixed32Q16) => {
                type $K = watertight::WatertightFx<Q16>;
                $body
            }
            (KernelKind::MollerTrumbore, NumberFormat::F32) => {
                type $K = moller_trumbore::MollerTrumbore;
                $body
            }
            (KernelKind::MollerTrumbore, NumberFormat::Fixed64Q23) => {
                type $K = moller_trumbore::MollerTrumboreFx<Q23>;
                $body
            }
            (KernelKind::MollerTrumbore, NumberFormat::Fixed32Q16) => {
                type $K = moller_trumbore::MollerTrumboreFx<Q16>;
                $body
            }
            (KernelKind::Cramer, NumberFormat::F32) => {
                type $K = cramer::Cramer;
                $body
            }
            (KernelKind::Cramer, NumberFormat::Fixed64Q23) => {
                type $K = cramer::CramerFx<Q23>;
                $body
            }
            (KernelKind::Cramer, NumberFormat::Fixed32Q16) => {
                type $K = cramer::CramerFx<Q16>;
                $body
            }
            (KernelKind::Wald, NumberFormat::F32) => {
                type $K = wald::Wald;
                $body
            }
            (KernelKind::Wald, NumberFormat::Fixed64Q23) => {
                type $K = wald::WaldFx<Q23>;
                $body
            }
            (KernelKind::Wald, NumberFormat::Fixed32Q16) => {
                type $K = wald::WaldFx<Q16>;
                $body
            }
            (KernelKind::HanikaKeller, NumberFormat::F32) => {
                type $K = hanika_keller::HanikaKeller;
                $body
            }
            (KernelKind::HanikaKeller, NumberFormat::Fixed64Q23) => {
                type $K = hanika_keller::HanikaKellerFx<Q23>;
                $body
            }
            (KernelKind::HanikaKeller, NumberFormat::Fixed32Q16) => {
                type $K = hanika_keller::HanikaKellerFx<Q16>;
                $body
            }
        }
    }};
}
pub(crate) use with_kernel;

/// What each kernel needs, looked up through `with_kernel!`.
impl KernelKind {
    /// Per-triangle record words of the kernel in f32.
    pub fn triangle_words(self) -> usize {
        self.record_words(NumberFormat::F32)
    }

    /// Operations of one full f32 test.
    pub fn flops_per_test(self) -> u32 {
        self.ops(NumberFormat::F32).total()
    }

    /// Per-triangle record words in `format`.
    pub fn record_words(self, format: NumberFormat) -> usize {
        with_kernel!(self, format, K => K::RECORD_WORDS)
    }

    /// Per-triangle record bytes in `format` (the documented storage size; the scene image's
    /// prim id and material words come on top, see the module doc).
    pub fn bytes_per_triangle(self, format: NumberFormat) -> usize {
        4 * self.record_words(format)
    }

    /// True when the kernel reads the scene image's vertex words directly (no table).
    pub fn uses_image(self, format: NumberFormat) -> bool {
        with_kernel!(self, format, K => K::USES_IMAGE)
    }

    /// Operations of one full test in `format`.
    pub fn ops(self, format: NumberFormat) -> OpCount {
        with_kernel!(self, format, K => K::OPS)
    }

    /// PE memory words a PE image of `image_words` words holding `triangles` triangles needs
    /// with this kernel and format: the image plus the load-time record table.
    pub fn pe_words_needed(self, format: NumberFormat, image_words: usize, triangles: usize) -> usize {
        if self.uses_image(format) {
            image_words
        } else {
            image_words.saturating_add(triangles.saturating_mul(self.record_words(format)))
        }
    }

    /// Tests one triangle with this kernel in f32, preparing the ray and the record on the
    /// spot (convenience for references and tests; the co-processor hoists both).
    pub fn intersect_once(self, ray: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32> {
        Intersector::new(self, NumberFormat::F32, FixedFrame::IDENTITY).intersect_tri(ray, tri, t_bound).ok().flatten()
    }
}

/// One triangle's record as an [`Intersector`] stores it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Record {
    /// The record words (the first `record_words` are used).
    pub words: [u32; MAX_RECORD_WORDS],
    /// What the precomputation found.
    pub status: RecordStatus,
}

/// A kernel, a number format and a fixed-point frame chosen at run time: the dynamic entry
/// point for references, tests and benches (the co-processor monomorphises instead).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intersector {
    /// Kernel.
    pub kind: KernelKind,
    /// Number format.
    pub format: NumberFormat,
    /// Frame of the fixed-point formats (ignored by f32).
    pub frame: FixedFrame,
}

impl Intersector {
    /// A kernel in a format and frame.
    pub fn new(kind: KernelKind, format: NumberFormat, frame: FixedFrame) -> Self {
        Self { kind, format, frame }
    }

    /// The record of `tri` (what the co-processor would store at load time).
    pub fn precompute(&self, tri: &Triangle) -> Record {
        let mut words = [0u32; MAX_RECORD_WORDS];
        let status = with_kernel!(self.kind, self.format, K => K::precompute(tri, &self.frame, &mut words));
        Record { words, status }
    }

    /// Tests a precomputed record.
    pub fn intersect(&self, ray: &Ray, rec: &Record, t_bound: f32) -> Result<Option<f32>, Overflow> {
        if !ray.is_valid() {
            return Ok(None);
        }
        with_kernel!(self.kind, self.format, K => {
            let pre = K::prepare(ray, &self.frame)?;
            K::intersect(&pre, &rec.words, t_bound)
        })
    }

    /// Precomputes and tests in one go.
    pub fn intersect_tri(&self, ray: &Ray, tri: &Triangle, t_bound: f32) -> Result<Option<f32>, Overflow> {
        self.intersect(ray, &self.precompute(tri), t_bound)
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

    /// Every (kernel, format) with the frame of the box [−4, 4]³.
    fn all() -> impl Iterator<Item = Intersector> {
        KernelKind::ALL.into_iter().flat_map(|k| {
            NumberFormat::ALL.into_iter().map(move |f| {
                let frame = FixedFrame::for_box([-4.0; 3], [4.0; 3], f).unwrap();
                Intersector::new(k, f, frame)
            })
        })
    }

    /// Literal regression: axis-aligned ray onto the unit right triangle at z = 0.
    #[test]
    fn every_kernel_and_format_hits_unit_triangle_at_t_one() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let ray = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
        for k in KernelKind::ALL {
            assert_eq!(k.intersect_once(&ray, &tri, f32::INFINITY), Some(1.0), "{k:?}");
        }
        for is in all() {
            assert_eq!(is.intersect_tri(&ray, &tri, f32::INFINITY), Ok(Some(1.0)), "{is:?}");
            // Reversed winding (det < 0) must hit too: all kernels are two-sided.
            let rev = [tri[0], tri[2], tri[1]];
            assert_eq!(is.intersect_tri(&ray, &rev, f32::INFINITY), Ok(Some(1.0)), "{is:?} reversed");
        }
    }

    #[test]
    fn every_kernel_and_format_rejects_behind_parallel_degenerate_and_beyond_bound() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let behind = Ray { origin: v(0.25, 0.25, 1.0), dir: v(0.0, 0.0, 1.0) };
        let parallel = Ray { origin: v(0.25, 0.25, 0.0), dir: v(1.0, 0.0, 0.0) };
        let degenerate = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0)];
        let towards = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
        let outside = Ray { origin: v(0.75, 0.75, -1.0), dir: v(0.0, 0.0, 1.0) };
        for is in all() {
            assert_eq!(is.intersect_tri(&behind, &tri, f32::INFINITY), Ok(None), "{is:?} behind");
            assert_eq!(is.intersect_tri(&parallel, &tri, f32::INFINITY), Ok(None), "{is:?} parallel");
            assert_eq!(is.intersect_tri(&towards, &degenerate, f32::INFINITY), Ok(None), "{is:?} degenerate");
            assert_eq!(is.intersect_tri(&outside, &tri, f32::INFINITY), Ok(None), "{is:?} outside");
            // The bound is only an early-out: a kernel rejects the hit at t = 1 or returns it
            // for the caller's acceptance rule to reject (watertight fixed64-q23 has none).
            let bounded = is.intersect_tri(&towards, &tri, 0.5);
            assert!(matches!(bounded, Ok(None) | Ok(Some(1.0))), "{is:?} bound: {bounded:?}");
            let rec = is.precompute(&degenerate);
            if is.kind == KernelKind::Wald || is.kind == KernelKind::HanikaKeller {
                assert_eq!(rec.status, RecordStatus::Degenerate, "{is:?}");
            }
        }
    }

    /// Random interior hits: every kernel in every format agrees with an f64 plane
    /// intersection (f32: to a few ulp; fixed point: to its resolution in the frame).
    #[test]
    fn every_kernel_and_format_matches_f64_reference_on_interior_hits() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x15EC7);
        let mut checked = 0;
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
            let t_ref = crate::exact::t_f64(&ray, &tri);
            assert!(crate::exact::intersect(&ray, &tri).is_some());
            for is in all() {
                let t = is.intersect_tri(&ray, &tri, f32::INFINITY);
                let t = t
                    .unwrap_or_else(|e| panic!("{is:?}: {e}"))
                    .unwrap_or_else(|| panic!("{is:?} missed an interior hit"));
                let rel = ((t as f64 - t_ref) / t_ref).abs();
                let tol = match is.format {
                    NumberFormat::F32 => 1e-4,
                    NumberFormat::Fixed64Q23 => 1e-4,
                    _ => 2e-2,
                };
                assert!(rel < tol, "{is:?}: t {t} vs {t_ref} (rel {rel:e}, cos {cos})");
            }
            checked += 1;
        }
        assert!(checked > 1000, "{checked}");
    }

    /// Fixed-point range: a ray from far outside the frame overflows and is *reported*
    /// (`Err(Overflow)`), never turned into a wrong hit or a silent miss.
    #[test]
    fn fixed_point_overflow_is_reported_not_wrapped() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        for is in all().filter(|is| is.format.is_fixed()) {
            // Just inside the format's range the hit is exact; beyond it, overflow. The RTL's
            // watertight kernel takes origins within ±1024 frame units (here ±512 world).
            let (inside, beyond) = match (is.kind, is.format) {
                (_, NumberFormat::Fixed32Q16) => (1.0e4, 1.0e5),
                (KernelKind::Watertight, _) => (500.0, 600.0),
                _ => (1.0e5, 1.0e13),
            };
            let ok = Ray { origin: v(0.25, 0.25, -inside), dir: v(0.0, 0.0, 1.0) };
            let far = Ray { origin: v(0.25, 0.25, -beyond), dir: v(0.0, 0.0, 1.0) };
            assert_eq!(is.intersect_tri(&ok, &tri, f32::INFINITY), Ok(Some(inside)), "{is:?}");
            assert_eq!(is.intersect_tri(&far, &tri, f32::INFINITY), Err(Overflow), "{is:?}");
        }
        // A triangle that does not fit the storage: its record is flagged and every test of
        // it reports the overflow.
        let far_tri = [v(1.0e6, 1.0e6, 1.0e6), v(1.0e6 + 1.0, 1.0e6, 1.0e6), v(1.0e6, 1.0e6 + 1.0, 1.0e6)];
        let near = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
        for is in all().filter(|is| is.format.is_fixed()) {
            let rec = is.precompute(&far_tri);
            assert_eq!(rec.status, RecordStatus::Overflow, "{is:?}");
            assert_eq!(is.intersect(&near, &rec, f32::INFINITY), Err(Overflow), "{is:?}");
        }
    }

    #[test]
    fn names_and_storage_sizes_are_documented_values() {
        let names: Vec<_> = KernelKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names, ["watertight", "moller-trumbore", "wald", "hanika-keller", "cramer"]);
        for k in KernelKind::ALL {
            assert_eq!(KernelKind::from_name(k.name()), Some(k));
            for f in NumberFormat::ALL {
                let bytes = k.bytes_per_triangle(f);
                // Projection records carry an axis word; the RTL's watertight fixed64-q23
                // record a copy of the prim id.
                let want = match (k, f) {
                    (KernelKind::Wald | KernelKind::HanikaKeller, _) => 40,
                    (KernelKind::Watertight, NumberFormat::Fixed64Q23) => 40,
                    _ => 36,
                };
                assert_eq!(bytes, want, "{k:?} {f:?}");
                assert!(k.record_words(f) <= MAX_RECORD_WORDS);
                assert_eq!(k.uses_image(f), f == NumberFormat::F32 && want == 36);
                assert_eq!(
                    k.pe_words_needed(f, 100, 10),
                    if k.uses_image(f) { 100 } else { 100 + 10 * k.record_words(f) }
                );
            }
        }
        assert_eq!(NumberFormat::from_name("fixed64-q23"), Some(NumberFormat::Fixed64Q23));
        assert_eq!(NumberFormat::from_name("fixed32-q16"), Some(NumberFormat::Fixed32Q16));
    }
}
