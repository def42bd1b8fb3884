//! The PE array: loading and clearing PE memories (with the kernels' load-time record
//! tables) and the timed trace of one ray (search, PE timeline, counters).

use gridrt_shared::fsl::{FslError, ListEntry, RayKind, RayResult};
use gridrt_shared::math::Ray;
use gridrt_shared::scene::{MAX_PES, TRIANGLE_WORDS};

use super::image::{record, record_at, span, span_mut, validate_image, PeSlot};
use super::observe::PeReadObserver;
use super::pe_cache::{ExecSource, PeCacheTiming, PE_CACHE_MAX_PES};
use super::search::{Found, Numerics, View};
use super::stats::CoprocStats;
use crate::config::{ArbitrationRule, CoprocConfig, LIST_CAPACITY};
use crate::isect::{with_kernel, Kernel, RecordStatus};
use crate::numeric::FixedFrame;
use crate::timing::PeTimeline;

/// PE memory: the co-processor's own, or a read-only share of it (a [`super::RayPort`]).
pub(super) trait PeMem {
    /// Every PE's words.
    fn words(&self) -> &[u32];
    /// Every PE's words for a LOAD; `None` when the memory is shared read-only.
    fn words_mut(&mut self) -> Option<&mut [u32]>;
}

impl PeMem for &mut [u32] {
    fn words(&self) -> &[u32] {
        self
    }
    fn words_mut(&mut self) -> Option<&mut [u32]> {
        Some(self)
    }
}

impl PeMem for &[u32] {
    fn words(&self) -> &[u32] {
        self
    }
    fn words_mut(&mut self) -> Option<&mut [u32]> {
        None
    }
}

/// The PE array: configuration, memories, image slots, clocks and counters (everything but
/// the link buffers, so a buffered list can be traced in place).
pub(super) struct Pes<M> {
    pub(super) cfg: CoprocConfig,
    pub(super) mem: M,
    pub(super) slots: [PeSlot; MAX_PES],
    pub(super) loaded_pes: u16,
    pub(super) rule: ArbitrationRule,
    pub(super) numerics: Numerics,
    pub(super) clocks: [u64; MAX_PES],
    pub(super) stats: CoprocStats,
    /// The PE caches' timing model (`Coprocessor::with_pe_caches`), and its tags: words of
    /// the caller's backing after the PE memories (empty without caches).
    pub(super) cache: Option<PeCacheTiming>,
    pub(super) tags: M,
}

impl<M: PeMem> Pes<M> {
    pub(super) fn view(&self) -> View<'_> {
        let numerics = self.numerics;
        View {
            cfg: &self.cfg,
            mem: self.mem.words(),
            slots: &self.slots,
            loaded_pes: self.loaded_pes,
            rule: self.rule,
            numerics,
        }
    }

    pub(super) fn base(&self, pe: u8) -> usize {
        // pe < pe_count and pe_count · pe_mem_words fits the backing: never saturates.
        (pe as usize).saturating_mul(self.cfg.pe_mem_words as usize)
    }

    /// Marks `pe` empty (start of a LOAD).
    pub(super) fn begin_load(&mut self, pe: u8) {
        if let Some(slot) = self.slots.get_mut(pe as usize) {
            if slot.loaded {
                self.loaded_pes = self.loaded_pes.saturating_sub(1);
            }
            *slot = PeSlot::default();
        }
    }

    /// Validates the `len` words already written at `pe`'s base, builds the kernel's record
    /// table after them if it needs one (module doc), and installs them.
    pub(super) fn finish_load(&mut self, pe: u8, len: usize) -> Result<(), FslError> {
        let base = self.base(pe);
        let image = span(self.mem.words(), base, len).ok_or(FslError::PeMemoryOverflow)?;
        let slot = validate_image(image).ok_or(FslError::PeImageMalformed)?;
        with_kernel!(self.cfg.kernel, self.numerics.format, K => {
            if !K::TESTS_PRIMITIVES && slot.prims > 0 {
                return Err(FslError::Unsupported);
            }
            if !K::USES_IMAGE {
                self.build_records::<K>(base, &slot)?;
            }
        });
        let dst = self.slots.get_mut(pe as usize).ok_or(FslError::PeOutOfRange)?;
        *dst = slot;
        if let (Some(c), Some(tags)) = (self.cache.as_mut(), self.tags.words_mut()) {
            let before = c.counters();
            if let Some(image) = span(self.mem.words(), base, len) {
                c.load(tags, pe, image);
            }
            add_counters(&mut self.stats, before, c.counters());
        }
        self.loaded_pes = self.loaded_pes.saturating_add(1);
        self.stats.loads = self.stats.loads.saturating_add(1);
        let t = &self.cfg.timing;
        // Header, count and `len` image words in, the ACK out.
        let cycles = (len as u64)
            .saturating_add(2)
            .saturating_mul(t.word_in_cycles as u64)
            .saturating_add(t.word_out_cycles as u64);
        self.stats.cycles = self.stats.cycles.saturating_add(cycles);
        Ok(())
    }

    /// Precomputes kernel `K`'s record of every triangle of the image at `base` into PE
    /// memory right after the image, charged against `pe_mem_words`.
    fn build_records<K: Kernel>(&mut self, base: usize, slot: &PeSlot) -> Result<(), FslError> {
        let tris = slot.tris as usize;
        let rec_off = slot.len as usize;
        let need = tris.checked_mul(K::RECORD_WORDS).and_then(|n| n.checked_add(rec_off));
        if need.is_none_or(|n| n > self.cfg.pe_mem_words as usize) {
            return Err(FslError::PeMemoryOverflow);
        }
        let frame = self.numerics.frame;
        // `need` fits pe_mem_words, so none of these offsets saturates; a saturated one would
        // fail the checked access below.
        let tri_base = base.saturating_add(slot.tri_off as usize);
        let rec_base = base.saturating_add(rec_off);
        for i in 0..tris {
            let src = tri_base.saturating_add(i.saturating_mul(TRIANGLE_WORDS));
            let words = record_at(self.mem.words(), src).ok_or(FslError::PeImageMalformed)?;
            let (tri, prim) = (record(words), words.get(9).copied().unwrap_or(0));
            let dst = rec_base.saturating_add(i.saturating_mul(K::RECORD_WORDS));
            let mem = self.mem.words_mut().ok_or(FslError::Unsupported)?;
            let out = span_mut(mem, dst, K::RECORD_WORDS).ok_or(FslError::PeMemoryOverflow)?;
            let status = K::precompute(&tri, &frame, out);
            if K::PRIM_IN_RECORD {
                if let Some(last) = out.last_mut() {
                    *last = prim;
                }
            }
            let counter = match status {
                RecordStatus::Ok => continue,
                RecordStatus::Degenerate => &mut self.stats.degenerate_records,
                RecordStatus::Overflow => &mut self.stats.overflow_records,
            };
            *counter = counter.saturating_add(1);
        }
        Ok(())
    }

    pub(super) fn clear(&mut self) {
        self.slots = [PeSlot::default(); MAX_PES];
        self.loaded_pes = 0;
        self.cache_other_packet();
    }

    /// A packet without PE-memory traffic, for the PE caches' timing (after a reset, the
    /// cycle that starts the tag clear).
    fn cache_other_packet(&mut self) {
        if let (Some(c), Some(tags)) = (self.cache.as_mut(), self.tags.words_mut()) {
            let before = c.counters();
            c.other_packet(tags);
            add_counters(&mut self.stats, before, c.counters());
        }
    }

    /// FRAME: the frame of the box for the number format in force (`FixedFrame::for_box`;
    /// the box passed `check_frame_box`), and every PE empty (records depend on the frame).
    pub(super) fn set_frame_box(&mut self, min: [f32; 3], max: [f32; 3]) {
        if let Some(frame) = FixedFrame::for_box(min, max, self.numerics.format) {
            self.numerics.frame = frame;
        }
        self.clear();
    }

    /// The timed path: validation, functional search, PE timeline, statistics; `obs` is told
    /// every PE-memory read ([`NoObserver`](super::observe::NoObserver) for none).
    pub(super) fn trace_timed_observed<O: PeReadObserver>(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
        obs: &mut O,
    ) -> Result<RayResult, (FslError, u16)> {
        self.view().validate(ray, t_max, list)?;
        Ok(self.trace_validated_observed(kind, ray, t_max, list, obs))
    }

    /// [`trace_timed_observed`](Self::trace_timed_observed) of a request that passed `View::validate` (the link
    /// checks every word of a packet as it arrives: the same checks), telling `obs` every
    /// PE-memory read of the ray (`observe` module doc; the result and counters do not
    /// depend on it).
    pub(super) fn trace_validated_observed<O: PeReadObserver>(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
        obs: &mut O,
    ) -> RayResult {
        let numerics = self.numerics;
        let view = View {
            cfg: &self.cfg,
            mem: self.mem.words(),
            slots: &self.slots,
            loaded_pes: self.loaded_pes,
            rule: self.rule,
            numerics,
        };
        let (found, info) = view.search_dyn(kind, ray, t_max, list);
        let mut result = view.result_of(list, found, ray);

        // Timeline (module doc of `timing`): pass 1 finds the completion time T of entries
        // 0..=w, pass 2 charges the tests every entry had started by T. Every entry is
        // scheduled with all its tests (a PE does not know a RAY_ANY hit before its result
        // comes out); the winner is done when the result of its last needed test is known.
        // Each entry's test count, looked up once for both passes (a heapless vector: no
        // zeroing of the whole capacity per ray). `list` fits: the request checks hold it
        // to `max_list` ≤ LIST_CAPACITY.
        let mut counts: heapless::Vec<u32, LIST_CAPACITY> = heapless::Vec::new();
        for e in list {
            let _ = counts.push(view.lookup_observed(e.pe, e.voxel, obs).map_or(0, |r| r.count));
        }
        let last = found.map_or(list.len(), |f| f.k.saturating_add(1));
        let profile = self.cfg.timing;
        for e in list {
            if let Some(c) = self.clocks.get_mut(e.pe as usize) {
                *c = 0;
            }
        }
        let mut end = 0u64;
        {
            let mut tl = PeTimeline::new(&profile, &mut self.clocks);
            for (k, (e, &n)) in list.iter().zip(&counts).enumerate().take(last) {
                let at = tl.schedule(e.pe, n);
                let done = match found {
                    Some(f) if f.k == k && f.tests_in_entry < n => tl.done_after(at, f.tests_in_entry),
                    _ => at.done,
                };
                end = end.max(done);
            }
        }
        for e in list {
            if let Some(c) = self.clocks.get_mut(e.pe as usize) {
                *c = 0;
            }
        }
        let mut tests = 0u64;
        {
            let mut tl = PeTimeline::new(&profile, &mut self.clocks);
            for (e, &n) in list.iter().zip(&counts) {
                let at = tl.schedule(e.pe, n);
                let started = tl.started_before(at, n, end);
                tests = tests.saturating_add(started as u64);
                if O::ACTIVE {
                    view.observe_tests(e, started, obs);
                }
            }
        }
        if O::ACTIVE {
            view.observe_result(list, found, obs);
        }
        if let (Some(c), Some(tags)) = (self.cache.as_mut(), self.tags.words_mut()) {
            let before = c.counters();
            cache_ray(c, tags, &view, (kind, ray, t_max), list, found, end);
            add_counters(&mut self.stats, before, c.counters());
        }
        let cycles = profile.ray_io_cycles(list.len()).saturating_add(end);
        result.tests = tests.min(u16::MAX as u64) as u16;
        result.cycles = cycles.min(u32::MAX as u64) as u32;
        let s = &mut self.stats;
        s.rays = s.rays.saturating_add(1);
        s.hits = s.hits.saturating_add(result.hit as u64);
        s.tests = s.tests.saturating_add(tests);
        s.cycles = s.cycles.saturating_add(cycles);
        s.overflows = s.overflows.saturating_add(info.overflows);
        obs.ray_end(&result);
        result
    }
}

/// Adds what the PE caches counted since `before` to the model's counters.
fn add_counters(stats: &mut CoprocStats, before: (u64, u64, u64), now: (u64, u64, u64)) {
    stats.pe_stall_cycles = stats.pe_stall_cycles.saturating_add(now.0.saturating_sub(before.0));
    stats.pe_mem_reads = stats.pe_mem_reads.saturating_add(now.1.saturating_sub(before.1));
    stats.pe_mem_writes = stats.pe_mem_writes.saturating_add(now.2.saturating_sub(before.2));
}

/// A ray's list as the PEs' issue loops see it (`pe_cache::ExecSource`).
struct RayExec<'v, 'a> {
    view: &'v View<'a>,
    list: &'v [ListEntry],
    refs: &'v [(u32, u32)],
}

impl ExecSource for RayExec<'_, '_> {
    fn len(&self) -> usize {
        self.list.len()
    }

    fn entry(&self, k: usize) -> (u8, u32, u32) {
        let pe = self.list.get(k).map_or(0, |e| e.pe);
        let (first, n) = self.refs.get(k).copied().unwrap_or((0, 0));
        (pe, first, n)
    }

    fn ref_word(&self, pe: u8, addr: u32) -> u32 {
        let at = (pe as usize).saturating_mul(self.view.cfg.pe_mem_words as usize).saturating_add(addr as usize);
        self.view.mem.get(at).copied().unwrap_or(0)
    }
}

/// One validated ray through the PE caches' timing model: the voxel lookups, the
/// execution until the stop (decision at `end`), the result stage's reads, and the result
/// stage's leftovers the next rays read (`pe_cache` module doc).
fn cache_ray(
    c: &mut PeCacheTiming,
    tags: &mut [u32],
    view: &View<'_>,
    (kind, ray, t_max): (RayKind, &Ray, f32),
    list: &[ListEntry],
    found: Option<Found>,
    end: u64,
) {
    let mut refs: heapless::Vec<(u32, u32), LIST_CAPACITY> = heapless::Vec::new();
    for e in list {
        let mut probes = heapless::Vec::<u32, 32>::new();
        let matched = view.lookup_probes(e.pe, e.voxel, &mut probes);
        c.lookup(tags, e.pe, &probes, matched);
        let _ = refs.push(view.entry_refs(e));
    }
    let winner = found.and_then(|f| view.winner_tri(list, f));
    // Entry 0's result (the result memory's word the result stage reads on a miss): the
    // winner's triangle if it won, else the PE's last Closest take before this ray.
    if let (Some(e0), Some(&(_, n0))) = (list.first(), refs.first()) {
        c.ent_pe0 = e0.pe;
        if n0 > 0 {
            let tri = match (found, winner) {
                (Some(f), Some((_, tri))) if f.k == 0 => tri,
                _ => c.best_tri(tags, e0.pe),
            };
            c.set_res_tri0(tags, e0.pe, tri);
        }
    }
    // Closest takes after this ray: the winner's entry, and the later entries' tests
    // whose results came before the stop (issued by end - 70).
    if let (RayKind::Closest, Some(f)) = (kind, found) {
        let mut clocks = [0u64; PE_CACHE_MAX_PES];
        let mut best: [(bool, f32, u32); PE_CACHE_MAX_PES] = [(false, 0.0, 0); PE_CACHE_MAX_PES];
        let mut last_take: [Option<u32>; PE_CACHE_MAX_PES] = [None; PE_CACHE_MAX_PES];
        for (k, (e, &(_, n))) in list.iter().zip(refs.iter()).enumerate() {
            let Some(clock) = clocks.get_mut(e.pe as usize) else { continue };
            let first_issue = clock.saturating_add(4);
            *clock = first_issue.saturating_add(4u64.saturating_mul(n as u64));
            if k < f.k || n == 0 {
                continue;
            }
            let m = if k == f.k {
                n
            } else if end >= first_issue.saturating_add(70) {
                let m = (end.saturating_sub(70).saturating_sub(first_issue) / 4).saturating_add(1);
                m.min(n as u64) as u32
            } else {
                0
            };
            let (Some(b), Some(taken)) = (best.get_mut(e.pe as usize), last_take.get_mut(e.pe as usize)) else {
                continue;
            };
            let mut j = 0u32;
            view.each_test(ray, t_max, e, m, &mut |tri, acc| {
                let last = j.saturating_add(1) == n;
                j = j.saturating_add(1);
                let take = acc.is_some_and(|(t, prim)| !b.0 || t < b.1 || (t == b.1 && prim < b.2));
                if last {
                    b.0 = false;
                } else if let (true, Some((t, prim))) = (take, acc) {
                    *b = (true, t, prim);
                    *taken = Some(tri);
                }
            });
        }
        for (pe, t) in last_take.iter().enumerate() {
            if let Some(tri) = *t {
                c.set_best_tri(tags, pe as u8, tri);
            }
        }
    }
    let (win_pe, win_tri) = match winner {
        Some(w) => w,
        None => (c.ent_pe0, c.res_tri0(tags, c.ent_pe0)),
    };
    let src = RayExec { view, list, refs: &refs };
    c.execute(tags, &src, end, win_pe, win_tri);
}
