//! The functional model of one ray: the checks of a request, and the search of its list
//! through the loaded PE memories (arbitration in the module doc of [`crate::coproc`]).

use gridrt_shared::fsl::{FslError, ListEntry, RayKind, RayResult, RAY_HEADER_WORDS, VOXEL_MASK};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::{MAX_PES, PRIM_WORDS, TRIANGLE_WORDS, VOXEL_ENTRY_WORDS};

use super::image::{record, record_at, span, PeSlot};
use super::observe::{NoObserver, PeRead, PeReadKind, PeReadObserver};
use super::stats::TraceInfo;
use crate::config::{ArbitrationRule, CoprocConfig};
use crate::isect::{geometric_normal, with_kernel, Kernel};
use crate::numeric::{FixedFrame, NumberFormat, Overflow};

/// Relative tolerance on a list entry's exit distance: a hit is accepted in entry k if
/// `t ≤ t_exit·(1 + T_EXIT_REL_TOL)`.
pub const T_EXIT_REL_TOL: f32 = 1.0 / 4096.0;

/// The number format the PEs compute in and its fixed-point frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Numerics {
    pub(super) format: NumberFormat,
    pub(super) frame: FixedFrame,
}

/// Where an entry's references live: absolute index of its first ref word, ref count, and
/// absolute index of its PE's triangle records.
#[derive(Debug, Clone, Copy)]
pub(super) struct EntryRefs {
    first: usize,
    pub(super) count: u32,
    tri_base: usize,
    /// Triangles of the PE: refs ≥ this name analytic primitives at `prim_base`.
    tris: u32,
    prim_base: usize,
    /// Load-time kernel record table (right after the image; unused by `USES_IMAGE`
    /// kernels, which read the triangle records at `tri_base`).
    rec_base: usize,
}

/// The winning hit of a search.
#[derive(Debug, Clone, Copy)]
pub(super) struct Found {
    /// List position.
    pub(super) k: usize,
    /// Absolute index of the triangle (or primitive) record.
    rec: usize,
    /// The record is an analytic primitive.
    prim: bool,
    t: f32,
    /// Tests the winning entry performed (all of them for Closest; up to the hit for Any).
    pub(super) tests_in_entry: u32,
}

/// The RESULT normal's NaN is always `0x7FC00000` (SPEC §4.4), whatever NaN the platform's
/// arithmetic made (x86 gives `0xFFC00000` for inf − inf).
fn canonical_nan(x: f32) -> f32 {
    if x.is_nan() {
        f32::from_bits(0x7FC0_0000)
    } else {
        x
    }
}

#[inline(always)]
fn accept(t: f32, t_max: f32, hi: f32) -> bool {
    t > 0.0 && t < t_max && t <= hi
}

/// Kernel early-out bound: slightly above the exact acceptance limit so that rounding in a
/// kernel's range test never drops a hit that the exact test would accept or tie.
#[inline(always)]
fn inflate(x: f32) -> f32 {
    if x.is_finite() {
        x + x.abs() * (1.0 / 65536.0)
    } else {
        x
    }
}

/// Read-only view of the PE memories (shared by the timed and untimed paths).
#[derive(Clone, Copy)]
pub(super) struct View<'a> {
    pub(super) cfg: &'a CoprocConfig,
    pub(super) mem: &'a [u32],
    pub(super) slots: &'a [PeSlot; MAX_PES],
    pub(super) loaded_pes: u16,
    pub(super) rule: ArbitrationRule,
    pub(super) numerics: Numerics,
}

impl View<'_> {
    /// Binary search of `voxel` in PE `pe`'s voxel table.
    pub(super) fn lookup(&self, pe: u8, voxel: u32) -> Option<EntryRefs> {
        self.lookup_observed(pe, voxel, &mut NoObserver)
    }

    /// Word `pe`'s memory starts at.
    fn pe_base(&self, pe: u8) -> usize {
        (pe as usize).saturating_mul(self.cfg.pe_mem_words as usize)
    }

    /// A read of `words` words at absolute index `at` of PE `pe`'s memory, as the PE sees it.
    fn pe_read(&self, pe: u8, at: usize, words: usize, kind: PeReadKind) -> PeRead {
        let rel = at.saturating_sub(self.pe_base(pe));
        let words = u32::try_from(words).unwrap_or(u32::MAX);
        PeRead { pe, addr: u32::try_from(rel).unwrap_or(u32::MAX), words, kind }
    }

    /// [`lookup`](Self::lookup) that tells `obs` what each probe reads: the entry's id word,
    /// and at the match its first-ref and count words (the RTL's controller, rtl/README §4.1).
    pub(super) fn lookup_observed<O: PeReadObserver>(&self, pe: u8, voxel: u32, obs: &mut O) -> Option<EntryRefs> {
        let slot = self.slots.get(pe as usize)?;
        if !slot.loaded {
            return None;
        }
        // Offsets were checked at LOAD to lie inside the PE's memory, so nothing here
        // saturates; a saturated offset would only make the checked access fail.
        let base = self.pe_base(pe);
        let at = |off: u32| base.saturating_add(off as usize);
        let table = span(self.mem, at(slot.hdr), slot.ref_off.saturating_sub(slot.hdr) as usize)?;
        let (mut lo, mut hi) = (0usize, slot.voxels as usize);
        while lo < hi {
            let mid = lo.midpoint(hi);
            let off = mid.saturating_mul(VOXEL_ENTRY_WORDS);
            let &[id, first, count] = record_at::<VOXEL_ENTRY_WORDS>(table, off)?;
            if O::ACTIVE {
                obs.read(self.pe_read(pe, at(slot.hdr).saturating_add(off), 1, PeReadKind::VoxelTable));
            }
            if id < voxel {
                lo = mid.saturating_add(1);
            } else if id > voxel {
                hi = mid;
            } else {
                if O::ACTIVE {
                    let words = at(slot.hdr).saturating_add(off).saturating_add(1);
                    obs.read(self.pe_read(pe, words, 2, PeReadKind::VoxelTable));
                }
                return Some(EntryRefs {
                    first: at(slot.ref_off).saturating_add(first as usize),
                    count,
                    tri_base: at(slot.tri_off),
                    tris: slot.tris,
                    prim_base: at(slot.prim_off),
                    rec_base: at(slot.len),
                });
            }
        }
        None
    }

    /// Tells `obs` the reads of the first `started` tests of entry `e`: each test's ref word,
    /// then its record (the kernel's record, or the analytic primitive's).
    pub(super) fn observe_tests<O: PeReadObserver>(&self, e: &ListEntry, started: u32, obs: &mut O) {
        let Some(refs) = self.lookup(e.pe, e.voxel) else { return };
        let Some(list) = span(self.mem, refs.first, refs.count as usize) else { return };
        let (rec_words, uses_image) =
            with_kernel!(self.cfg.kernel, self.numerics.format, K => (K::RECORD_WORDS, K::USES_IMAGE));
        for (j, &r) in list.iter().enumerate().take(started as usize) {
            obs.read(self.pe_read(e.pe, refs.first.saturating_add(j), 1, PeReadKind::Ref));
            let (at, words) = if let Some(p) = r.checked_sub(refs.tris) {
                (refs.prim_base.saturating_add((p as usize).saturating_mul(PRIM_WORDS)), PRIM_WORDS)
            } else if uses_image {
                (refs.tri_base.saturating_add((r as usize).saturating_mul(TRIANGLE_WORDS)), rec_words)
            } else {
                (refs.rec_base.saturating_add((r as usize).saturating_mul(rec_words)), rec_words)
            };
            obs.read(self.pe_read(e.pe, at, words, PeReadKind::Record));
        }
    }

    /// Tells `obs` what the result stage reads of the winner: a triangle's prim id and
    /// material (image words 9–10), then its normal (words 0–2, where the RTL keeps it); an
    /// analytic primitive's whole record.
    pub(super) fn observe_result<O: PeReadObserver>(&self, list: &[ListEntry], found: Option<Found>, obs: &mut O) {
        let Some(f) = found else { return };
        let Some(e) = list.get(f.k) else { return };
        if f.prim {
            obs.read(self.pe_read(e.pe, f.rec, PRIM_WORDS, PeReadKind::Result));
        } else {
            obs.read(self.pe_read(e.pe, f.rec.saturating_add(9), 2, PeReadKind::Result));
            obs.read(self.pe_read(e.pe, f.rec, 3, PeReadKind::Result));
        }
    }

    /// For the PE caches' timing (`pe_cache`): the voxel lookup of `voxel` on PE `pe` as
    /// the RTL's controller probes it: each probe's `mid` into `probes`, and the match.
    pub(super) fn lookup_probes(&self, pe: u8, voxel: u32, probes: &mut heapless::Vec<u32, 32>) -> Option<u32> {
        let slot = self.slots.get(pe as usize).filter(|s| s.loaded)?;
        let base = self.pe_base(pe).saturating_add(slot.hdr as usize);
        let (mut lo, mut hi) = (0usize, slot.voxels as usize);
        while lo < hi {
            let mid = lo.midpoint(hi);
            let _ = probes.push(mid as u32);
            let id = self.mem.get(base.saturating_add(mid.saturating_mul(VOXEL_ENTRY_WORDS))).copied()?;
            if id < voxel {
                lo = mid.saturating_add(1);
            } else if id > voxel {
                hi = mid;
            } else {
                return Some(mid as u32);
            }
        }
        None
    }

    /// For the PE caches' timing: entry `e`'s first ref word (an address in its PE's
    /// memory) and its tests.
    pub(super) fn entry_refs(&self, e: &ListEntry) -> (u32, u32) {
        self.lookup(e.pe, e.voxel).map_or((0, 0), |r| {
            let rel = r.first.saturating_sub(self.pe_base(e.pe));
            (u32::try_from(rel).unwrap_or(u32::MAX), r.count)
        })
    }

    /// For the PE caches' timing: the winner's PE and triangle index (None for an
    /// analytic primitive).
    pub(super) fn winner_tri(&self, list: &[ListEntry], f: Found) -> Option<(u8, u32)> {
        let e = list.get(f.k)?;
        if f.prim {
            return None;
        }
        let refs = self.lookup(e.pe, e.voxel)?;
        let off = f.rec.checked_sub(refs.tri_base)?;
        Some((e.pe, u32::try_from(off / TRIANGLE_WORDS).ok()?))
    }

    /// For the PE caches' timing (the RTL's result stage, which keeps the triangle of its
    /// last Closest take across rays): the first `m` tests of entry `e` in order, `f(tri,
    /// accepted)` with `accepted` = (t, prim id) of an accepted hit. The kernel runs as in
    /// `test_entry`, without its culling by the best hit so far (a culled test is never
    /// taken).
    pub(super) fn each_test(
        &self,
        ray: &Ray,
        t_max: f32,
        e: &ListEntry,
        m: u32,
        f: &mut dyn FnMut(u32, Option<(f32, u32)>),
    ) {
        with_kernel!(self.cfg.kernel, self.numerics.format, K => self.each_test_k::<K>(ray, t_max, e, m, f));
    }

    fn each_test_k<K: Kernel>(
        &self,
        ray: &Ray,
        t_max: f32,
        e: &ListEntry,
        m: u32,
        f: &mut dyn FnMut(u32, Option<(f32, u32)>),
    ) {
        let Ok(pre) = K::prepare(ray, &self.numerics.frame) else { return };
        let Some(refs) = self.lookup(e.pe, e.voxel) else { return };
        let Some(list) = span(self.mem, refs.first, refs.count as usize) else { return };
        let hi = self.entry_hi(e);
        let bound = inflate(if t_max < hi { t_max } else { hi });
        for &r in list.iter().take(m as usize) {
            let mut acc = None;
            if r < refs.tris {
                let rec = refs.tri_base.saturating_add((r as usize).saturating_mul(TRIANGLE_WORDS));
                let kr = if K::USES_IMAGE {
                    rec
                } else {
                    refs.rec_base.saturating_add((r as usize).saturating_mul(K::RECORD_WORDS))
                };
                if let (Some(words), Some(kwords)) =
                    (record_at::<TRIANGLE_WORDS>(self.mem, rec), span(self.mem, kr, K::RECORD_WORDS))
                {
                    if let Ok(Some(t)) = K::intersect(&pre, kwords, bound) {
                        if accept(t, t_max, hi) {
                            acc = Some((t, words[9]));
                        }
                    }
                }
            }
            f(r, acc);
        }
    }

    /// Request-level checks (ray header and ray words).
    pub(super) fn check_header(&self, count: usize) -> Result<(), (FslError, u16)> {
        if self.loaded_pes == 0 {
            return Err((FslError::SceneNotLoaded, 0));
        }
        if count > self.cfg.max_list as usize {
            return Err((FslError::ListTooLong, self.cfg.max_list));
        }
        Ok(())
    }

    pub(super) fn check_ray(ray: &Ray, t_max: f32) -> Result<(), (FslError, u16)> {
        let comps = [ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z];
        if let Some(i) = comps.iter().position(|c| !c.is_finite()) {
            // Ray word 1 + i (i < 6).
            return Err((FslError::NonFiniteRay, (i as u16).saturating_add(1)));
        }
        if ray.dir == Vec3::ZERO {
            return Err((FslError::NonFiniteRay, 4));
        }
        if t_max.is_nan() {
            return Err((FslError::NonFiniteRay, 7));
        }
        Ok(())
    }

    /// Entry word 0 checks: PE range and voxel presence.
    pub(super) fn check_entry_target(&self, k: usize, pe: u8, voxel: u32) -> Result<EntryRefs, (FslError, u16)> {
        let pos = k.min(u16::MAX as usize) as u16;
        if pe as u16 >= self.cfg.pe_count {
            return Err((FslError::PeOutOfRange, pe as u16));
        }
        if voxel & VOXEL_MASK != voxel {
            return Err((FslError::VoxelOutOfRange, pos));
        }
        self.lookup(pe, voxel).ok_or((FslError::VoxelNotLoaded, pos))
    }

    /// Entry word 1 check.
    pub(super) fn check_entry_exit(k: usize, t_exit: f32) -> Result<(), (FslError, u16)> {
        if t_exit.is_nan() {
            // Word 1 of entry k: header, then 2 words per entry.
            let word = k.saturating_mul(2).saturating_add(RAY_HEADER_WORDS + 1);
            return Err((FslError::NonFiniteRay, word.min(u16::MAX as usize) as u16));
        }
        Ok(())
    }

    /// Every check of a request, in wire order.
    pub(super) fn validate(&self, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Result<(), (FslError, u16)> {
        self.check_header(list.len())?;
        Self::check_ray(ray, t_max)?;
        for (k, e) in list.iter().enumerate() {
            self.check_entry_target(k, e.pe, e.voxel)?;
            Self::check_entry_exit(k, e.t_exit)?;
        }
        Ok(())
    }

    fn entry_hi(&self, e: &ListEntry) -> f32 {
        match self.rule {
            ArbitrationRule::IntervalChecked => e.t_exit * (1.0 + T_EXIT_REL_TOL),
            ArbitrationRule::GridRtOriginal => f32::INFINITY,
        }
    }

    /// One PE working through one entry: tests every referenced triangle (Closest) or up to
    /// the first accepted one (Any). Returns the entry's hit and the tests performed; adds
    /// the tests whose fixed-point arithmetic overflowed to `overflows`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn test_entry<K: Kernel>(
        &self,
        pre: &K::RayData,
        ray: &Ray,
        kind: RayKind,
        refs: EntryRefs,
        t_max: f32,
        hi: f32,
        overflows: &mut u64,
    ) -> (Option<(f32, usize, bool)>, u32) {
        let Some(list) = span(self.mem, refs.first, refs.count as usize) else {
            return (None, 0);
        };
        let limit = if t_max < hi { t_max } else { hi };
        let mut best: Option<(f32, usize, u32, bool)> = None;
        let mut bound = inflate(limit);
        // Record offsets come from the image's reference table: a saturated one is out of
        // memory and skipped like any other bad reference.
        for (tests, &r) in (1u32..).zip(list) {
            if let Some(p) = r.checked_sub(refs.tris) {
                // Analytic primitive: same acceptance and arbitration.
                let rec = refs.prim_base.saturating_add((p as usize).saturating_mul(PRIM_WORDS));
                let Some(words) = record_at::<PRIM_WORDS>(self.mem, rec) else { continue };
                let Some(t) = crate::isect::analytic::intersect(words, ray) else { continue };
                if !accept(t, t_max, hi) {
                    continue;
                }
                match kind {
                    RayKind::Any => return (Some((t, rec, true)), tests),
                    RayKind::Closest => {
                        let prim = words[1];
                        if best.is_none_or(|(bt, _, bp, _)| t < bt || (t == bt && prim < bp)) {
                            best = Some((t, rec, prim, true));
                            bound = inflate(t);
                        }
                    }
                }
                continue;
            }
            let rec = refs.tri_base.saturating_add((r as usize).saturating_mul(TRIANGLE_WORDS));
            let Some(words) = record_at::<TRIANGLE_WORDS>(self.mem, rec) else { continue };
            // The kernel's record: the image's vertex words, or its load-time table entry.
            let kr = if K::USES_IMAGE {
                rec
            } else {
                refs.rec_base.saturating_add((r as usize).saturating_mul(K::RECORD_WORDS))
            };
            let Some(kwords) = span(self.mem, kr, K::RECORD_WORDS) else { continue };
            let t = match K::intersect(pre, kwords, bound) {
                Ok(Some(t)) => t,
                Ok(None) => continue,
                Err(Overflow) => {
                    *overflows = overflows.saturating_add(1);
                    continue;
                }
            };
            if !accept(t, t_max, hi) {
                continue;
            }
            match kind {
                RayKind::Any => return (Some((t, rec, false)), tests),
                RayKind::Closest => {
                    let prim = words[9];
                    if best.is_none_or(|(bt, _, bp, _)| t < bt || (t == bt && prim < bp)) {
                        best = Some((t, rec, prim, false));
                        bound = inflate(t);
                    }
                }
            }
        }
        (best.map(|(t, rec, _, p)| (t, rec, p)), refs.count)
    }

    /// The functional model: entries in list order until the first with an accepted hit.
    /// Returns the winner, the tests performed and the tests that overflowed. Assumes
    /// `validate` passed. A ray the fixed-point frame cannot represent overflows every test
    /// it would have made (reported, and a miss).
    fn search<K: Kernel>(
        &self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> (Option<Found>, TraceInfo) {
        let mut info = TraceInfo::default();
        let pre = match K::prepare(ray, &self.numerics.frame) {
            Ok(pre) => pre,
            Err(Overflow) => {
                for e in list {
                    info.tests = info.tests.saturating_add(self.lookup(e.pe, e.voxel).map_or(0, |r| r.count as u64));
                }
                info.overflows = info.tests;
                return (None, info);
            }
        };
        for (k, e) in list.iter().enumerate() {
            let Some(refs) = self.lookup(e.pe, e.voxel) else { continue };
            let (hit, n) = self.test_entry::<K>(&pre, ray, kind, refs, t_max, self.entry_hi(e), &mut info.overflows);
            info.tests = info.tests.saturating_add(n as u64);
            if let Some((t, rec, prim)) = hit {
                return (Some(Found { k, rec, prim, t, tests_in_entry: n }), info);
            }
        }
        (None, info)
    }

    pub(super) fn search_dyn(
        &self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> (Option<Found>, TraceInfo) {
        with_kernel!(self.cfg.kernel, self.numerics.format, K => self.search::<K>(kind, ray, t_max, list))
    }

    /// The result words' content for a winner (tests/cycles filled by the caller).
    pub(super) fn result_of(&self, list: &[ListEntry], found: Option<Found>, ray: &Ray) -> RayResult {
        let Some(f) = found else { return RayResult::MISS };
        let Some(e) = list.get(f.k) else { return RayResult::MISS };
        if f.prim {
            let Some(words) = record_at::<PRIM_WORDS>(self.mem, f.rec) else { return RayResult::MISS };
            return RayResult {
                hit: true,
                pe: e.pe,
                list_pos: f.k.min(u16::MAX as usize) as u16,
                t: f.t,
                prim: words[1],
                material: words[2] as u16,
                tests: 0,
                normal: crate::isect::analytic::normal(words, ray, f.t).map(canonical_nan),
                cycles: 0,
            };
        }
        let Some(words) = record_at::<TRIANGLE_WORDS>(self.mem, f.rec) else { return RayResult::MISS };
        let n = geometric_normal(&record(words));
        RayResult {
            hit: true,
            pe: e.pe,
            list_pos: f.k.min(u16::MAX as usize) as u16,
            t: f.t,
            prim: words[9],
            material: words[10] as u16,
            tests: 0,
            normal: [n.x, n.y, n.z].map(canonical_nan),
            cycles: 0,
        }
    }
}
