//! The device state machine: UART frames in → scene load over FSL → render → frames out.
//!
//! I/O agnostic: bytes arrive through [`Device::feed`], leave through an
//! [`embedded_io::Write`] (blocking `write_all`, e.g. a `crate::bsp` UART), the
//! co-processor is any [`FslLink`], and stage timing comes from a [`StageClock`]. The same code
//! runs on the soft-core, in host tests and in the loopback simulator.
//!
//! Data path of one pixel (DESIGN.md §4, GridRT seed 004 §1.4 with the extended request of
//! `shared::fsl`): camera ray → 3D-DDA list of non-empty voxels (an empty list sends nothing)
//! → put 8 head words + 2 words per entry, control bit on the last → get the 8 result words →
//! Lambert shading (+ an any-hit shadow ray, feature `shadows`) → pixel span.
//!
//! Every wait on the link is a bounded poll ([`FslLink::get`]/[`FslLink::put`]); a timeout, a
//! link error, an ERROR word or a malformed answer aborts the frame with `Msg::Error` and the
//! device goes back to waiting for frames. Nothing allocates.

use crate::text::TextOut;

use crate::camera::{Camera, CameraError};
use crate::dda::{build_list, GridDesc, TraversalList, MAX_GRID_DIM};
use crate::fsl::{BoundedError, FslLink, FslWord, LinkError, LinkErrorKind};
use crate::pixels::{FrameTx, SpanEncoder, TxError};
use crate::shade::{self, Light, DEFAULT_ALBEDO};
use embedded_io::Write;
use gridrt_shared::frame::{Crc32Digest, FeedResult, FrameAccumulator, FrameError, MAX_PAYLOAD};
use gridrt_shared::fsl::{self as wire, op, FslError, RayKind, RayResult, RESULT_WORDS};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::msg::{
    feature, region_options, render_flags, stat, DeviceInfo, ErrorCode, Msg, MsgError, MsgType, Region, RenderRequest,
    SceneStatus, MAX_ERROR_TEXT, STAT_ENTRY_LEN,
};
use gridrt_shared::scene::{
    LightingRecord, Material, MaterialModel, ObjectRecord, SceneError, SceneHeader, SceneSink, SceneStream, EMPTY_VOXEL,
};

/// A pair of free-running counters read at stage boundaries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageCount {
    /// Clock cycles (`mcycle`).
    pub cycles: u64,
    /// Instructions retired (`minstret`).
    pub instret: u64,
}

impl StageCount {
    fn since(self, earlier: Self) -> Self {
        Self { cycles: self.cycles.wrapping_sub(earlier.cycles), instret: self.instret.wrapping_sub(earlier.instret) }
    }
    fn add(&mut self, d: Self) {
        self.cycles = self.cycles.wrapping_add(d.cycles);
        self.instret = self.instret.wrapping_add(d.instret);
    }
}

/// Source of [`StageCount`]s (RISC-V `mcycle`/`minstret`, a board timer, or nothing).
pub trait StageClock {
    /// Current counter values.
    fn now(&self) -> StageCount;
}

/// A clock that always reads zero: stage counters stay 0 and cost nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoClock;

impl StageClock for NoClock {
    #[inline(always)]
    fn now(&self) -> StageCount {
        StageCount::default()
    }
}

/// Adapter from a board [`crate::bsp::CycleCounter`] to a [`StageClock`].
#[derive(Debug, Clone, Copy, Default)]
pub struct CounterClock<T>(pub T);

impl<T: crate::bsp::CycleCounter> StageClock for CounterClock<T> {
    #[inline]
    fn now(&self) -> StageCount {
        StageCount { cycles: self.0.cycles(), instret: self.0.instret() }
    }
}

/// Pipeline stages with their own cycle/instruction counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Camera ray generation.
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
    pub const fn instret_key(self) -> u8 {
        stat::STAGE_BASE + 2 * self as u8
    }
    /// Stats key of this stage's cycle count: `STAGE_BASE + 2·stage + 1`.
    pub const fn cycles_key(self) -> u8 {
        stat::STAGE_BASE + 2 * self as u8 + 1
    }
}

/// Counters of the last rendered frame (sent as `Msg::Stats`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Camera rays generated (one per pixel).
    pub primary_rays: u64,
    /// Shadow rays generated (lit hits with shadows on), culled ones included.
    pub shadow_rays: u64,
    /// Rays sent to the co-processor (all kinds).
    pub coproc_rays: u64,
    /// Rays whose list was empty (missed the grid box or crossed only empty voxels): sent
    /// nothing. `primary_rays + shadow_rays == coproc_rays + culled_rays` on a full frame.
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
    /// Mirror-reflection rays generated (scene image v2).
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
}

/// Stats entries of the pipeline plan (SPEC.md §3.13), after the per-stage counters.
const PLAN_STATS: usize = 7;

/// Number of entries in a `Msg::Stats`.
pub const STAT_COUNT: usize = 10 + 2 * Stage::ALL.len() + PLAN_STATS;

impl FrameStats {
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
        for (slot, v) in e.iter_mut().zip(base) {
            *slot = v;
        }
        for (i, s) in Stage::ALL.iter().enumerate() {
            let c = self.stages[i];
            if let Some(slot) = e.get_mut(10 + 2 * i) {
                *slot = (s.instret_key(), c.instret);
            }
            if let Some(slot) = e.get_mut(11 + 2 * i) {
                *slot = (s.cycles_key(), c.cycles);
            }
        }
        let plan = [
            (stat::REFLECTION_RAYS, self.reflection_rays),
            (stat::INTERPOLATED_PIXELS, self.interpolated_pixels),
            (stat::INTERP_RETRACES, self.interp_retraces),
            (stat::PLAN, self.plan),
            (stat::FSL_WORDS_PRIMARY, self.fsl_words_primary),
            (stat::FSL_WORDS_SHADOW, self.fsl_words_shadow),
            (stat::FSL_WORDS_REFLECTION, self.fsl_words_reflection),
        ];
        for (slot, v) in e.iter_mut().skip(10 + 2 * Stage::ALL.len()).zip(plan) {
            *slot = v;
        }
        e
    }
}

/// Largest material table the device holds.
pub const MAX_MATERIALS: usize = 64;

/// Largest accepted render width and height.
pub const MAX_IMAGE_DIM: u16 = 4096;

/// Default poll budget of every blocking FSL put/get (≈ 4 M polls: seconds on a 50 MHz
/// soft-core, far above the longest legitimate co-processor answer).
pub const DEFAULT_POLLS: u32 = 1 << 22;

/// Most stale words read back (and dropped) after an aborted ray, to resynchronise.
const DRAIN_WORDS: u32 = 4096;

/// Feature bits of this build.
pub const fn compiled_features() -> u32 {
    let shadows = if cfg!(feature = "shadows") { feature::SHADOWS } else { 0 };
    shadows
        | feature::PRIM_IDS
        | feature::RENDER_REGION
        | feature::RGB565
        | feature::RLE
        | pipeline::pipeline_features()
}

/// `Msg::Error` detail of a link timeout (distinct from any ERROR word, whose top nibble is 0xE).
pub const DETAIL_LINK_TIMEOUT: u32 = 0xFFFF_0001;
/// `Msg::Error` detail of a link hardware error.
pub const DETAIL_LINK_HARDWARE: u32 = 0xFFFF_0002;
/// `Msg::Error` detail of any other link error.
pub const DETAIL_LINK_OTHER: u32 = 0xFFFF_0003;

/// Offsets of the RenderRequest fields (`Msg::Error{BadRequest}` detail).
mod field {
    pub const WIDTH: u32 = 2;
    pub const HEIGHT: u32 = 4;
    pub const EYE: u32 = 8;
    pub const TARGET: u32 = 20;
    pub const UP: u32 = 32;
    pub const FOV: u32 = 44;
    pub const LIGHT_POS: u32 = 48;
    pub const LIGHT_INTENSITY: u32 = 60;
    pub const AMBIENT: u32 = 64;
    pub const ENCODING: u32 = 68;
    /// `RenderRegion`: region fields, then the embedded request at [`REGION_REQUEST`].
    pub const REGION_X0: u32 = 0;
    pub const REGION_Y0: u32 = 2;
    pub const REGION_REQUEST: u32 = 12;
}

/// Error text buffer (formatted details, ≤ `MAX_ERROR_TEXT`).
type Text = heapless::String<MAX_ERROR_TEXT>;

/// [`TextOut`] into a [`Text`] that keeps what fits (whole characters) instead of failing,
/// so a long detail never loses the whole message. (No `core::fmt` on the device: its
/// `write!` machinery costs KBs of the soft-core's code budget; `crate::text`.)
struct Trunc<'a>(&'a mut Text);

impl TextOut for Trunc<'_> {
    fn put(&mut self, s: &str) {
        // The longest prefix that fits and ends on a character boundary.
        let mut end = s.len().min(self.0.capacity() - self.0.len());
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        let _ = self.0.push_str(s.get(..end).unwrap_or(""));
    }
}

/// Why a frame or an upload stopped. Small and `Copy` so the per-ray `Result`s stay cheap;
/// the text is formatted only when the error is reported.
#[derive(Debug, Clone, Copy)]
enum Fail {
    /// The link failed (timeout, hardware) during `what`.
    Link(LinkErrorKind, &'static str),
    /// The co-processor answered `what` with this word (an ERROR word, or garbage).
    Word(u32, &'static str),
    /// Anything else, reported as is.
    Plain(ErrorCode, u32, &'static str),
    /// Writing to the output failed (already counted by the frame encoder): the frame
    /// stops and nothing more is sent for it, not even an `Error`, which would need the
    /// output that just failed.
    Output,
}

impl Fail {
    fn link<E: LinkError>(e: BoundedError<E>, what: &'static str) -> Self {
        Self::Link(e.kind(), what)
    }

    /// The failure of a frame's span or `Stats` that could not be sent.
    fn tx(e: TxError) -> Self {
        match e {
            TxError::Write(_) => Self::Output,
            TxError::Msg(_) | TxError::Frame(_) => Self::Plain(ErrorCode::BadRequest, 0, "frame encoder failure"),
        }
    }

    fn code_detail(self) -> (ErrorCode, u32) {
        match self {
            Self::Link(LinkErrorKind::Timeout, _) => (ErrorCode::Coprocessor, DETAIL_LINK_TIMEOUT),
            Self::Link(LinkErrorKind::Hardware, _) => (ErrorCode::Coprocessor, DETAIL_LINK_HARDWARE),
            Self::Link(_, _) => (ErrorCode::Coprocessor, DETAIL_LINK_OTHER),
            Self::Word(w, _) => (ErrorCode::Coprocessor, w),
            Self::Plain(c, d, _) => (c, d),
            Self::Output => (ErrorCode::BadRequest, 0),
        }
    }

    fn describe(self, t: &mut Text) {
        let mut w = Trunc(t);
        match self {
            Self::Link(kind, what) => {
                let why = match kind {
                    LinkErrorKind::Timeout => "timeout",
                    LinkErrorKind::Hardware => "hardware error",
                    _ => "error",
                };
                for s in ["FSL link ", why, " on ", what] {
                    w.put(s);
                }
            }
            Self::Word(word, what) if wire::opcode(word) == op::ERROR => {
                let (e, detail) = FslError::from_word(word);
                for s in ["co-processor error on ", what, ": ", e.as_str(), " (detail "] {
                    w.put(s);
                }
                w.put_dec(detail as u64);
                w.put(")");
            }
            Self::Word(word, what) => {
                w.put("unexpected word ");
                w.put_hex(word, 8);
                w.put(" on ");
                w.put(what);
            }
            Self::Plain(_, _, text) => w.put(text),
            Self::Output => w.put("output write error"),
        }
    }
}

/// The loaded scene as the device needs it for rendering.
struct SceneStore<const N: usize> {
    loaded: bool,
    grid: GridDesc,
    voxels: usize,
    voxel_pe: [u8; N],
    materials: heapless::Vec<Material, MAX_MATERIALS>,
    /// Shading models, parallel to `materials`.
    material_model: heapless::Vec<MaterialModel, MAX_MATERIALS>,
    /// Object table (prim id ranges, texture spaces).
    objects: heapless::Vec<ObjectRecord, MAX_OBJECTS>,
    /// Lighting record.
    lighting: LightingRecord,
}

/// Largest object table the device holds.
pub const MAX_OBJECTS: usize = 64;

/// An upload in progress.
struct Upload {
    stream: SceneStream,
    total_len: u32,
    crc: u32,
    digest: Crc32Digest,
    next: u32,
    /// Words of the current PE block still to forward (a block spans chunks).
    pe_words_left: u32,
}

/// [`SceneSink`] that stores the header, voxel map and materials and forwards PE blocks to
/// the co-processor as LOAD_PE packets.
struct Loader<'a, L: FslLink, const N: usize> {
    link: &'a mut L,
    store: &'a mut SceneStore<N>,
    info: &'a DeviceInfo,
    polls: u32,
    total_len: u32,
    words_left: &'a mut u32,
    /// Set when the co-processor or the link failed (the stream only sees `Rejected`).
    failure: Option<Fail>,
}

impl<L: FslLink, const N: usize> Loader<'_, L, N> {
    fn put(&mut self, word: FslWord, what: &'static str) -> Result<(), SceneError> {
        self.link.put(word, self.polls).map_err(|e| {
            self.failure = Some(Fail::link(e, what));
            SceneError::Rejected
        })
    }

    /// Reads the one-word answer to CLEAR / LOAD_PE: ACK, else the load fails.
    fn expect_ack(&mut self, what: &'static str) -> Result<(), SceneError> {
        match self.link.get(self.polls) {
            Ok(w) if wire::opcode(w.data) == op::ACK => Ok(()),
            Ok(w) => {
                self.failure = Some(Fail::Word(w.data, what));
                Err(SceneError::Rejected)
            }
            Err(e) => {
                self.failure = Some(Fail::link(e, what));
                Err(SceneError::Rejected)
            }
        }
    }
}

impl<L: FslLink, const N: usize> SceneSink for Loader<'_, L, N> {
    fn header(&mut self, h: &SceneHeader) -> Result<(), SceneError> {
        let dims = h.dims.map(u32::from);
        if dims.iter().any(|&d| d > MAX_GRID_DIM) || h.voxel_count() as usize > N {
            return Err(SceneError::GridTooLarge);
        }
        if h.material_count as usize > MAX_MATERIALS {
            return Err(SceneError::TooManyMaterials);
        }
        if h.total_len != self.total_len || (self.info.pe_count != 0 && h.pe_count > self.info.pe_count) {
            return Err(SceneError::BadHeader);
        }
        if self.info.pe_mem_words != 0 && h.pe_mem_words > self.info.pe_mem_words {
            return Err(SceneError::PeMemoryOverflow);
        }
        if h.object_count as usize > MAX_OBJECTS {
            return Err(SceneError::BadHeader);
        }
        self.store.grid = GridDesc { min: Vec3::from_array(h.bounds_min), max: Vec3::from_array(h.bounds_max), dims };
        self.store.voxels = h.voxel_count() as usize;
        self.store.voxel_pe.fill(EMPTY_VOXEL);
        self.store.materials.clear();
        self.store.material_model.clear();
        self.store.objects.clear();
        self.store.lighting = LightingRecord::default();
        // The co-processor's old scene goes now: CLEAR, then one LOAD_PE per block.
        self.put(FslWord::last(wire::CLEAR_WORD), "CLEAR")?;
        self.expect_ack("CLEAR")
    }

    fn voxel_map(&mut self, first: u32, owners: &[u8]) -> Result<(), SceneError> {
        let start = first as usize;
        let dst = self.store.voxel_pe.get_mut(start..start + owners.len()).ok_or(SceneError::GridTooLarge)?;
        dst.copy_from_slice(owners);
        Ok(())
    }

    fn material(&mut self, _index: u16, m: Material) -> Result<(), SceneError> {
        self.store.materials.push(m).map_err(|_| SceneError::TooManyMaterials)
    }

    fn material_model(&mut self, _index: u16, m: MaterialModel) -> Result<(), SceneError> {
        self.store.material_model.push(m).map_err(|_| SceneError::TooManyMaterials)
    }

    fn object(&mut self, _index: u16, o: ObjectRecord) -> Result<(), SceneError> {
        self.store.objects.push(o).map_err(|_| SceneError::BadHeader)
    }

    fn lighting(&mut self, l: LightingRecord) -> Result<(), SceneError> {
        self.store.lighting = l;
        Ok(())
    }

    fn pe_begin(&mut self, pe: u8, words: u32) -> Result<(), SceneError> {
        *self.words_left = words;
        self.put(FslWord::data(wire::load_header(pe)), "LOAD_PE")?;
        let count = if words == 0 { FslWord::last(words) } else { FslWord::data(words) };
        self.put(count, "LOAD_PE")
    }

    fn pe_word(&mut self, word: u32) -> Result<(), SceneError> {
        *self.words_left = self.words_left.checked_sub(1).ok_or(SceneError::BadPeBlock)?;
        let w = if *self.words_left == 0 { FslWord::last(word) } else { FslWord::data(word) };
        self.put(w, "LOAD_PE")
    }

    fn pe_end(&mut self) -> Result<(), SceneError> {
        if *self.words_left != 0 {
            return Err(SceneError::BadPeBlock);
        }
        self.expect_ack("LOAD_PE")
    }
}

/// Stage stopwatch: each lap charges the time since the previous lap to one stage.
struct Stopwatch {
    last: StageCount,
}

impl Stopwatch {
    #[inline(always)]
    fn lap<C: StageClock>(&mut self, clock: &C, stats: &mut FrameStats, stage: Stage) {
        let now = clock.now();
        if let Some(s) = stats.stages.get_mut(stage.index()) {
            s.add(now.since(self.last));
        }
        self.last = now;
    }
}

/// The ray path: link, list buffer and counters.
struct RayPath<L> {
    link: L,
    list: TraversalList,
    stats: FrameStats,
    polls: u32,
}

impl<L: FslLink> RayPath<L> {
    /// Traces one ray; `Ok(None)` when its list is empty (nothing sent).
    #[inline]
    fn trace<C: StageClock, const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        ray: &Ray,
        kind: RayKind,
        t_max: f32,
        clock: &C,
        sw: &mut Stopwatch,
    ) -> Result<Option<RayResult>, Fail> {
        let map = scene.voxel_pe.get(..scene.voxels).unwrap_or(&[]);
        build_list(&scene.grid, map, ray, 0.0, t_max, &mut self.list);
        sw.lap(clock, &mut self.stats, Stage::Traverse);
        if self.list.is_empty() {
            self.stats.culled_rays += 1;
            return Ok(None);
        }
        let r = self.exchange(ray, kind, t_max);
        sw.lap(clock, &mut self.stats, Stage::FslIo);
        if r.is_err() {
            self.drain();
        }
        r.map(Some)
    }

    /// Puts the request and gets the 8 result words.
    fn exchange(&mut self, ray: &Ray, kind: RayKind, t_max: f32) -> Result<RayResult, Fail> {
        let n = self.list.len();
        let head = wire::ray_request_head(kind, ray.origin.to_array(), ray.dir.to_array(), t_max, n as u16);
        for w in head {
            self.link.put(FslWord::data(w), self.polls).map_err(|e| Fail::link(e, "ray request"))?;
            self.stats.fsl_words_out += 1;
        }
        for (i, e) in self.list.iter().enumerate() {
            let [w0, w1] = wire::entry_words(*e);
            let w1 = if i + 1 == n { FslWord::last(w1) } else { FslWord::data(w1) };
            for w in [FslWord::data(w0), w1] {
                self.link.put(w, self.polls).map_err(|e| Fail::link(e, "ray request"))?;
                self.stats.fsl_words_out += 1;
            }
        }
        self.stats.coproc_rays += 1;
        self.stats.list_entries += n as u64;
        let mut words = [0u32; RESULT_WORDS];
        for (i, slot) in words.iter_mut().enumerate() {
            let w = self.link.get(self.polls).map_err(|e| Fail::link(e, "ray result"))?;
            self.stats.fsl_words_in += 1;
            let opc = wire::opcode(w.data);
            // An ERROR word is a whole packet; anything else must be an 8-word RESULT packet
            // whose only control bit is on the last word.
            if i == 0 && opc != op::RESULT {
                return Err(Fail::Word(w.data, "ray result"));
            }
            if w.control != (i + 1 == RESULT_WORDS) {
                return Err(Fail::Word(w.data, "ray result (misplaced control bit)"));
            }
            *slot = w.data;
        }
        let r = RayResult::from_words(&words).map_err(|_| Fail::Word(words[0], "ray result"))?;
        self.stats.intersection_tests += r.tests as u64;
        self.stats.coproc_cycles += r.cycles as u64;
        Ok(r)
    }

    /// Drops stale answer words after an aborted ray so the next request starts clean.
    fn drain(&mut self) {
        for _ in 0..DRAIN_WORDS {
            match self.link.nget() {
                Ok(_) => continue,
                Err(_) => break,
            }
        }
    }
}

/// Everything but the receive buffer (split so a received frame can borrow that buffer
/// while the handler mutates the rest).
struct Core<L, C, const N: usize> {
    path: RayPath<L>,
    clock: C,
    info: DeviceInfo,
    tx: FrameTx,
    spans: SpanEncoder,
    scene: SceneStore<N>,
    upload: Option<Upload>,
    /// Row buffer of the row interpolation.
    row: [crate::interp::Sample; pipeline::MAX_INTERP_WIDTH],
}

/// The device: feed it UART bytes, it answers through a [`ByteSink`].
pub struct Device<L: FslLink, C: StageClock, const MAX_VOXELS: usize> {
    rx: FrameAccumulator,
    core: Core<L, C, MAX_VOXELS>,
}

impl<L: FslLink, C: StageClock, const MAX_VOXELS: usize> Device<L, C, MAX_VOXELS> {
    /// A device with no scene. `info` supplies firmware version, board, PE count and PE memory
    /// size (0 = unknown, not checked); protocol, max payload, voxel capacity (= MAX_VOXELS)
    /// and feature bits are filled in here.
    pub fn new(link: L, clock: C, info: DeviceInfo) -> Self {
        let info = DeviceInfo {
            protocol: gridrt_shared::PROTOCOL_VERSION as u16,
            max_payload: MAX_PAYLOAD as u16,
            voxel_capacity: u32::try_from(MAX_VOXELS).unwrap_or(u32::MAX),
            features: compiled_features(),
            ..info
        };
        Self {
            rx: FrameAccumulator::new(),
            core: Core {
                path: RayPath { link, list: TraversalList::new(), stats: FrameStats::default(), polls: DEFAULT_POLLS },
                clock,
                info,
                tx: FrameTx::new(),
                spans: SpanEncoder::new(),
                scene: SceneStore {
                    loaded: false,
                    grid: GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [1; 3] },
                    voxels: 0,
                    voxel_pe: [EMPTY_VOXEL; MAX_VOXELS],
                    materials: heapless::Vec::new(),
                    material_model: heapless::Vec::new(),
                    objects: heapless::Vec::new(),
                    lighting: LightingRecord::default(),
                },
                row: [crate::interp::Sample::default(); pipeline::MAX_INTERP_WIDTH],
                upload: None,
            },
        }
    }

    /// Processes received bytes; every complete frame is handled before this returns (a
    /// render request renders the whole frame). Partial frames wait for the next call.
    pub fn feed(&mut self, input: &[u8], out: &mut impl Write) {
        let mut input = input;
        // Each round consumes at least one byte (up to a delimiter), so this bound is never hit.
        for _ in 0..=input.len() {
            match self.rx.feed(input) {
                FeedResult::Consumed => return,
                FeedResult::Overflow { rest } => {
                    self.core.bad_frame(FrameError::DecodeOversize, out);
                    input = rest;
                }
                FeedResult::BadFrame { error, rest } => {
                    self.core.bad_frame(error, out);
                    input = rest;
                }
                FeedResult::Frame { frame, rest } => {
                    self.core.handle(frame.kind, frame.payload, out);
                    input = rest;
                }
            }
            if input.is_empty() {
                return;
            }
        }
    }

    /// The boot banner (SPEC.md §3.12): a lone `0x00` (flushes whatever the host's receiver
    /// holds) and an unsolicited `Version`. Call once after every reset, before the first
    /// [`feed`](Self::feed); a host that sees it mid-session knows the device lost its scene.
    pub fn announce(&mut self, out: &mut impl Write) {
        // A failed write is counted (`write_errors`); the host, which waits for the banner,
        // asks again with `Hello`.
        let _ = self.core.tx.delimiter(out);
        let info = self.core.info;
        self.core.send(&Msg::Version(info), out);
    }

    /// The co-processor link.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.core.path.link
    }

    /// The co-processor link.
    pub fn link(&self) -> &L {
        &self.core.path.link
    }

    /// What the device reports in `Msg::Version`.
    pub fn info(&self) -> &DeviceInfo {
        &self.core.info
    }

    /// True when a scene is loaded and renders are accepted.
    pub fn scene_loaded(&self) -> bool {
        self.core.scene.loaded
    }

    /// Counters of the last (or current, if it was aborted) frame.
    pub fn stats(&self) -> &FrameStats {
        &self.core.path.stats
    }

    /// Writes to the output that failed so far (saturating). A failed write stops the frame
    /// it belonged to (nothing more is sent for it: no spans, `Stats`, end message or
    /// `Error`); a failed answer outside a frame is lost. Either way the host, which waits
    /// for every answer, times out and asks again.
    pub fn write_errors(&self) -> u32 {
        self.core.tx.write_errors()
    }

    /// Sets the poll budget of every blocking FSL put/get (default [`DEFAULT_POLLS`]).
    pub fn set_poll_budget(&mut self, polls: u32) {
        self.core.path.polls = polls;
    }
}

impl<L: FslLink, C: StageClock, const N: usize> Core<L, C, N> {
    fn send(&mut self, msg: &Msg<'_>, out: &mut impl Write) {
        // Fails on a write error (counted by `tx`, see `Device::write_errors`) or a firmware
        // bug (message larger than a frame): nothing to report either with.
        let _ = self.tx.send(msg, out);
    }

    fn error(&mut self, code: ErrorCode, detail: u32, text: &str, out: &mut impl Write) {
        self.send(&Msg::Error { code, detail, text }, out);
    }

    fn abort(&mut self, f: Fail, out: &mut impl Write) {
        if let Fail::Output = f {
            return;
        }
        let (code, detail) = f.code_detail();
        let mut t = Text::new();
        f.describe(&mut t);
        self.error(code, detail, t.as_str(), out);
    }

    fn bad_frame(&mut self, e: FrameError, out: &mut impl Write) {
        let mut t = Text::new();
        Trunc(&mut t).put("bad frame: ");
        Trunc(&mut t).put(e.as_str());
        self.error(ErrorCode::BadFrame, e.code(), t.as_str(), out);
    }

    fn handle(&mut self, kind: u8, payload: &[u8], out: &mut impl Write) {
        let msg = match Msg::decode(kind, payload) {
            Ok(m) => m,
            Err(MsgError::DecodeUnknownType) => {
                return self.error(ErrorCode::UnexpectedMessage, kind as u32, "unknown message type", out);
            }
            Err(e) => {
                let mut t = Text::new();
                let mut w = Trunc(&mut t);
                w.put("malformed payload of message ");
                w.put_hex(kind as u32, 2);
                w.put(": ");
                w.put(e.as_str());
                return self.error(ErrorCode::BadRequest, kind as u32, t.as_str(), out);
            }
        };
        match msg {
            Msg::Hello { .. } => {
                let info = self.info;
                self.send(&Msg::Version(info), out);
            }
            Msg::SceneBegin { total_len, crc } => {
                // A new upload invalidates the old scene (it will CLEAR the co-processor).
                self.scene.loaded = false;
                self.upload = Some(Upload {
                    stream: SceneStream::new(),
                    total_len,
                    crc,
                    digest: Crc32Digest::default(),
                    next: 0,
                    pe_words_left: 0,
                });
            }
            Msg::SceneChunk { offset, data } => self.scene_chunk(offset, data, out),
            Msg::RenderRequest(req) => self.render(&req, out),
            Msg::RenderRegion { region, max_span, options, request } => {
                self.render_region(&request, region, max_span, options, out)
            }
            other => {
                let k = other.kind() as u8;
                self.error(ErrorCode::UnexpectedMessage, k as u32, "message not accepted by the device", out);
            }
        }
    }

    fn scene_chunk(&mut self, offset: u32, data: &[u8], out: &mut impl Write) {
        let Some(up) = self.upload.as_mut() else {
            return self.error(
                ErrorCode::UnexpectedMessage,
                MsgType::SceneChunk as u32,
                "scene chunk without SceneBegin",
                out,
            );
        };
        if offset != up.next {
            let expected = up.next;
            return self.error(ErrorCode::BadOffset, expected, "scene chunk out of order", out);
        }
        let end = (up.next as u64) + data.len() as u64;
        let result = if end > up.total_len as u64 {
            Err((SceneError::TrailingBytes, None))
        } else {
            up.digest.update(data);
            let mut loader = Loader {
                link: &mut self.path.link,
                store: &mut self.scene,
                info: &self.info,
                polls: self.path.polls,
                total_len: up.total_len,
                words_left: &mut up.pe_words_left,
                failure: None,
            };
            match up.stream.feed(data, &mut loader) {
                Ok(()) => Ok(()),
                Err(e) => Err((e, loader.failure.take())),
            }
        };
        match result {
            Err((e, failure)) => {
                self.upload = None;
                self.scene.loaded = false;
                let mut t = Text::new();
                Trunc(&mut t).put("scene rejected: ");
                Trunc(&mut t).put(e.as_str());
                if let Some(f) = failure {
                    Trunc(&mut t).put("; ");
                    f.describe(&mut t);
                }
                self.error(ErrorCode::SceneRejected, e.code(), t.as_str(), out);
            }
            Ok(()) => {
                up.next = end as u32;
                let next = up.next;
                if next < up.total_len {
                    return self.send(&Msg::SceneAck { next_offset: next, status: SceneStatus::Receiving }, out);
                }
                // All bytes in: the stream has checked the body CRC and every ACK; check the
                // whole-image CRC of SceneBegin too.
                let done = up.stream.is_done();
                let crc_ok = core::mem::take(&mut up.digest).finalize() == up.crc;
                self.upload = None;
                if !done {
                    self.error(ErrorCode::SceneRejected, SceneError::Truncated.code(), "scene image ended early", out);
                } else if !crc_ok {
                    self.error(
                        ErrorCode::SceneRejected,
                        SceneError::BadCrc.code(),
                        "scene CRC differs from SceneBegin",
                        out,
                    );
                } else {
                    self.scene.loaded = true;
                    self.send(&Msg::SceneAck { next_offset: next, status: SceneStatus::Loaded }, out);
                }
            }
        }
    }

    /// Validates a request; returns the camera and light.
    fn validate(&self, r: &RenderRequest, base: u32) -> Result<(Camera, Light), Fail> {
        let bad = |f: u32, t: &'static str| Fail::Plain(ErrorCode::BadRequest, base + f, t);
        if !self.scene.loaded {
            return Err(Fail::Plain(ErrorCode::NoScene, 0, "no scene loaded"));
        }
        if !(1..=MAX_IMAGE_DIM).contains(&r.width) {
            return Err(bad(field::WIDTH, "width not in 1..=4096"));
        }
        if !(1..=MAX_IMAGE_DIM).contains(&r.height) {
            return Err(bad(field::HEIGHT, "height not in 1..=4096"));
        }
        let finite = |v: [f32; 3]| v.iter().all(|c| c.is_finite());
        let vectors = [
            (r.eye, field::EYE, "eye not finite"),
            (r.target, field::TARGET, "target not finite"),
            (r.up, field::UP, "up not finite"),
            (r.light_pos, field::LIGHT_POS, "light position not finite"),
        ];
        for (v, f, t) in vectors {
            if !finite(v) {
                return Err(bad(f, t));
            }
        }
        if !r.light_intensity.is_finite() {
            return Err(bad(field::LIGHT_INTENSITY, "light intensity not finite"));
        }
        if !r.ambient.is_finite() {
            return Err(bad(field::AMBIENT, "ambient not finite"));
        }
        if !r.encoding.is_colour() {
            return Err(bad(field::ENCODING, "encoding is not a colour encoding"));
        }
        let v = Vec3::from_array;
        let cam =
            Camera::new(v(r.eye), v(r.target), v(r.up), r.fov_y_deg, r.width as u32, r.height as u32).map_err(|e| {
                match e {
                    CameraError::EyeIsTarget => bad(field::TARGET, "eye equals target"),
                    CameraError::DegenerateUp => bad(field::UP, "up is zero or parallel to the view direction"),
                    CameraError::BadSize => bad(field::WIDTH, "empty image"),
                    CameraError::BadFov | CameraError::NonFinite => bad(field::FOV, "fov not in (0, 180) degrees"),
                }
            })?;
        Ok((cam, Light { pos: v(r.light_pos), intensity: r.light_intensity, ambient: r.ambient }))
    }

    fn render(&mut self, req: &RenderRequest, out: &mut impl Write) {
        let (cam, light) = match self.validate(req, 0) {
            Ok(v) => v,
            Err(f) => return self.abort(f, out),
        };
        let region = Region::full(req.width, req.height);
        if let Some((spans, image_crc)) = self.render_rect(req, region, 0, false, &cam, &light, out) {
            self.send(&Msg::FrameEnd { frame: req.frame, spans, image_crc }, out);
        }
    }

    /// `RenderRegion` (SPEC.md §3.12): the pixels of `region`, exactly as a full render of
    /// `req` would produce them, then `Stats` and `RegionEnd`.
    fn render_region(
        &mut self,
        req: &RenderRequest,
        region: Region,
        max_span: u16,
        options: u16,
        out: &mut impl Write,
    ) {
        let (cam, light) = match self.validate(req, field::REGION_REQUEST) {
            Ok(v) => v,
            Err(f) => return self.abort(f, out),
        };
        if !region.fits(req.width, req.height) {
            let (f, t) = if region.cols == 0 || region.x0 as u32 + region.cols as u32 > req.width as u32 {
                (field::REGION_X0, "region columns outside the image")
            } else {
                (field::REGION_Y0, "region rows outside the image")
            };
            return self.abort(Fail::Plain(ErrorCode::BadRequest, f, t), out);
        }
        let crc_only = options & region_options::CRC_ONLY != 0;
        if let Some((spans, crc)) = self.render_rect(req, region, max_span, crc_only, &cam, &light, out) {
            self.send(&Msg::RegionEnd { frame: req.frame, region, spans, crc }, out);
        }
    }

    /// Renders `region` and sends its spans and `Stats`; returns (spans, CRC of the decoded
    /// pixels), or `None` when the frame was aborted (the error is already sent).
    #[allow(clippy::too_many_arguments)]
    fn render_rect(
        &mut self,
        req: &RenderRequest,
        region: Region,
        max_span: u16,
        crc_only: bool,
        cam: &Camera,
        light: &Light,
        out: &mut impl Write,
    ) -> Option<(u32, u32)> {
        self.path.stats = FrameStats::default();
        let prim_ids = req.flags & render_flags::PRIM_IDS != 0 && !crc_only;
        self.spans.begin_with(req.frame, prim_ids, req.encoding, max_span);
        self.spans.set_silent(crc_only);
        if let Err(f) = self.render_pixels(req, region, cam, light, out) {
            self.abort(f, out);
            return None;
        }
        let (spans, crc) = self.spans.finish();
        let mut buf = [0u8; STAT_COUNT * STAT_ENTRY_LEN];
        for (chunk, (k, v)) in buf.chunks_exact_mut(STAT_ENTRY_LEN).zip(self.path.stats.entries()) {
            if let Some((key, val)) = chunk.split_first_mut() {
                *key = k;
                val.copy_from_slice(&v.to_le_bytes());
            }
        }
        if let Err(TxError::Write(_)) = self.tx.send(&Msg::Stats { frame: req.frame, entries: &buf }, out) {
            return None; // the frame stops (`Fail::Output`)
        }
        Some((spans, crc))
    }

    /// Row-major render loop; returns early (frame aborted) on any co-processor failure
    /// (the pixel pipeline, plan and interpolation are in `device/pipeline.rs`).
    fn render_pixels(
        &mut self,
        req: &RenderRequest,
        region: Region,
        cam: &Camera,
        light: &Light,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        self.render_pipeline(req, region, cam, light, out)
    }
}

mod pipeline;

#[cfg(test)]
mod tests;
