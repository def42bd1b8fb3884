//! PE-memory reads of a ray, for memory studies (a cache in front of external memory): an
//! optional observer the timed trace calls with every read a PE's memory serves, in the
//! order the RTL makes them (rtl/README.md §4.1–§4.4). Off by default ([`NoObserver`],
//! compiled away); an observer only watches, so results and counters do not change.
//!
//! Per ray, for every list entry in list order, the voxel-table binary search of its PE
//! (the controller, while the request streams in: one id word per probe, then the first-ref
//! and count words of the match); then, entry by entry, every test the entry's PE issued
//! before the ray was decided (the tests RESULT counts): its ref word, then its record; then
//! the winner's prim, material and normal; then [`PeReadObserver::ray_end`].
//!
//! Addresses are word offsets inside the PE's own memory, in the model's layout (image at
//! 0, a kernel's load-time record table right after it; the RTL stacks the records from the
//! top down instead).

use gridrt_shared::fsl::RayResult;

/// What a read fetches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeReadKind {
    /// Voxel table: an id word of a binary-search probe, or the match's first-ref and count.
    VoxelTable,
    /// A reference word (which triangle or primitive a test takes).
    Ref,
    /// The record a test reads: the kernel's triangle record, or an analytic primitive's.
    Record,
    /// The winner's prim id, material and normal (triangles: image words 0–2 and 9–10,
    /// where the RTL keeps the normal over vertex a).
    Result,
}

/// One read of `words` consecutive words at word `addr` of PE `pe`'s memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeRead {
    /// The PE.
    pub pe: u8,
    /// Word offset in the PE's memory.
    pub addr: u32,
    /// Consecutive words read.
    pub words: u32,
    /// What they are.
    pub kind: PeReadKind,
}

/// Watches the PE-memory reads of timed traces (module doc).
pub trait PeReadObserver {
    /// False only for [`NoObserver`]: the trace then skips the work of describing reads.
    const ACTIVE: bool = true;

    /// One read, in PE order (module doc).
    fn read(&mut self, read: PeRead);

    /// The ray is answered with `result` (its `cycles` and `tests` filled).
    #[inline(always)]
    fn ray_end(&mut self, _result: &RayResult) {}
}

/// No observer: the default of every trace; costs nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl PeReadObserver for NoObserver {
    const ACTIVE: bool = false;

    #[inline(always)]
    fn read(&mut self, _read: PeRead) {}
}

impl<O: PeReadObserver> PeReadObserver for &mut O {
    const ACTIVE: bool = O::ACTIVE;

    #[inline(always)]
    fn read(&mut self, read: PeRead) {
        (**self).read(read);
    }

    #[inline(always)]
    fn ray_end(&mut self, result: &RayResult) {
        (**self).ray_end(result);
    }
}
