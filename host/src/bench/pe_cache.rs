//! `gridrt bench pe-cache`: sizes a per-PE cache for PE images kept in external memory (the
//! ULX3S's SDRAM behind LiteDRAM) instead of block RAM, from the PE-memory reads of a whole
//! frame. A model study: nothing here runs on a board.
//!
//! 1. [`trace_frame`]: one frame through the firmware's device code and the co-processor
//!    model in this process, with the RTL's kernel, format and timing (watertight,
//!    fixed64-q23, `TimingProfile::RTL`), every PE's reads recorded in order by a
//!    [`PeReadObserver`] ([`FrameTrace`]; what is read and in which order:
//!    `gridrt_coproc`'s `observe` module).
//! 2. [`replay`]: each PE's reads through a cache of its own ([`Cache`]: size, line, ways,
//!    LRU), cold at the frame's start; a read of n words touches every line of its span once.
//! 3. [`MissModel`]: the cycles a miss costs (modelled, see there), and two bounds of the
//!    cycles per ray: every miss stalls the ray in turn (one SDRAM serves all PEs), or the
//!    PEs' misses of a ray overlap and only the busiest PE's count.
//! 4. [`brams`]: the ECP5's DP16KD blocks one PE's cache takes (data and tags).

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::Duration;

use gridrt_coproc::{Coprocessor, FixedFrame, PeRead, PeReadKind, PeReadObserver, RayResult};
use gridrt_firmware::device::{Device, NoClock};
use gridrt_firmware::fsl::{FslLink, FslWord};
use gridrt_loopback::{SimConfig, SIM_MAX_VOXELS};
use gridrt_shared::msg::{stat, RenderRequest};
use serde::Serialize;

use super::in_process::{read_queued, VecSink};
use crate::scene_image::PreparedScene;
use crate::session::{RenderedFrame, Session, SessionConfig};

/// The ULX3S's SDRAM (32 MiB), split evenly between the PEs: what a tag must address.
pub const SDRAM_BYTES: u64 = 32 << 20;

/// Read kinds in report order.
pub const KINDS: [PeReadKind; 4] = [PeReadKind::VoxelTable, PeReadKind::Ref, PeReadKind::Record, PeReadKind::Result];

/// A read kind's name in reports.
pub fn kind_name(k: PeReadKind) -> &'static str {
    match k {
        PeReadKind::VoxelTable => "voxel_table",
        PeReadKind::Ref => "ref",
        PeReadKind::Record => "record",
        PeReadKind::Result => "result",
    }
}

fn kind_index(k: PeReadKind) -> usize {
    match k {
        PeReadKind::VoxelTable => 0,
        PeReadKind::Ref => 1,
        PeReadKind::Record => 2,
        PeReadKind::Result => 3,
    }
}

/// One read, packed: word address (bits 0..32), words (32..48), kind index (48..).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Packed(u64);

impl Packed {
    fn new(r: &PeRead) -> Self {
        let words = u64::from(r.words.min(u32::from(u16::MAX)));
        Self(u64::from(r.addr) | words << 32 | (kind_index(r.kind) as u64) << 48)
    }
    fn addr(self) -> u64 {
        self.0 & 0xFFFF_FFFF
    }
    fn words(self) -> u64 {
        (self.0 >> 32) & 0xFFFF
    }
    fn kind(self) -> usize {
        (self.0 >> 48) as usize & 3
    }
}

/// The PE-memory reads of a frame, per PE, with the rays' boundaries.
#[derive(Debug, Clone, Default)]
pub struct FrameTrace {
    /// PEs.
    pub pes: u16,
    /// Per PE, its reads in the order it makes them.
    reads: Vec<Vec<Packed>>,
    /// Per ray, each PE's read count when the ray was answered (`pes` entries per ray).
    ray_ends: Vec<u64>,
    /// Rays the co-processor answered.
    pub rays: u64,
    /// Their cycles (RESULT words, the timing profile's).
    pub cycles: u64,
    /// Their ray–triangle tests.
    pub tests: u64,
}

impl FrameTrace {
    /// An empty trace of `pes` PEs.
    pub fn new(pes: u16) -> Self {
        Self { pes, reads: vec![Vec::new(); pes as usize], ..Self::default() }
    }

    /// Reads of PE `pe` (0 for a PE out of range).
    pub fn reads_of(&self, pe: usize) -> usize {
        self.reads.get(pe).map_or(0, Vec::len)
    }

    /// Reads of every PE.
    pub fn total_reads(&self) -> u64 {
        self.reads.iter().map(|r| r.len() as u64).sum()
    }

    /// Reads and words read, per kind ([`KINDS`] order), over every PE.
    pub fn by_kind(&self) -> [(u64, u64); 4] {
        let mut out = [(0u64, 0u64); 4];
        for r in self.reads.iter().flatten() {
            let slot = &mut out[r.kind()];
            slot.0 += 1;
            slot.1 += r.words();
        }
        out
    }

    /// The reads of PE `pe` as (word address, words, kind), in order.
    pub fn reads(&self, pe: usize) -> impl Iterator<Item = (u32, u32, PeReadKind)> + '_ {
        self.reads.get(pe).into_iter().flatten().map(|p| (p.addr() as u32, p.words() as u32, KINDS[p.kind()]))
    }
}

impl PeReadObserver for FrameTrace {
    fn read(&mut self, read: PeRead) {
        if let Some(v) = self.reads.get_mut(read.pe as usize) {
            v.push(Packed::new(&read));
        }
    }

    fn ray_end(&mut self, result: &RayResult) {
        self.rays += 1;
        self.cycles += u64::from(result.cycles);
        self.tests += u64::from(result.tests);
        self.ray_ends.extend(self.reads.iter().map(|r| r.len() as u64));
    }
}

/// Geometry of one PE's cache.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CacheConfig {
    /// Data bytes.
    pub size_bytes: u32,
    /// Bytes per line.
    pub line_bytes: u32,
    /// Lines per set (1 = direct-mapped); LRU within a set.
    pub ways: u32,
}

impl CacheConfig {
    /// Sets.
    pub fn sets(&self) -> u32 {
        self.size_bytes / (self.line_bytes * self.ways).max(1)
    }

    /// Checks the geometry: powers of two, lines of at least one word, at least one set.
    pub fn check(&self) -> Result<(), String> {
        let pow2 = |v: u32| v.is_power_of_two();
        if !pow2(self.size_bytes) || !pow2(self.line_bytes) || !pow2(self.ways) {
            return Err(format!("{}: size, line and ways must be powers of two", self.label()));
        }
        if self.line_bytes < 4 {
            return Err(format!("{}: a line holds at least one 4-byte word", self.label()));
        }
        if u64::from(self.line_bytes) * u64::from(self.ways) > u64::from(self.size_bytes) {
            return Err(format!("{}: fewer bytes than one set of lines", self.label()));
        }
        Ok(())
    }

    /// "8 KiB, 32 B lines, 2-way".
    pub fn label(&self) -> String {
        let ways = if self.ways == 1 { "direct-mapped".to_string() } else { format!("{}-way", self.ways) };
        format!("{} KiB, {} B lines, {ways}", f64::from(self.size_bytes) / 1024.0, self.line_bytes)
    }
}

/// A set-associative cache of line numbers with LRU replacement (the data is not kept: a
/// read of the PE image never changes it).
#[derive(Debug, Clone)]
pub struct Cache {
    sets: u64,
    ways: usize,
    /// Line number per way (`u64::MAX`: empty), set after set.
    tags: Vec<u64>,
    /// Last use per way (0: never), set after set.
    used: Vec<u64>,
    clock: u64,
}

impl Cache {
    /// An empty cache of `cfg` (checked with [`CacheConfig::check`]).
    pub fn new(cfg: CacheConfig) -> Self {
        let n = cfg.sets().max(1) as usize * cfg.ways.max(1) as usize;
        Self {
            sets: u64::from(cfg.sets().max(1)),
            ways: cfg.ways.max(1) as usize,
            tags: vec![u64::MAX; n],
            used: vec![0; n],
            clock: 0,
        }
    }

    /// Looks up line `line` (byte address ÷ line bytes): true on a hit; on a miss the line
    /// replaces the least recently used way of its set (index = line mod sets).
    pub fn access(&mut self, line: u64) -> bool {
        self.clock += 1;
        let base = (line % self.sets) as usize * self.ways;
        let tags = &mut self.tags[base..base + self.ways];
        let used = &mut self.used[base..base + self.ways];
        if let Some(w) = tags.iter().position(|&t| t == line) {
            used[w] = self.clock;
            return true;
        }
        // Empty ways have never been used, so they go first; ties go to the lowest way.
        let victim = (0..self.ways).min_by_key(|&w| used[w]).unwrap_or(0);
        tags[victim] = line;
        used[victim] = self.clock;
        false
    }
}

/// Cycles (of the co-processor's clock, 50 MHz) one miss stalls a PE: `latency` until the
/// line's first beat, then `line_bytes ÷ bytes_per_cycle` beats. **Modelled, not measured.**
///
/// [`MissModel::LITEDRAM_ULX3S`]: LiteDRAM's generic SDR PHY (`GENSDRPHY`, 1:1, CL 2,
/// `read_latency` = CL + 1 command cycle) as litex-boards' `radiona_ulx3s` target builds it
/// at `sys_clk` 50 MHz, on the board's 16-bit SDRAM (MT48LC16M16 / AS4C32M16 timings: tRP,
/// tRCD ≤ 20 ns = 1 cycle). Latency 12 = miss detection 1 + native port and crossbar 2 + a
/// row miss in the bank machine (precharge, tRP, activate, tRCD: 4) + command multiplexer 1
/// + PHY command register 1 + CL 2 + read-data register 1; then one 16-bit beat per cycle
///   (burst length 1, one READ per cycle). A row hit saves about 4, a refresh (every 7.8 µs)
///   costs about 5 more: neither is modelled, and nor is another SDRAM user (the soft-core).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MissModel {
    /// Cycles from the miss to the line's first beat.
    pub latency: u32,
    /// Bytes per beat (the SDRAM's data bus: 2 on the ULX3S).
    pub bytes_per_cycle: u32,
}

impl MissModel {
    /// LiteDRAM on the ULX3S's SDRAM at 50 MHz (type doc).
    pub const LITEDRAM_ULX3S: MissModel = MissModel { latency: 12, bytes_per_cycle: 2 };

    /// Cycles one miss of a `line_bytes` line costs.
    pub fn penalty(&self, line_bytes: u32) -> u64 {
        u64::from(self.latency) + u64::from(line_bytes.div_ceil(self.bytes_per_cycle.max(1)))
    }
}

/// A trace replayed through one cache configuration (every PE its own cache).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Replay {
    /// Line look-ups (a read touches each line of its span once).
    pub accesses: u64,
    /// Of which hits.
    pub hits: u64,
    /// Misses per read kind ([`KINDS`] order).
    pub misses_by_kind: [u64; 4],
    /// Misses summed over every PE and ray.
    pub misses: u64,
    /// Σ over rays of the largest miss count of one PE in that ray.
    pub busiest_pe_misses: u64,
}

impl Replay {
    /// Hits ÷ accesses (1 with no access).
    pub fn hit_rate(&self) -> f64 {
        if self.accesses == 0 {
            1.0
        } else {
            self.hits as f64 / self.accesses as f64
        }
    }
}

/// Replays every PE's reads of `trace` through a cold cache of `cfg` of its own.
pub fn replay(trace: &FrameTrace, cfg: CacheConfig) -> Replay {
    let mut out = Replay::default();
    let pes = trace.pes as usize;
    let rays = trace.ray_ends.len() / pes.max(1);
    let mut busiest = vec![0u64; rays];
    let line = u64::from(cfg.line_bytes.max(1));
    for (pe, reads) in trace.reads.iter().enumerate() {
        let mut cache = Cache::new(cfg);
        let mut at = 0usize;
        // Reads of ray r end at `ray_ends[r·pes + pe]`; none come after the last ray.
        for (r, slot) in busiest.iter_mut().enumerate() {
            let end = (trace.ray_ends[r * pes + pe] as usize).min(reads.len());
            let mut misses = 0u64;
            for p in &reads[at..end] {
                let first = p.addr() * 4 / line;
                let last = ((p.addr() + p.words().max(1)) * 4 - 1) / line;
                for l in first..=last {
                    out.accesses += 1;
                    if cache.access(l) {
                        out.hits += 1;
                    } else {
                        misses += 1;
                        out.misses_by_kind[p.kind()] += 1;
                    }
                }
            }
            out.misses += misses;
            *slot = (*slot).max(misses);
            at = end;
        }
    }
    out.busiest_pe_misses = busiest.iter().sum();
    out
}

/// DP16KD blocks of one PE's cache.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Brams {
    /// The data array.
    pub data: u32,
    /// Tags, valid bits and LRU state.
    pub tags: u32,
    /// Bits of one tag entry (tag + valid).
    pub tag_bits: u32,
}

impl Brams {
    /// Both.
    pub fn total(&self) -> u32 {
        self.data + self.tags
    }
}

/// The ECP5 DP16KD's shapes (depth × width, 18 kbit; 36 wide only as a pseudo-dual port).
pub const DP16KD_SHAPES: [(u32, u32); 6] = [(16_384, 1), (8_192, 2), (4_096, 4), (2_048, 9), (1_024, 18), (512, 36)];

/// Fewest DP16KD blocks for a `depth` × `width` memory.
pub fn dp16kd_blocks(depth: u32, width: u32) -> u32 {
    if depth == 0 || width == 0 {
        return 0;
    }
    DP16KD_SHAPES.iter().map(|&(d, w)| depth.div_ceil(d) * width.div_ceil(w)).min().unwrap_or(0)
}

/// Words the RTL's PE memory returns per read (rtl/README.md §4.2: a 4-word window, the
/// record in three reads): a cache that feeds the PE the same way keeps 4 banks of 32 bits.
pub const DATA_BANKS: u32 = 4;

/// DP16KD blocks of a cache of `cfg` for a PE whose image lives in `region_bytes` of
/// external memory: data in [`DATA_BANKS`] banks of 32-bit words; one tag entry per way
/// (tag + valid) and the set's LRU state (⌈log₂ ways!⌉ bits) side by side, one row per set.
pub fn brams(cfg: CacheConfig, region_bytes: u64) -> Brams {
    let addr_bits = 64 - region_bytes.saturating_sub(1).leading_zeros();
    let index_bits = cfg.sets().max(1).trailing_zeros() + cfg.line_bytes.max(1).trailing_zeros();
    let tag_bits = addr_bits.saturating_sub(index_bits) + 1;
    let lru_bits = match cfg.ways {
        0 | 1 => 0,
        2 => 1,
        3 => 3,
        4 => 5,
        w => (1..=w).map(|k| f64::from(k).log2()).sum::<f64>().ceil() as u32,
    };
    let bank_depth = (cfg.size_bytes / 4).div_ceil(DATA_BANKS);
    Brams {
        data: DATA_BANKS * dp16kd_blocks(bank_depth, 32),
        tags: dp16kd_blocks(cfg.sets(), cfg.ways * tag_bits + lru_bits),
        tag_bits,
    }
}

/// The co-processor link of [`trace_frame`]'s device: the model, whose ray packets tell the
/// trace every read.
struct TracedLink<'m> {
    model: Coprocessor<'m>,
    trace: FrameTrace,
}

impl FslLink for TracedLink<'_> {
    type Error = core::convert::Infallible;

    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        self.model.push_observed(word, &mut self.trace);
        Ok(())
    }

    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.model.pop().ok_or(nb::Error::WouldBlock)
    }
}

type TracedDevice<'m> = Device<TracedLink<'m>, NoClock, SIM_MAX_VOXELS>;

/// The device on this thread as a byte transport: a write runs it, a read returns its answer.
struct InProcess<'d, 'm> {
    device: &'d mut TracedDevice<'m>,
    out: VecDeque<u8>,
}

impl Write for InProcess<'_, '_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.device.feed(buf, &mut VecSink(&mut self.out));
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for InProcess<'_, '_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_queued(&mut self.out, buf)
    }
}

/// The board a trace runs on: [`SimConfig::RTL`]'s co-processor (kernel, format, timing,
/// lists), computed by the model, with `pes` PEs of `pe_mem_words` words.
pub fn board(pes: u16, pe_mem_words: u32) -> SimConfig {
    SimConfig { pe_count: pes, pe_mem_words, backend: gridrt_loopback::Backend::Model, threads: 1, ..SimConfig::RTL }
}

/// One frame of `req` on `config`'s board (the firmware's device code on this thread, the
/// model as its co-processor), every PE-memory read of the frame's rays recorded. Checks
/// that the trace saw every co-processor ray and its cycles, as the device counted them.
pub fn trace_frame(
    prepared: &PreparedScene,
    req: &RenderRequest,
    config: SimConfig,
) -> anyhow::Result<(RenderedFrame, FrameTrace)> {
    let work = || -> anyhow::Result<(RenderedFrame, FrameTrace)> {
        let coproc = config.coproc();
        let mut backing = vec![0u32; coproc.required_backing_words()];
        let mut model =
            Coprocessor::new(coproc, &mut backing).map_err(|e| anyhow::anyhow!("co-processor configuration: {e}"))?;
        model.set_number_format(config.format, FixedFrame::IDENTITY);
        let link = TracedLink { model, trace: FrameTrace::new(config.pe_count) };
        let mut device: Box<TracedDevice<'_>> = Box::new(Device::new(link, NoClock, config.device_info()));
        let port = InProcess { device: &mut device, out: VecDeque::new() };
        let cfg = SessionConfig::new("pe-cache").render_timeout(Duration::from_secs(3600));
        let mut session = Session::new(port, cfg);
        let info = session.hello(&mut |_| {})?;
        anyhow::ensure!(
            (info.pe_count, info.pe_mem_words) == (prepared.grid.pe_count, prepared.grid.pe_mem_words),
            "the grid was built for {} PEs of {} words, the board has {} of {}",
            prepared.grid.pe_count,
            prepared.grid.pe_mem_words,
            info.pe_count,
            info.pe_mem_words
        );
        session.upload_scene(&prepared.image, &mut |_| {})?;
        session.port_mut().device.link_mut().trace = FrameTrace::new(config.pe_count);
        let frame = session.render(req, &mut |_| {})?;
        drop(session);
        let trace = std::mem::take(&mut device.link_mut().trace);
        let counted = |k| frame.stats.get(&k).copied().unwrap_or(0);
        anyhow::ensure!(
            (trace.rays, trace.cycles) == (counted(stat::COPROC_RAYS), counted(stat::COPROC_CYCLES)),
            "the trace saw {} rays of {} cycles, the device counted {} of {}",
            trace.rays,
            trace.cycles,
            counted(stat::COPROC_RAYS),
            counted(stat::COPROC_CYCLES)
        );
        Ok((frame, trace))
    };
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("gridrt-pe-cache-device".into())
            // The device keeps its voxel map inline, as firmware does in static RAM.
            .stack_size(64 << 20)
            .spawn_scoped(s, work)
            .map_err(|e| anyhow::anyhow!("starting the device thread: {e}"))?
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the device thread panicked")))
    })
}

/// One scene × cache configuration: measured hit rate (of the model's reads) and the
/// modelled cycles per ray.
#[derive(Debug, Clone, Serialize)]
pub struct CacheRow {
    /// Scene name.
    pub scene: String,
    /// The cache of each PE.
    #[serde(flatten)]
    pub cache: CacheConfig,
    /// Sets.
    pub sets: u32,
    /// Line look-ups, every PE.
    pub accesses: u64,
    /// Of which hits.
    pub hits: u64,
    /// Hits ÷ look-ups.
    pub hit_rate: f64,
    /// Misses, every PE.
    pub misses: u64,
    /// Misses per co-processor ray.
    pub misses_per_ray: f64,
    /// Misses per read kind ([`KINDS`] order).
    pub misses_by_kind: [u64; 4],
    /// Cycles one miss costs ([`MissModel::penalty`], modelled).
    pub miss_penalty: u64,
    /// Cycles per ray of the `rtl` profile, every read a hit (the block-RAM design).
    pub rtl_cycles_per_ray: f64,
    /// Modelled: `rtl_cycles_per_ray` + misses per ray × penalty (each miss stalls the ray
    /// in turn: one SDRAM serves every PE).
    pub cycles_per_ray: f64,
    /// Modelled lower bound: only the busiest PE's misses of each ray stall it.
    pub cycles_per_ray_overlapped: f64,
    /// DP16KD blocks of one PE's cache: data.
    pub brams_data: u32,
    /// DP16KD blocks of one PE's cache: tags, valid and LRU bits.
    pub brams_tags: u32,
    /// Both, per PE.
    pub brams_per_pe: u32,
    /// Both, every PE.
    pub brams_all_pes: u32,
}

/// The row of `replay` (of `trace` through `cache`) under `model`, for `pes` PEs sharing
/// [`SDRAM_BYTES`].
pub fn row(scene: &str, trace: &FrameTrace, cache: CacheConfig, replay: &Replay, model: MissModel) -> CacheRow {
    let rays = trace.rays.max(1) as f64;
    let penalty = model.penalty(cache.line_bytes);
    let b = brams(cache, SDRAM_BYTES / u64::from(trace.pes.max(1)));
    let rtl = trace.cycles as f64 / rays;
    CacheRow {
        scene: scene.to_string(),
        cache,
        sets: cache.sets(),
        accesses: replay.accesses,
        hits: replay.hits,
        hit_rate: replay.hit_rate(),
        misses: replay.misses,
        misses_per_ray: replay.misses as f64 / rays,
        misses_by_kind: replay.misses_by_kind,
        miss_penalty: penalty,
        rtl_cycles_per_ray: rtl,
        cycles_per_ray: rtl + (replay.misses * penalty) as f64 / rays,
        cycles_per_ray_overlapped: rtl + (replay.busiest_pe_misses * penalty) as f64 / rays,
        brams_data: b.data,
        brams_tags: b.tags,
        brams_per_pe: b.total(),
        brams_all_pes: b.total() * u32::from(trace.pes),
    }
}

/// The rows as CSV.
pub fn csv(rows: &[CacheRow]) -> String {
    let mut s = String::from(
        "scene,size_bytes,line_bytes,ways,sets,accesses,hits,hit_rate,misses,misses_per_ray,\
         misses_voxel_table,misses_ref,misses_record,misses_result,miss_penalty,rtl_cycles_per_ray,\
         cycles_per_ray,cycles_per_ray_overlapped,brams_data,brams_tags,brams_per_pe,brams_all_pes\n",
    );
    for r in rows {
        let [v, f, c, x] = r.misses_by_kind;
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{:.5},{},{:.3},{v},{f},{c},{x},{},{:.2},{:.2},{:.2},{},{},{},{}\n",
            r.scene,
            r.cache.size_bytes,
            r.cache.line_bytes,
            r.cache.ways,
            r.sets,
            r.accesses,
            r.hits,
            r.hit_rate,
            r.misses,
            r.misses_per_ray,
            r.miss_penalty,
            r.rtl_cycles_per_ray,
            r.cycles_per_ray,
            r.cycles_per_ray_overlapped,
            r.brams_data,
            r.brams_tags,
            r.brams_per_pe,
            r.brams_all_pes
        ));
    }
    s
}

/// Words of PE memory the fullest PE of `prepared` needs with `config`'s kernel and format
/// (image and record table).
pub fn words_needed(prepared: &PreparedScene, config: &SimConfig) -> usize {
    let g = &prepared.grid;
    g.pe_images
        .iter()
        .zip(&g.pe_triangles)
        .map(|(img, &t)| config.kernel.pe_words_needed(config.format, img.len(), t as usize))
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(size: u32, line: u32, ways: u32) -> CacheConfig {
        CacheConfig { size_bytes: size, line_bytes: line, ways }
    }

    /// Two 16-byte lines, direct-mapped (line l in set l mod 2), by hand:
    /// 0 miss · 1 miss · 0 hit · 2 miss (evicts 0) · 0 miss (evicts 2) · 1 hit · 3 miss
    /// (evicts 1) · 1 miss. One set of two LRU lines would hit 0 at the fifth access; any
    /// other index would put 0 and 1 in one set.
    #[test]
    fn a_direct_mapped_two_line_cache_hits_and_misses_as_worked_out_by_hand() {
        let mut c = Cache::new(cfg(32, 16, 1));
        let got: Vec<bool> = [0, 1, 0, 2, 0, 1, 3, 1].iter().map(|&l| c.access(l)).collect();
        assert_eq!(got, [false, false, true, false, false, true, false, false]);
    }

    /// Two ways of one set, LRU: 0 1 0 2 (evicts 1, the least recently used, not 0) 0 hit ·
    /// 1 miss (evicts 2) · 2 miss (evicts 0) · 1 hit. FIFO would evict 0 at the fourth access.
    #[test]
    fn a_two_way_set_evicts_the_least_recently_used_line() {
        let mut c = Cache::new(cfg(32, 16, 2));
        let got: Vec<bool> = [0, 1, 0, 2, 0, 1, 2, 1].iter().map(|&l| c.access(l)).collect();
        assert_eq!(got, [false, false, true, false, true, false, false, true]);
    }

    /// A replay counts every line a read spans, per PE, and the busiest PE per ray: two PEs,
    /// two rays, 16-byte lines (4 words), 2 lines direct-mapped.
    #[test]
    fn a_replay_counts_lines_per_read_and_the_busiest_pe_per_ray() {
        let mut t = FrameTrace::new(2);
        let read = |pe, addr, words| PeRead { pe, addr, words, kind: PeReadKind::Record };
        // Ray 0: PE 0 reads words 2..12 (lines 0, 1, 2: 3 misses); PE 1 word 0 (1 miss).
        t.read(read(0, 2, 10));
        t.read(read(1, 0, 1));
        t.ray_end(&RayResult { cycles: 100, tests: 1, ..RayResult::MISS });
        // Ray 1: PE 0 reads word 8 (line 2: still there, a hit); PE 1 words 0 and 4..8
        // (line 0 hit, line 1 miss).
        t.read(read(0, 8, 1));
        t.read(read(1, 0, 1));
        t.read(read(1, 4, 4));
        t.ray_end(&RayResult { cycles: 50, tests: 2, ..RayResult::MISS });
        let r = replay(&t, cfg(32, 16, 1));
        assert_eq!((r.accesses, r.hits, r.misses), (7, 2, 5));
        assert_eq!(r.busiest_pe_misses, 3 + 1);
        assert_eq!(r.misses_by_kind, [0, 0, 5, 0]);
        assert_eq!((t.rays, t.cycles, t.tests), (2, 150, 3));
    }

    /// DP16KD counts: data in four 32-bit banks (2 KiB per block); tags one row per set.
    #[test]
    fn block_ram_counts_follow_the_dp16kd_shapes() {
        assert_eq!(dp16kd_blocks(512, 36), 1);
        assert_eq!(dp16kd_blocks(2048, 32), 4);
        assert_eq!(dp16kd_blocks(128, 74), 3);
        // 8 MiB per PE (32 MiB over 4 PEs): 23 address bits.
        let b = brams(cfg(8 << 10, 32, 2), SDRAM_BYTES / 4);
        // 128 sets × 32 B: 12 index bits, tag 11 + valid; 2 × 12 + 1 LRU bit = 25 wide.
        assert_eq!((b.data, b.tags, b.tag_bits), (4, 1, 12));
        let b = brams(cfg(32 << 10, 16, 4), SDRAM_BYTES / 4);
        assert_eq!((b.data, b.tag_bits), (16, 23 - 9 - 4 + 1));
        assert_eq!(MissModel::LITEDRAM_ULX3S.penalty(32), 12 + 16);
    }

    /// A row adds misses × penalty to the profile's cycles per ray: every miss in turn, or
    /// only the busiest PE's per ray.
    #[test]
    fn a_row_adds_the_miss_stalls_to_the_profiles_cycles() {
        let mut t = FrameTrace::new(4);
        t.rays = 10;
        t.cycles = 1_000;
        let rp = Replay { accesses: 100, hits: 80, misses: 20, busiest_pe_misses: 8, misses_by_kind: [2, 3, 15, 0] };
        let model = MissModel { latency: 10, bytes_per_cycle: 4 };
        let r = row("s", &t, cfg(4096, 16, 2), &rp, model);
        assert_eq!(r.miss_penalty, 14);
        assert_eq!((r.rtl_cycles_per_ray, r.cycles_per_ray), (100.0, 128.0));
        assert!((r.cycles_per_ray_overlapped - 111.2).abs() < 1e-9, "{}", r.cycles_per_ray_overlapped);
        assert_eq!((r.hit_rate, r.misses_per_ray, r.brams_all_pes), (0.8, 2.0, 4 * r.brams_per_pe));
        let line = csv(&[r]).lines().nth(1).unwrap().to_string();
        assert!(
            line.starts_with("s,4096,16,2,128,100,80,0.80000,20,2.000,2,3,15,0,14,100.00,128.00,111.20,"),
            "{line}"
        );
    }
}
