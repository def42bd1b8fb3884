//! The co-processor: PE memories, the FSL word interface, arbitration and cycle accounting.
//!
//! Source: GridRT (Nery 2010) with its cross-voxel flaw fixed
//! (DESIGN.md §5, CONTRACTS.md "Ray queries"); packet formats from `gridrt_shared::fsl`.
//!
//! # Packets (host → co-processor)
//!
//! | packet | words | reply |
//! |---|---|---|
//! | LOAD_PE | `load_header(pe)`, word count N, N image words | [`load_ack`]`(pe)` |
//! | CLEAR | `CLEAR_WORD` | [`CLEAR_ACK`] |
//! | FRAME | `frame_packet(min, max)` (7 words): the grid box, which sets the fixed-point frame and empties every PE | [`FRAME_ACK`] |
//! | RAY_CLOSEST / RAY_ANY | `ray_request_head` (8), then 2 words per entry (`entry_words`) | 8 words of `RayResult::to_words` |
//!
//! The last word of every packet, and only it, carries the control bit; so does the last
//! word of every reply. A packet executes when its last word arrives (one packet in flight).
//!
//! # Errors
//!
//! Every violation is answered with exactly one word `FslError::to_word(detail)` with the
//! control bit, at the first word where it is detectable (content checks of a word precede
//! its framing check). If that word carried the control bit the packet is over; otherwise the
//! model discards words silently up to and including the next control word (resynchronising).
//!
//! | error | detected at | detail |
//! |---|---|---|
//! | UnknownOpcode | first word | the opcode (bits 31..28) |
//! | PacketTooShort | a control bit before the declared last word | index of that word in the packet |
//! | MissingControl | declared last word without control bit | its index |
//! | PeOutOfRange | LOAD header / list entry word 0 | the PE id |
//! | VoxelOutOfRange | direct API only: voxel id ≥ 2²⁴ (not encodable) | list position |
//! | VoxelNotLoaded | list entry word 0: voxel not in that PE's voxel table | list position |
//! | ListTooLong | ray header: count > `max_list` | `max_list` (the limit, SPEC §4.5) |
//! | PeMemoryOverflow | LOAD word count > `pe_mem_words` (nothing is buffered) | the PE id |
//! | PeImageMalformed | LOAD last word: `PeImage::parse` fails, voxel ids not strictly increasing, or a material > 65535 | the PE id |
//! | SceneNotLoaded | ray header while no PE holds a loaded image | 0 |
//! | NonFiniteRay | ray word 7 (origin/dir NaN/inf, dir zero, t_max NaN) or entry word 1 (t_exit NaN) | index of the offending word |
//! | BadFrame | FRAME word 6: a non-finite box word, or an axis with max < min | that word's index (4 + axis for an inverted axis) |
//! | Unsupported | LOAD last word, after the image checks: the kernel does not test the image's analytic primitives (watertight fixed64-q23) | the PE id |
//!
//! A LOAD that fails for any reason after its header named a valid PE leaves that PE empty.
//!
//! # Kernels, number formats and record tables
//!
//! Every PE runs `config.kernel` in the number format set by
//! [`Coprocessor::set_number_format`] (default f32). A (kernel, format) pair whose record is
//! not the image's own vertex words (`Kernel::USES_IMAGE`) gets its per-triangle records
//! precomputed at LOAD time into the PE's memory right after the image; the image plus
//! that table must fit `pe_mem_words` or the LOAD fails with `PeMemoryOverflow`
//! ([`crate::KernelKind::pe_words_needed`]; the scene image format does not change). The
//! precomputation is not charged in cycles (a hardware design would receive the records from
//! the host). Fixed-point range overflows are counted ([`CoprocStats::overflows`], per test;
//! [`CoprocStats::overflow_records`], per record at load) and such a test is a miss.
//!
//! # Arbitration (GridRT's flaw fixed)
//!
//! A hit at distance t in list entry k is accepted iff `t > 0` (each kernel reports only
//! t above its conservative lower bound), `t < t_max`, and `t ≤ t_exit(k)·(1 + 2⁻¹²)`
//! ([`T_EXIT_REL_TOL`]). The relative tolerance keeps a hit on the exit face of a voxel,
//! whose t and whose DDA t_exit were rounded independently (the firmware's DDA accumulates one
//! rounding per step; 2⁻¹² covers ~2000 of them), from being lost by both neighbours; its cost
//! is that a hit up to 2⁻¹²·t beyond a face can beat a hit in the next voxel that is nearer by
//! less than that. Within an entry the nearest accepted hit wins (ties: lowest prim id);
//! across entries the first entry in list order with an accepted hit wins. RAY_ANY returns the
//! first accepted hit in list order and, within its entry, in reference order, and stops.
//!
//! | module | concern | uses |
//! | --- | --- | --- |
//! | `stats` | [`CoprocStats`], [`TraceInfo`] | — |
//! | `image` | a loaded PE image: table offsets, the checks beyond `PeImage::parse`, vertices | — |
//! | `search` | one ray: request checks, the list search through the PE memories, arbitration, the result | `image`, `stats`, `observe` |
//! | `pes` | the PE array: LOAD (with record tables), CLEAR, the timed trace and its counters | `image`, `search`, `stats`, `observe`, `pe_cache` |
//! | `observe` | [`PeReadObserver`]: the PE-memory reads of a timed trace, for memory studies | — |
//! | `pe_cache` | the RTL's PE caches' stall cycles, cycle by cycle ([`Coprocessor::with_pe_caches`]) | — |
//! | `link` | the FSL word interface: packet receiver, resynchronisation, reply queue | `pes`, `search` |
//!
//! [`Coprocessor`] (this module) owns a `pes::Pes` and a `link::Link` and is the public API.
//! [`RayPort`] is a second `Link` over the same PE memories, shared read-only, so a simulator
//! can trace rays on several threads and get the co-processor's own answers.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

mod image;
mod link;
mod observe;
mod pe_cache;
mod pes;
mod search;
mod stats;

use gridrt_shared::fsl::{FslError, FslWord, ListEntry, RayKind, RayResult};
use gridrt_shared::math::Ray;
use gridrt_shared::scene::MAX_PES;

use crate::config::{ArbitrationRule, ConfigError, CoprocConfig};
use crate::numeric::{FixedFrame, NumberFormat};
use image::PeSlot;
use link::Link;
use pes::{PeMem, Pes};
use search::Numerics;

pub use link::{load_ack, CLEAR_ACK, FRAME_ACK};
pub use observe::{NoObserver, PeRead, PeReadKind, PeReadObserver};
pub use pe_cache::{PeCacheConfig, PE_CACHE_MAX_PES, PE_STATE_WORDS};
pub use search::T_EXIT_REL_TOL;
pub use stats::{CoprocStats, TraceInfo};

/// The co-processor model. Holds no allocation: PE memories live in the caller's `backing`.
pub struct Coprocessor<'m> {
    pes: Pes<&'m mut [u32]>,
    link: Link,
}

impl core::fmt::Debug for Coprocessor<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Coprocessor")
            .field("config", &self.pes.cfg)
            .field("loaded_pes", &self.pes.loaded_pes)
            .field("link", &self.link)
            .field("stats", &self.pes.stats)
            .finish_non_exhaustive()
    }
}

impl<'m> Coprocessor<'m> {
    /// A co-processor with every PE empty. `backing` must hold at least
    /// [`CoprocConfig::required_backing_words`] words (PE p owns words
    /// `p·pe_mem_words .. (p+1)·pe_mem_words`).
    pub fn new(config: CoprocConfig, backing: &'m mut [u32]) -> Result<Self, ConfigError> {
        config.validate()?;
        let need = config.required_backing_words();
        if backing.len() < need {
            return Err(ConfigError::BackingTooSmall { need, have: backing.len() });
        }
        let (mem, _) = backing.split_at_mut(need);
        Ok(Self::from_parts(config, mem, &mut [], None))
    }

    /// A co-processor whose PE memories sit behind the RTL's PE caches (`PE_CACHE = 1`,
    /// rtl/README.md §4.6): answers and `cycles` are those of [`Coprocessor::new`], and the
    /// counters also count the cycles the RTL stands still for its caches
    /// ([`CoprocStats::pe_stall_cycles`]) and its external memory's words. Exact for the
    /// `rtl` timing profile (4 PEs per pipeline) with the request words taken one per
    /// cycle, as the Verilator harness without `--stall` gives them. `backing` holds the PE
    /// memories, then the caches' tags and registers: [`CoprocConfig::required_backing_words`]
    /// + [`PeCacheConfig::state_words`] words. The caches start as after the RTL's reset.
    pub fn with_pe_caches(
        config: CoprocConfig,
        caches: PeCacheConfig,
        backing: &'m mut [u32],
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        caches.validate(&config)?;
        let mem_words = config.required_backing_words();
        let need = mem_words.saturating_add(caches.state_words(config.pe_count));
        if backing.len() < need {
            return Err(ConfigError::BackingTooSmall { need, have: backing.len() });
        }
        let (mem, rest) = backing.split_at_mut(mem_words);
        let (tags, _) = rest.split_at_mut(need.saturating_sub(mem_words));
        let timing = pe_cache::PeCacheTiming::new(caches, &config, tags);
        Ok(Self::from_parts(config, mem, tags, Some(timing)))
    }

    fn from_parts(
        config: CoprocConfig,
        mem: &'m mut [u32],
        tags: &'m mut [u32],
        cache: Option<pe_cache::PeCacheTiming>,
    ) -> Self {
        Self {
            pes: Pes {
                cfg: config,
                mem,
                slots: [PeSlot::default(); MAX_PES],
                loaded_pes: 0,
                rule: ArbitrationRule::default(),
                numerics: Numerics::default(),
                clocks: [0; MAX_PES],
                stats: CoprocStats::default(),
                cache,
                tags,
            },
            link: Link::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CoprocConfig {
        &self.pes.cfg
    }

    /// The arbitration rule in force (default [`ArbitrationRule::IntervalChecked`]).
    pub fn arbitration(&self) -> ArbitrationRule {
        self.pes.rule
    }

    /// Switches the arbitration rule (GridRT's original rule is for comparisons only).
    pub fn set_arbitration(&mut self, rule: ArbitrationRule) {
        self.pes.rule = rule;
    }

    /// The number format the PEs compute in (default [`NumberFormat::F32`]).
    pub fn number_format(&self) -> NumberFormat {
        self.pes.numerics.format
    }

    /// The fixed-point frame in force.
    pub fn fixed_frame(&self) -> FixedFrame {
        self.pes.numerics.frame
    }

    /// Selects the number format of every PE and, for the fixed-point formats, the frame that
    /// maps the scene into the format's box (`FixedFrame::for_box` of the grid box). Records
    /// depend on both, so this empties every PE like CLEAR: call it before loading.
    pub fn set_number_format(&mut self, format: NumberFormat, frame: FixedFrame) {
        self.pes.numerics = Numerics { format, frame };
        self.pes.clear();
    }

    /// The FRAME packet's effect (SPEC §4.6): the frame of the grid box `min..max` for the
    /// number format in force, and every PE empty. `Err(BadFrame)` for a non-finite or
    /// inverted box (then nothing changes).
    pub fn set_frame_box(&mut self, min: [f32; 3], max: [f32; 3]) -> Result<(), FslError> {
        link::check_frame_box(min, max).map_err(|_| FslError::BadFrame)?;
        self.pes.set_frame_box(min, max);
        Ok(())
    }

    /// Counters.
    pub fn stats(&self) -> &CoprocStats {
        &self.pes.stats
    }

    /// Zeroes the counters.
    pub fn reset_stats(&mut self) {
        self.pes.stats = CoprocStats::default();
    }

    /// True when PE `pe` holds a successfully loaded image.
    pub fn is_pe_loaded(&self, pe: u8) -> bool {
        self.pes.slots.get(pe as usize).is_some_and(|s| s.loaded)
    }

    /// The loaded image of PE `pe`, if any.
    pub fn pe_image(&self, pe: u8) -> Option<&[u32]> {
        let slot = self.pes.slots.get(pe as usize).filter(|s| s.loaded)?;
        let base = self.pes.base(pe);
        image::span(self.pes.mem.words(), base, slot.len as usize)
    }

    /// Number of PEs holding a loaded image.
    pub fn loaded_pes(&self) -> u16 {
        self.pes.loaded_pes
    }

    /// True while a packet is partly received (or being discarded after an error).
    pub fn in_packet(&self) -> bool {
        self.link.in_packet()
    }

    // ---------------------------------------------------------------- direct API

    /// Loads PE `pe` with an image (same validation as a LOAD_PE packet). On error the PE is
    /// left empty (if `pe` was in range).
    pub fn load_pe(&mut self, pe: u8, words: &[u32]) -> Result<(), FslError> {
        let r = self.load_pe_inner(pe, words);
        if r.is_err() {
            self.pes.stats.errors = self.pes.stats.errors.saturating_add(1);
        }
        r
    }

    fn load_pe_inner(&mut self, pe: u8, words: &[u32]) -> Result<(), FslError> {
        if pe as u16 >= self.pes.cfg.pe_count {
            return Err(FslError::PeOutOfRange);
        }
        self.pes.begin_load(pe);
        if words.len() > self.pes.cfg.pe_mem_words as usize {
            return Err(FslError::PeMemoryOverflow);
        }
        let base = self.pes.base(pe);
        let dst = image::span_mut(&mut self.pes.mem[..], base, words.len()).ok_or(FslError::PeMemoryOverflow)?;
        dst.copy_from_slice(words);
        self.pes.finish_load(pe, words.len())
    }

    /// Empties every PE (the CLEAR packet).
    pub fn clear(&mut self) {
        self.pes.clear();
    }

    /// Traces one ray with cycle accounting (same validation and semantics as a RAY packet;
    /// `result.cycles` includes the request and result words the packet would take).
    pub fn trace(&mut self, kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Result<RayResult, FslError> {
        self.trace_observed(kind, ray, t_max, list, &mut NoObserver)
    }

    /// [`Coprocessor::trace`] that tells `obs` every PE-memory read of the ray, in the order
    /// the PEs make them ([`PeReadObserver`]); result and counters are those of `trace`.
    pub fn trace_observed<O: PeReadObserver>(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
        obs: &mut O,
    ) -> Result<RayResult, FslError> {
        self.pes.trace_timed_observed(kind, ray, t_max, list, obs).map_err(|(e, _)| {
            self.pes.stats.errors = self.pes.stats.errors.saturating_add(1);
            e
        })
    }

    /// Traces one ray without the cycle timeline and without touching the counters: the same
    /// validation and intersection code as [`Coprocessor::trace`] (so the same hit), for the
    /// native benchmark. `tests` counts the tests performed (entries up to the winner);
    /// `cycles` is 0. Takes `&self`, so one loaded model can serve several threads.
    pub fn trace_untimed(
        &self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Result<RayResult, FslError> {
        self.trace_untimed_with_info(kind, ray, t_max, list).map(|(r, _)| r)
    }

    /// [`Coprocessor::trace_untimed`] that also returns the unsaturated test count and the
    /// tests whose fixed-point arithmetic overflowed (the bench's native path reports them).
    pub fn trace_untimed_with_info(
        &self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Result<(RayResult, TraceInfo), FslError> {
        let view = self.pes.view();
        view.validate(ray, t_max, list).map_err(|(e, _)| e)?;
        let (found, info) = view.search_dyn(kind, ray, t_max, list);
        let mut r = view.result_of(list, found, ray);
        r.tests = info.tests.min(u16::MAX as u64) as u16;
        Ok((r, info))
    }

    // ---------------------------------------------------------------- word interface

    /// Dequeues the next outbound word.
    pub fn pop(&mut self) -> Option<FslWord> {
        self.link.pop()
    }

    /// Outbound words waiting.
    pub fn out_len(&self) -> usize {
        self.link.out_len()
    }

    /// True when the output queue can take a full ray result; a driver modelling FSL
    /// back-pressure should stop pushing while this is false (words of replies that do not
    /// fit are dropped and counted in `CoprocStats::out_dropped`).
    pub fn can_push(&self) -> bool {
        self.link.can_push()
    }

    /// Consumes one inbound word; executes a packet when its last word arrives.
    pub fn push(&mut self, w: FslWord) {
        self.link.push(&mut self.pes, w);
    }

    /// [`Coprocessor::push`] that tells `obs` the PE-memory reads of a ray packet it executes
    /// ([`PeReadObserver`]); the reply words are those of `push`.
    pub fn push_observed<O: PeReadObserver>(&mut self, w: FslWord, obs: &mut O) {
        self.link.push_observed(&mut self.pes, w, obs);
    }

    /// A second word interface onto this co-processor's loaded PE memories, read-only, for
    /// tracing rays on several threads (see [`RayPort`]).
    pub fn ray_port(&self) -> RayPort<'_> {
        let p = &self.pes;
        RayPort {
            pes: Pes {
                cfg: p.cfg,
                mem: p.mem.words(),
                slots: p.slots,
                loaded_pes: p.loaded_pes,
                rule: p.rule,
                numerics: p.numerics,
                clocks: [0; MAX_PES],
                stats: CoprocStats::default(),
                cache: None,
                tags: &[],
            },
            link: Link::new(),
        }
    }
}

/// A word interface of its own onto a [`Coprocessor`]'s PE memories, which it shares
/// read-only: a ray packet gets the answer, word for word (cycles and test counts included),
/// that the co-processor itself would give, because a ray's trace depends only on the
/// packet, the loaded images, the number format and the arbitration rule, all of which the
/// port copies or borrows when it is made. Its counters are its own ([`RayPort::stats`]).
///
/// A port cannot change what the PEs hold: it answers LOAD_PE with
/// `FslError::Unsupported`; CLEAR and FRAME empty the port's own view of the PEs (its
/// later rays get `SceneNotLoaded`), never the co-processor's.
pub struct RayPort<'a> {
    pes: Pes<&'a [u32]>,
    link: Link,
}

impl core::fmt::Debug for RayPort<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("RayPort").field("link", &self.link).field("stats", &self.pes.stats).finish_non_exhaustive()
    }
}

impl RayPort<'_> {
    /// Consumes one inbound word; executes a packet when its last word arrives.
    #[inline]
    pub fn push(&mut self, w: FslWord) {
        self.link.push(&mut self.pes, w);
    }

    /// Dequeues the next outbound word.
    #[inline]
    pub fn pop(&mut self) -> Option<FslWord> {
        self.link.pop()
    }

    /// This port's counters.
    pub fn stats(&self) -> &CoprocStats {
        &self.pes.stats
    }
}
