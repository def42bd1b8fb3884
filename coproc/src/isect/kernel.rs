//! What every intersection kernel is: the [`Kernel`] trait, its record status, the selector
//! [`KernelKind`] and the triangle it reads.

use crate::numeric::{FixedFrame, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::{Ray, Vec3};

/// Triangle vertices `a, b, c` as stored in PE memory (words 0..9 of a triangle record).
pub type Triangle = [Vec3; 3];

/// Largest record of any kernel, in words.
pub const MAX_RECORD_WORDS: usize = 10;

/// What precomputing one triangle's record found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RecordStatus {
    /// A usable record.
    Ok,
    /// Zero-area (or, in f32, so thin that a coefficient is not finite): the record never hits.
    Degenerate,
    /// A value does not fit the format's 32-bit storage: every test of it reports
    /// [`Overflow`].
    Overflow,
}

/// A ray–triangle intersection kernel in one number format.
pub trait Kernel {
    /// The selector of this kernel.
    const KIND: KernelKind;
    /// The number format it computes in.
    const FORMAT: NumberFormat;
    /// 32-bit words of the per-triangle record it reads.
    const RECORD_WORDS: usize;
    /// True when the record is the 9 vertex words at the start of the scene image's triangle
    /// record, so no load-time table is needed.
    const USES_IMAGE: bool;
    /// True when the record's last word is a copy of the triangle's prim id (written by the
    /// co-processor at load, not by [`Kernel::precompute`]), so that one read of the record
    /// serves a test, ties included (the RTL's layout).
    const PRIM_IN_RECORD: bool = false;
    /// False for a kernel that does not test the analytic primitives of the scene image: a
    /// LOAD_PE image holding any is refused (`FslError::Unsupported`).
    const TESTS_PRIMITIVES: bool = true;
    /// Operations of one full test (no early exit), for the cycle model.
    const OPS: OpCount;
    /// Per-ray data computed once by [`Kernel::prepare`].
    type RayData: Copy;

    /// Per-ray setup. `ray` has passed [`Ray::is_valid`]. Fixed point: `Err` when the ray
    /// cannot be represented in `frame` (origin out of range).
    fn prepare(ray: &Ray, frame: &FixedFrame) -> Result<Self::RayData, Overflow>;

    /// Writes the record of `tri` into `out[..RECORD_WORDS]` (load time).
    fn precompute(tri: &Triangle, frame: &FixedFrame, out: &mut [u32]) -> RecordStatus;

    /// Tests one record (`rec.len() >= RECORD_WORDS`); returns the hit distance `t` in world
    /// units (see the contract in the module doc of [`crate::isect`]).
    fn intersect(ray: &Self::RayData, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow>;
}

/// Run-time selection of the intersection kernel every PE runs.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum KernelKind {
    /// Woop, Benthin, Wald 2013 with pbrt-v4's conservative `t` bound (the default).
    #[default]
    Watertight,
    /// Möller and Trumbore 1997.
    MollerTrumbore,
    /// GridRT's PE program: Shirley's Cramer's-rule barycentric test (Nery 2010).
    Cramer,
    /// Wald's projection test with precomputed per-triangle data (TriAccel, 2004).
    Wald,
    /// Hanika and Keller's fixed-point-friendly projection test (2007).
    HanikaKeller,
}

impl KernelKind {
    /// Every kernel, in a stable order.
    pub const ALL: [KernelKind; 5] =
        [Self::Watertight, Self::MollerTrumbore, Self::Wald, Self::HanikaKeller, Self::Cramer];

    /// Short name (for CLIs and reports: `--isect NAME`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Watertight => "watertight",
            Self::MollerTrumbore => "moller-trumbore",
            Self::Cramer => "cramer",
            Self::Wald => "wald",
            Self::HanikaKeller => "hanika-keller",
        }
    }

    /// Parses [`KernelKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}
