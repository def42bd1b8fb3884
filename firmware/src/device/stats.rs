//! Frame statistics and stage timing: the counters a frame reports in `Msg::Stats`
//! ([`FrameStats`], SPEC.md §3.9 and §3.13), the stages they are charged to ([`Stage`]), the
//! clocks that time them ([`StageClock`]: `mcycle`/`minstret`, a board timer, or nothing)
//! and the stopwatch the pixel loop laps.

use gridrt_shared::msg::{stat, STAT_ENTRY_LEN, STAT_HARTS};

/// A pair of free-running counters read at stage boundaries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageCount {
    /// Clock cycles (`mcycle`).
    pub cycles: u64,
    /// Instructions retired (`minstret`).
    pub instret: u64,
}

impl StageCount {
    #[inline(always)]
    fn add(&mut self, d: StageStamp) {
        self.cycles = self.cycles.wrapping_add(u64::from(d.cycles));
        self.instret = self.instret.wrapping_add(u64::from(d.instret));
    }
}

/// The low 32 bits of both counters: what a stage lap reads (one CSR read each on RV32,
/// where a consistent 64-bit read is a three-instruction retry loop). A lap charges the
/// wrapping difference of two stamps, which is exact while a lap lasts fewer than 2^31
/// cycles (43 s at 50 MHz; [`Stopwatch`] sums laps in 32 bits): the pixel loop laps at
/// least once per pixel, and a pixel's work is bounded (lists ≤ 765 entries, ≤ 8 bounces,
/// every link wait ≤ `DEFAULT_POLLS` polls).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageStamp {
    /// Low word of `mcycle`.
    pub cycles: u32,
    /// Low word of `minstret`.
    pub instret: u32,
}

impl StageStamp {
    #[inline(always)]
    fn since(self, earlier: Self) -> Self {
        Self { cycles: self.cycles.wrapping_sub(earlier.cycles), instret: self.instret.wrapping_sub(earlier.instret) }
    }
}

/// Instructions a [`StageClock`] leaves out of every stage because they are not the
/// firmware's, counted from an arbitrary origin (take differences). The emulated board runs
/// the co-processor model on the soft-core behind a timed link: `model` is what ran inside
/// its counter reads (the model and the call into it), `link_wrapper` the timed link's own
/// instructions outside them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExcludedWork {
    /// Instructions inside the excluded calls.
    pub model: u64,
    /// Instructions of the link wrapper outside them.
    pub link_wrapper: u64,
}

/// Source of [`StageStamp`]s (RISC-V `mcycle`/`minstret`, a board timer, or nothing).
///
/// `Clone`: a frame's UART writer reads its own copy ([`FrameWriter`]); a copy reads the same
/// counters.
pub trait StageClock: Clone {
    /// Current counter values (low words).
    fn now(&self) -> StageStamp;

    /// What this clock excludes from the stages so far (nothing for a plain hart).
    fn excluded(&self) -> ExcludedWork {
        ExcludedWork::default()
    }
}

/// The UART writer of a frame's pixels: counts the bytes and stamps the first one, so that
/// the frame's link time ([`FrameStats::link_cycles`]) is measured on the board's own clock.
pub(super) struct FrameWriter<'a, W: ?Sized, C> {
    out: &'a mut W,
    clock: C,
    /// The clock when the first byte was handed to the UART.
    pub(super) first: Option<StageStamp>,
    /// Bytes handed to the UART.
    pub(super) bytes: u64,
}

impl<'a, W: embedded_io::Write + ?Sized, C: StageClock> FrameWriter<'a, W, C> {
    pub(super) fn new(out: &'a mut W, clock: C) -> Self {
        Self { out, clock, first: None, bytes: 0 }
    }
}

impl<W: embedded_io::Write + ?Sized, C> embedded_io::ErrorType for FrameWriter<'_, W, C> {
    type Error = W::Error;
}

impl<W: embedded_io::Write + ?Sized, C: StageClock> embedded_io::Write for FrameWriter<'_, W, C> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        if self.first.is_none() && !buf.is_empty() {
            self.first = Some(self.clock.now());
        }
        let n = self.out.write(buf)?;
        count(&mut self.bytes, n as u64);
        Ok(n)
    }

    /// Blocks until the UART has sent everything (its transmit FIFO drained).
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.out.flush()
    }
}

/// Cycles from `earlier` to `later` (low words: exact below 2^32 cycles, 85 s at 50 MHz).
pub(super) fn cycles_between(earlier: StageStamp, later: StageStamp) -> u64 {
    u64::from(later.cycles.wrapping_sub(earlier.cycles))
}

/// A clock that always reads zero: stage counters stay 0 and cost nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoClock;

impl StageClock for NoClock {
    #[inline(always)]
    fn now(&self) -> StageStamp {
        StageStamp::default()
    }
}

/// Adapter from a board [`crate::bsp::CycleCounter`] to a [`StageClock`].
#[derive(Debug, Clone, Copy, Default)]
pub struct CounterClock<T>(pub T);

impl<T: crate::bsp::CycleCounter + Clone> StageClock for CounterClock<T> {
    #[inline(always)]
    fn now(&self) -> StageStamp {
        let (instret, cycles) = self.0.instret_cycles_lo();
        StageStamp { instret, cycles }
    }
}

/// Pipeline stages with their own cycle/instruction counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Camera ray generation, and the frame's setup for it (camera, spans, occupancy mask).
    RayGen,
    /// 3D-DDA and list building.
    Traverse,
    /// FSL puts and gets (including waiting for the co-processor).
    FslIo,
    /// Shading (and building shadow rays).
    Shade,
    /// Span packing, frame encoding and UART writes.
    Encode,
}

impl Stage {
    /// All stages in key order.
    pub const ALL: [Stage; 5] = [Stage::RayGen, Stage::Traverse, Stage::FslIo, Stage::Shade, Stage::Encode];

    /// Index 0..5.
    pub const fn index(self) -> usize {
        self as usize
    }
    /// Stats key of this stage's instruction count: `STAGE_BASE + 2·stage`.
    #[allow(clippy::arithmetic_side_effects)] // stage < 5: the key stays below 0x4A
    pub const fn instret_key(self) -> u8 {
        stat::STAGE_BASE + 2 * self as u8
    }
    /// Stats key of this stage's cycle count: `STAGE_BASE + 2·stage + 1`.
    #[allow(clippy::arithmetic_side_effects)] // stage < 5: the key stays below 0x4A
    pub const fn cycles_key(self) -> u8 {
        stat::STAGE_BASE + 2 * self as u8 + 1
    }
}

/// Adds `n` to a frame counter. Wrapping, as release arithmetic always was: a u64 counter
/// cannot wrap within a frame, and the soft-core pays no saturation check per FSL word.
#[inline(always)]
pub(super) fn count(counter: &mut u64, n: u64) {
    *counter = counter.wrapping_add(n);
}

/// Counters of the last rendered frame (sent as `Msg::Stats`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Camera rays generated (one per pixel).
    pub primary_rays: u64,
    /// Shadow rays generated (lit hits with shadows on), culled ones included.
    pub shadow_rays: u64,
    /// Ray requests sent to the co-processor (all kinds; a camera ray whose list went in two
    /// parts, `RayPath::trace_as`, sent two).
    pub coproc_rays: u64,
    /// Rays whose list was empty (missed the grid box or crossed only empty voxels): sent
    /// nothing. `primary_rays + shadow_rays ≤ coproc_rays + culled_rays` on a full frame,
    /// the difference being the second parts.
    pub culled_rays: u64,
    /// FSL words put (ray requests only; scene loads are not counted).
    pub fsl_words_out: u64,
    /// FSL words got.
    pub fsl_words_in: u64,
    /// Traversal-list entries sent.
    pub list_entries: u64,
    /// Sum of the `tests` field of every result.
    pub intersection_tests: u64,
    /// Sum of the `cycles` field of every result.
    pub coproc_cycles: u64,
    /// Pixels sent.
    pub pixels: u64,
    /// Per-stage counters, indexed by [`Stage::index`].
    pub stages: [StageCount; 5],
    /// Mirror-reflection rays generated.
    pub reflection_rays: u64,
    /// Pixels filled by row interpolation.
    pub interpolated_pixels: u64,
    /// Centre pixels traced after a failed interpolation test.
    pub interp_retraces: u64,
    /// The pipeline plan followed (`render_flags` bits).
    pub plan: u64,
    /// FSL words (both directions) of primary rays.
    pub fsl_words_primary: u64,
    /// FSL words (both directions) of shadow rays.
    pub fsl_words_shadow: u64,
    /// FSL words (both directions) of reflection rays.
    pub fsl_words_reflection: u64,
    /// Instructions the stage clock excluded as the co-processor model's ([`ExcludedWork`]).
    pub model_instructions: u64,
    /// Instructions the stage clock excluded as the link wrapper's ([`ExcludedWork`]).
    pub link_wrapper_instructions: u64,
    /// Cycles from the request's arrival to the frame's pixels drained from the UART.
    pub frame_cycles: u64,
    /// Cycles from the frame's first pixel byte written to the UART to that drain.
    pub link_cycles: u64,
    /// Bytes written to the UART in that span.
    pub frame_tx_bytes: u64,
    /// Where each hart's time went, in a frame shared by several harts (all zero otherwise).
    pub harts: [HartWork; MAX_FRAME_HARTS],
    /// What loading the current scene cost (all zero without a cycle counter).
    pub upload: UploadWork,
}

/// The cycles of the upload that loaded the current scene (`stat::UPLOAD_CYCLES`,
/// `UPLOAD_FEED_CYCLES`, `UPLOAD_PARSE_CYCLES`), each the sum of laps shorter than 2^32
/// cycles: one UART batch or the wait before it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UploadWork {
    /// From the batch holding `SceneBegin` to the batch completing the upload.
    pub cycles: u64,
    /// Of those, inside the device's input handling.
    pub feed_cycles: u64,
    /// Of the feed cycles, inside the scene parser and loader.
    pub parse_cycles: u64,
}

/// Harts a frame's per-hart counters cover (the keys' `STAT_HARTS`).
pub const MAX_FRAME_HARTS: usize = STAT_HARTS as usize;

/// One hart's share of a frame (`stat::HART_ROWS_BASE`, `HART_BUSY_BASE`, `HART_WAIT_BASE`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HartWork {
    /// Rows it traced.
    pub rows: u64,
    /// Cycles it spent tracing them.
    pub busy_cycles: u64,
    /// Cycles it waited (the first hart for the next row, a worker for a free row slot).
    pub wait_cycles: u64,
}

/// Stats entries of the pipeline plan (SPEC.md §3.13), the excluded work and the frame's
/// timing (§3.8), after the per-stage counters.
const PLAN_STATS: usize = 12;

/// Number of entries in a `Msg::Stats` (of a frame one hart traced).
pub const STAT_COUNT: usize = 10 + 2 * Stage::ALL.len() + PLAN_STATS;

/// Entries of [`FrameStats::upload_entries`].
const UPLOAD_STATS: usize = 3;

/// Bytes of the longest `Msg::Stats` entries: [`STAT_COUNT`], three per hart and the upload's.
pub const MAX_STATS_BYTES: usize = (STAT_COUNT + 3 * MAX_FRAME_HARTS + UPLOAD_STATS) * STAT_ENTRY_LEN;

impl FrameStats {
    /// Adds every counter of `o` (all but `plan`) to this one's, as if this frame had also
    /// done `o`'s work.
    pub fn accumulate(&mut self, o: &FrameStats) {
        let FrameStats {
            primary_rays,
            shadow_rays,
            coproc_rays,
            culled_rays,
            fsl_words_out,
            fsl_words_in,
            list_entries,
            intersection_tests,
            coproc_cycles,
            pixels,
            stages,
            reflection_rays,
            interpolated_pixels,
            interp_retraces,
            plan: _,
            fsl_words_primary,
            fsl_words_shadow,
            fsl_words_reflection,
            model_instructions,
            link_wrapper_instructions,
            frame_cycles,
            link_cycles,
            frame_tx_bytes,
            harts,
            upload: _,
        } = *o;
        count(&mut self.primary_rays, primary_rays);
        count(&mut self.shadow_rays, shadow_rays);
        count(&mut self.coproc_rays, coproc_rays);
        count(&mut self.culled_rays, culled_rays);
        count(&mut self.fsl_words_out, fsl_words_out);
        count(&mut self.fsl_words_in, fsl_words_in);
        count(&mut self.list_entries, list_entries);
        count(&mut self.intersection_tests, intersection_tests);
        count(&mut self.coproc_cycles, coproc_cycles);
        count(&mut self.pixels, pixels);
        for (s, d) in self.stages.iter_mut().zip(stages) {
            count(&mut s.cycles, d.cycles);
            count(&mut s.instret, d.instret);
        }
        count(&mut self.reflection_rays, reflection_rays);
        count(&mut self.interpolated_pixels, interpolated_pixels);
        count(&mut self.interp_retraces, interp_retraces);
        count(&mut self.fsl_words_primary, fsl_words_primary);
        count(&mut self.fsl_words_shadow, fsl_words_shadow);
        count(&mut self.fsl_words_reflection, fsl_words_reflection);
        count(&mut self.model_instructions, model_instructions);
        count(&mut self.link_wrapper_instructions, link_wrapper_instructions);
        count(&mut self.frame_cycles, frame_cycles);
        count(&mut self.link_cycles, link_cycles);
        count(&mut self.frame_tx_bytes, frame_tx_bytes);
        for (h, o) in self.harts.iter_mut().zip(harts) {
            count(&mut h.rows, o.rows);
            count(&mut h.busy_cycles, o.busy_cycles);
            count(&mut h.wait_cycles, o.wait_cycles);
        }
    }

    /// (key, value) pairs in the order they are sent.
    pub fn entries(&self) -> [(u8, u64); STAT_COUNT] {
        let mut e = [(0u8, 0u64); STAT_COUNT];
        let base = [
            (stat::PRIMARY_RAYS, self.primary_rays),
            (stat::SHADOW_RAYS, self.shadow_rays),
            (stat::COPROC_RAYS, self.coproc_rays),
            (stat::CULLED_RAYS, self.culled_rays),
            (stat::FSL_WORDS_OUT, self.fsl_words_out),
            (stat::FSL_WORDS_IN, self.fsl_words_in),
            (stat::INTERSECTION_TESTS, self.intersection_tests),
            (stat::COPROC_CYCLES, self.coproc_cycles),
            (stat::PIXELS, self.pixels),
            (stat::LIST_ENTRIES, self.list_entries),
        ];
        let stages = Stage::ALL
            .iter()
            .zip(self.stages)
            .flat_map(|(s, c)| [(s.instret_key(), c.instret), (s.cycles_key(), c.cycles)]);
        let plan = [
            (stat::REFLECTION_RAYS, self.reflection_rays),
            (stat::INTERPOLATED_PIXELS, self.interpolated_pixels),
            (stat::INTERP_RETRACES, self.interp_retraces),
            (stat::PLAN, self.plan),
            (stat::FSL_WORDS_PRIMARY, self.fsl_words_primary),
            (stat::FSL_WORDS_SHADOW, self.fsl_words_shadow),
            (stat::FSL_WORDS_REFLECTION, self.fsl_words_reflection),
            (stat::MODEL_INSTRUCTIONS, self.model_instructions),
            (stat::LINK_WRAPPER_INSTRUCTIONS, self.link_wrapper_instructions),
            (stat::FRAME_CYCLES, self.frame_cycles),
            (stat::LINK_CYCLES, self.link_cycles),
            (stat::FRAME_TX_BYTES, self.frame_tx_bytes),
        ];
        for (slot, v) in e.iter_mut().zip(base.into_iter().chain(stages).chain(plan)) {
            *slot = v;
        }
        e
    }

    /// The per-hart entries of a frame shared by several harts: for each hart that traced a
    /// row, its rows, busy and wait cycles (none on a frame one hart traced).
    pub fn hart_entries(&self) -> impl Iterator<Item = (u8, u64)> + '_ {
        let shared = self.harts.iter().skip(1).any(|h| h.rows > 0);
        (0u8..).zip(self.harts.iter()).filter(move |(_, w)| shared && w.rows > 0).flat_map(|(h, w)| {
            [
                (stat::HART_ROWS_BASE.wrapping_add(h), w.rows),
                (stat::HART_BUSY_BASE.wrapping_add(h), w.busy_cycles),
                (stat::HART_WAIT_BASE.wrapping_add(h), w.wait_cycles),
            ]
        })
    }

    /// The upload's entries, after an upload timed by a cycle counter (none otherwise).
    pub fn upload_entries(&self) -> impl Iterator<Item = (u8, u64)> {
        let u = self.upload;
        [
            (stat::UPLOAD_CYCLES, u.cycles),
            (stat::UPLOAD_FEED_CYCLES, u.feed_cycles),
            (stat::UPLOAD_PARSE_CYCLES, u.parse_cycles),
        ]
        .into_iter()
        .filter(move |_| u.cycles > 0)
    }

    /// The `entries` of `Msg::Stats`: each pair as its key byte and the value in little
    /// endian, [`entries`](Self::entries), [`hart_entries`](Self::hart_entries), then
    /// [`upload_entries`](Self::upload_entries); the first `len` bytes of the buffer.
    pub fn to_bytes(&self) -> ([u8; MAX_STATS_BYTES], usize) {
        let mut buf = [0u8; MAX_STATS_BYTES];
        let mut len = 0usize;
        let all = self.entries().into_iter().chain(self.hart_entries()).chain(self.upload_entries());
        for (chunk, (k, v)) in buf.chunks_exact_mut(STAT_ENTRY_LEN).zip(all) {
            if let Some((key, val)) = chunk.split_first_mut() {
                *key = k;
                val.copy_from_slice(&v.to_le_bytes());
            }
            len = len.wrapping_add(STAT_ENTRY_LEN);
        }
        (buf, len)
    }
}

/// Stage stopwatch: each lap charges the time since the previous lap to one stage.
///
/// Laps add into 32-bit sums per stage ([`StageStamp`]s), which go into the frame's 64-bit
/// counters at [`flush`](Self::flush) (the frame loop's end of every row) and whenever a sum
/// reaches 2^31: two 32-bit additions per lap where the 64-bit counters took two carries
/// and twice the loads and stores. With every lap below 2^31 cycles no sum wraps.
pub(super) struct Stopwatch {
    last: StageStamp,
    pending: [StageStamp; 5],
}

impl Stopwatch {
    /// A stopwatch whose first lap starts now.
    pub(super) fn start<C: StageClock>(clock: &C) -> Self {
        Self { last: clock.now(), pending: [StageStamp::default(); 5] }
    }

    /// Charges the time since the previous lap to `stage`.
    #[inline(always)]
    pub(super) fn lap<C: StageClock>(&mut self, clock: &C, stats: &mut FrameStats, stage: Stage) {
        let now = clock.now();
        let d = now.since(self.last);
        self.last = now;
        if let Some(p) = self.pending.get_mut(stage.index()) {
            p.cycles = p.cycles.wrapping_add(d.cycles);
            p.instret = p.instret.wrapping_add(d.instret);
            if (p.cycles | p.instret) >> 31 != 0 {
                self.flush(stats);
            }
        }
    }

    /// Adds the laps' sums into `stats` and starts them again from zero.
    #[cold]
    #[inline(never)]
    pub(super) fn flush(&mut self, stats: &mut FrameStats) {
        for (s, p) in stats.stages.iter_mut().zip(&mut self.pending) {
            s.add(core::mem::take(p));
        }
    }
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects, clippy::indexing_slicing)] // test sums in u64
mod tests {
    use super::{FrameStats, Stage, StageClock, StageStamp, Stopwatch};
    use core::cell::Cell;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A clock that reads what the test set.
    #[derive(Clone)]
    struct Scripted<'a>(&'a Cell<StageStamp>);

    impl StageClock for Scripted<'_> {
        fn now(&self) -> StageStamp {
            self.0.get()
        }
    }

    /// Laps of up to 2^31 − 1 cycles each, in any order of stages, flushed or not: the
    /// frame's counters equal the 64-bit sums of the laps (the 32-bit sums never wrap).
    #[test]
    fn laps_summed_in_32_bits_equal_the_64_bit_sums() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x1A95_0032);
        for round in 0..50 {
            let now = Cell::new(StageStamp { cycles: rng.gen(), instret: rng.gen() });
            let clock = Scripted(&now);
            let mut sw = Stopwatch::start(&clock);
            let mut stats = FrameStats::default();
            let mut want = [(0u64, 0u64); 5];
            let big = round % 2 == 0;
            for _ in 0..2_000 {
                let dc: u32 = if big { rng.gen_range(0..1 << 31) } else { rng.gen_range(0..5_000) };
                let di = rng.gen_range(0..=dc);
                let t = now.get();
                now.set(StageStamp { cycles: t.cycles.wrapping_add(dc), instret: t.instret.wrapping_add(di) });
                let stage = Stage::ALL[rng.gen_range(0..5)];
                sw.lap(&clock, &mut stats, stage);
                want[stage.index()].0 += u64::from(dc);
                want[stage.index()].1 += u64::from(di);
                if rng.gen_bool(0.01) {
                    sw.flush(&mut stats);
                }
            }
            sw.flush(&mut stats);
            for (s, (c, i)) in stats.stages.iter().zip(want) {
                assert_eq!((s.cycles, s.instret), (c, i), "round {round}");
            }
        }
    }
}
