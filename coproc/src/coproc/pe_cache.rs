//! The PE caches' stall cycles (`PE_CACHE = 1`, rtl/README.md §4.6): an optional timing
//! model of the RTL's per-PE caches of an external memory, cycle by cycle as
//! `gridrt_pe_cache.sv` and the freeze controller and memory arbiter of `gridrt_coproc.sv`
//! spend them, behind the Verilator harness's memory (`rtl/sim/coproc_main.cpp`: one
//! request at a time, answered `mem_latency` cycles after it is seen).
//!
//! The co-processor's own timeline (its enabled cycles, the ones `RESULT.cycles` counts) is
//! the model's; this module replays, per enabled cycle, what each PE's memory port sees:
//!
//! - the controller's reads while a PE is idle: every cycle the controller does not write,
//!   the PE reads the window at the controller's address register (its voxel lookups, the
//!   result's prim, material and normal, and after LOAD_PE the last word written);
//! - LOAD_PE's writes (image words as they arrive, then each triangle's record and normal
//!   after the triangle loader's 35 cycles), one cycle late through the PE's write register;
//! - while a ray executes, each test's ref word (issue + 1) and its record's three windows
//!   (issue + 4, + 6, + 7), until the stop reaches the PEs (three cycles after the model's
//!   decision time T), tests issued after T included;
//! - the result stage's five reads (image words 9, 10, 0, 1, 2 of the winner's triangle;
//!   on a miss, of the triangle entry 0's PE still holds in its result memory, which this
//!   model follows from ray to ray as the RTL's result stage keeps it).
//!
//! Each cache is direct-mapped, `lines` lines of 8 words, line l at index l mod lines with
//! tag l / lines; a 4-word window at a looks up lines a / 8 and (a + 3) / 8 (the even and
//! odd tag RAMs) in the cycle after the read. A miss stops the co-processor: FILL (each
//! PE's write buffer drained, then its missed lines fetched word by word over the one
//! memory port, lowest PE first, each word an arbitration cycle and `mem_latency` cycles),
//! REPLAY_R, REPLAY_R2, and back to FILL if a replayed read misses; the write buffer (4
//! words) stops it too when it holds 3. After a reset every tag is cleared (lines / 2
//! stopped cycles) and each PE's first read misses; CLEAR and FRAME leave the tags as
//! they are, as the RTL does. The stopped cycles are
//! `CoprocStats::pe_stall_cycles`; the words read and written, `pe_mem_reads` and
//! `pe_mem_writes` (the harness's PE-memory counters).
//!
//! Not modelled: LOAD_PE packets that fail, rays refused with an error, stalled stream
//! handshakes (request words are taken one per cycle, as the harness without `--stall`
//! offers them), and analytic primitives (the RTL has none).

use crate::config::{ConfigError, CoprocConfig};

/// PEs the cache model covers (the RTL's PES is at most 16).
pub const PE_CACHE_MAX_PES: usize = 16;

/// Words of one PE's registers in the backing, after its tags ([`PeCacheConfig::state_words`]).
pub const PE_STATE_WORDS: usize = 19;

/// Write-buffer depth of `gridrt_pe_cache` (`WB_DEPTH`).
const WB_DEPTH: u32 = 4;

/// Cycles from the triangle loader's start to its `done` (`gridrt_tri_loader` LATENCY 35,
/// plus its start register): the idle cycles between a triangle's last image word and its
/// first record write.
const TRI_LOADER_IDLE: u32 = 36;

/// Record words (10) and normal words (3) LOAD_PE writes per triangle.
const TRI_WRITES: u32 = 13;

/// The PE caches of the RTL: geometry and the external memory's latency.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeCacheConfig {
    /// Lines of 8 words per PE (`CACHE_LINES`): a power of two, at least 2, fewer than
    /// `pe_mem_words / 8`.
    pub lines: u32,
    /// Cycles the external memory takes to answer a request (the harness's
    /// `--mem-latency`, at least 1).
    pub mem_latency: u32,
}

impl PeCacheConfig {
    /// Backing words the caches' state takes after the PE memories: per PE one tag word
    /// per line and [`PE_STATE_WORDS`] of registers (the model's own footprint stays small).
    pub const fn state_words(&self, pe_count: u16) -> usize {
        (pe_count as usize).saturating_mul((self.lines as usize).saturating_add(PE_STATE_WORDS))
    }

    /// Checks the caches against the co-processor they serve: at most
    /// [`PE_CACHE_MAX_PES`] PEs, `pe_mem_words` a power of two, `lines` a power of two
    /// from 2 below `pe_mem_words / 8`, a latency from 1.
    pub fn validate(&self, config: &CoprocConfig) -> Result<(), ConfigError> {
        let words = config.pe_mem_words;
        let ok = (config.pe_count as usize) <= PE_CACHE_MAX_PES
            && words.is_power_of_two()
            && self.lines >= 2
            && self.lines.is_power_of_two()
            && (self.lines as u64).saturating_mul(8) < words as u64
            && self.mem_latency >= 1;
        if ok {
            Ok(())
        } else {
            Err(ConfigError::PeCache)
        }
    }
}

/// The freeze controller's phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Run,
    Fill,
    ReplayR,
    ReplayR2,
}

/// A cache's memory side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ms {
    Clear = 0,
    Idle = 1,
    Write = 2,
    FillE = 3,
    FillO = 4,
}

/// One cache's registers (names as in `gridrt_pe_cache.sv`).
#[derive(Debug, Clone, Copy)]
struct Regs {
    te: u32,
    to: u32,
    le: u32,
    lo: u32,
    need_e: bool,
    need_o: bool,
    look_v: bool,
    look_a: u32,
    sav_r: u32,
    sav_r_v: bool,
    sav_r2: u32,
    sav_r2_v: bool,
    wb_n: u32,
    ms: Ms,
    clr: u32,
    pend_e: bool,
    pend_o: bool,
    pl_e: u32,
    pl_o: u32,
    fw: u32,
    req: bool,
}

impl Regs {
    /// After the harness's reset cycles: the tag clear ahead, and the lookup of the read
    /// at address 0 (the controller's address register) against a zero (invalid) tag.
    const RESET: Regs = Regs {
        te: 0,
        to: 0,
        le: 0,
        lo: 0,
        need_e: true,
        need_o: false,
        look_v: true,
        look_a: 0,
        sav_r: 0,
        sav_r_v: false,
        sav_r2: 0,
        sav_r2_v: false,
        wb_n: 0,
        ms: Ms::Clear,
        clr: 0,
        pend_e: false,
        pend_o: false,
        pl_e: 0,
        pl_o: 0,
        fw: 0,
        req: false,
    };
}

// Word offsets of a PE's registers after its tags.
const W_TE: usize = 0;
const W_TO: usize = 1;
const W_LE: usize = 2;
const W_LO: usize = 3;
const W_FLAGS: usize = 4;
const W_LOOK_A: usize = 5;
const W_SAV_R: usize = 6;
const W_SAV_R2: usize = 7;
const W_WB_N: usize = 8;
const W_MS: usize = 9;
const W_CLR: usize = 10;
const W_PL_E: usize = 11;
const W_PL_O: usize = 12;
const W_FW: usize = 13;
/// The controller's address register of the PE.
const W_A_ADDR: usize = 14;
/// The PE's write register: a write of the last enabled cycle, pushed this one.
const W_W_REG: usize = 15;
/// The controller's `pe_tri_off` of the PE (its image's triangle offset).
const W_TRI_OFF: usize = 16;
/// The PE's result stage: the triangle of its last Closest take (`best_tri`, kept across
/// rays) and what its result memory holds for list entry 0.
const W_BEST_TRI: usize = 17;
const W_RES_TRI0: usize = 18;

const F_NEED_E: u32 = 1;
const F_NEED_O: u32 = 2;
const F_LOOK_V: u32 = 4;
const F_SAV_R_V: u32 = 8;
const F_SAV_R2_V: u32 = 16;
const F_PEND_E: u32 = 32;
const F_PEND_O: u32 = 64;
const F_REQ: u32 = 128;
const F_W_REG: u32 = 256;

fn word(w: &[u32], i: usize) -> u32 {
    w.get(i).copied().unwrap_or(0)
}

fn set_word(w: &mut [u32], i: usize, v: u32) {
    if let Some(x) = w.get_mut(i) {
        *x = v;
    }
}

impl Regs {
    fn load(w: &[u32]) -> Regs {
        let f = word(w, W_FLAGS);
        Regs {
            te: word(w, W_TE),
            to: word(w, W_TO),
            le: word(w, W_LE),
            lo: word(w, W_LO),
            need_e: f & F_NEED_E != 0,
            need_o: f & F_NEED_O != 0,
            look_v: f & F_LOOK_V != 0,
            look_a: word(w, W_LOOK_A),
            sav_r: word(w, W_SAV_R),
            sav_r_v: f & F_SAV_R_V != 0,
            sav_r2: word(w, W_SAV_R2),
            sav_r2_v: f & F_SAV_R2_V != 0,
            wb_n: word(w, W_WB_N),
            ms: match word(w, W_MS) {
                0 => Ms::Clear,
                1 => Ms::Idle,
                2 => Ms::Write,
                3 => Ms::FillE,
                _ => Ms::FillO,
            },
            clr: word(w, W_CLR),
            pend_e: f & F_PEND_E != 0,
            pend_o: f & F_PEND_O != 0,
            pl_e: word(w, W_PL_E),
            pl_o: word(w, W_PL_O),
            fw: word(w, W_FW),
            req: f & F_REQ != 0,
        }
    }

    fn store(&self, w: &mut [u32]) {
        let flag = |b: bool, f: u32| if b { f } else { 0 };
        let keep = word(w, W_FLAGS) & F_W_REG;
        let f = flag(self.need_e, F_NEED_E)
            | flag(self.need_o, F_NEED_O)
            | flag(self.look_v, F_LOOK_V)
            | flag(self.sav_r_v, F_SAV_R_V)
            | flag(self.sav_r2_v, F_SAV_R2_V)
            | flag(self.pend_e, F_PEND_E)
            | flag(self.pend_o, F_PEND_O)
            | flag(self.req, F_REQ)
            | keep;
        for (i, v) in [
            (W_TE, self.te),
            (W_TO, self.to),
            (W_LE, self.le),
            (W_LO, self.lo),
            (W_FLAGS, f),
            (W_LOOK_A, self.look_a),
            (W_SAV_R, self.sav_r),
            (W_SAV_R2, self.sav_r2),
            (W_WB_N, self.wb_n),
            (W_MS, self.ms as u32),
            (W_CLR, self.clr),
            (W_PL_E, self.pl_e),
            (W_PL_O, self.pl_o),
            (W_FW, self.fw),
        ] {
            set_word(w, i, v);
        }
    }
}

/// What one PE's port does in an enabled cycle.
#[derive(Debug, Clone, Copy, Default)]
struct Port {
    read: Option<u32>,
    push: Option<u32>,
}

const VALID: u32 = 1 << 31;

/// The freeze controller, the memory arbiter and the harness's memory; the caches' tags and
/// registers, and the controller state each PE sees (its address register, the result
/// stage's leftovers), live in the caller's words (`st`: per PE its tags, then
/// [`PE_STATE_WORDS`]), so the model's own footprint stays small.
#[derive(Debug, Clone)]
pub(super) struct PeCacheTiming {
    cfg: PeCacheConfig,
    pes: usize,
    words: u32,
    amask: u32,
    iw: u32,
    phase: Phase,
    busy: bool,
    who: usize,
    mem_wait: i64,
    /// The PE of list entry 0 of the last ray with entries (`ent_pe_of[0]`).
    pub(super) ent_pe0: u8,
    /// Cycles stopped, words read (line fills) and written.
    stall_cycles: u64,
    reads: u64,
    writes: u64,
}

/// The tests a ray's execution issues, per PE, for [`PeCacheTiming::execute`].
pub(super) trait ExecSource {
    /// List entries.
    fn len(&self) -> usize;
    /// Entry `k`: its PE, the address of its first ref word and its tests.
    fn entry(&self, k: usize) -> (u8, u32, u32);
    /// The ref word at `addr` of PE `pe` (the triangle a test takes).
    fn ref_word(&self, pe: u8, addr: u32) -> u32;
}

/// A test in flight: issued in `at`, its ref word's address and its triangle.
#[derive(Debug, Clone, Copy)]
struct Issued {
    at: u64,
    ref_addr: u32,
    tri: u32,
}

/// One PE's issue loop (rtl/README.md §4.3): entries in list order, tests every 4 cycles.
#[derive(Debug, Clone, Copy, Default)]
struct Issuer {
    k: usize,
    j: u32,
    n: u32,
    first: u32,
    next: Option<u64>,
    clock: u64,
    last: [Option<Issued>; 2],
}

impl PeCacheTiming {
    /// The timing of `cfg`'s caches for `config`; `st` (its [`PeCacheConfig::state_words`])
    /// is set as after the RTL's reset.
    pub(super) fn new(cfg: PeCacheConfig, config: &CoprocConfig, st: &mut [u32]) -> Self {
        let words = config.pe_mem_words;
        let t = Self {
            cfg,
            pes: (config.pe_count as usize).min(PE_CACHE_MAX_PES),
            words,
            amask: words.wrapping_sub(1),
            iw: cfg.lines.trailing_zeros(),
            phase: Phase::Run,
            busy: false,
            who: 0,
            mem_wait: -1,
            ent_pe0: 0,
            stall_cycles: 0,
            reads: 0,
            writes: 0,
        };
        st.fill(0);
        for p in 0..t.pes {
            Regs::RESET.store(t.regs_mut(st, p));
        }
        t
    }

    /// PE `p`'s block of `st`: its tags, then its registers.
    fn block(&self, p: usize) -> core::ops::Range<usize> {
        let n = (self.cfg.lines as usize).saturating_add(PE_STATE_WORDS);
        let start = p.saturating_mul(n);
        start..start.saturating_add(n)
    }

    fn regs<'s>(&self, st: &'s [u32], p: usize) -> &'s [u32] {
        let b = self.block(p);
        st.get(b.start.saturating_add(self.cfg.lines as usize)..b.end).unwrap_or(&[])
    }

    fn regs_mut<'s>(&self, st: &'s mut [u32], p: usize) -> &'s mut [u32] {
        let b = self.block(p);
        st.get_mut(b.start.saturating_add(self.cfg.lines as usize)..b.end).unwrap_or(&mut [])
    }

    /// A word of PE `pe`'s controller state (`W_A_ADDR` .. `W_RES_TRI0`).
    fn get(&self, st: &[u32], pe: u8, i: usize) -> u32 {
        word(self.regs(st, pe as usize), i)
    }

    fn set(&self, st: &mut [u32], pe: u8, i: usize, v: u32) {
        set_word(self.regs_mut(st, pe as usize), i, v);
    }

    /// PE `pe`'s result stage: the triangle of its last Closest take.
    pub(super) fn best_tri(&self, st: &[u32], pe: u8) -> u32 {
        self.get(st, pe, W_BEST_TRI)
    }

    pub(super) fn set_best_tri(&self, st: &mut [u32], pe: u8, tri: u32) {
        self.set(st, pe, W_BEST_TRI, tri);
    }

    /// PE `pe`'s result memory at list entry 0.
    pub(super) fn res_tri0(&self, st: &[u32], pe: u8) -> u32 {
        self.get(st, pe, W_RES_TRI0)
    }

    pub(super) fn set_res_tri0(&self, st: &mut [u32], pe: u8, tri: u32) {
        self.set(st, pe, W_RES_TRI0, tri);
    }

    /// The PE's write register: `Some(address)` of last enabled cycle's write.
    fn w_reg(&self, st: &[u32], p: usize) -> Option<u32> {
        let r = self.regs(st, p);
        (word(r, W_FLAGS) & F_W_REG != 0).then(|| word(r, W_W_REG))
    }

    fn set_w_reg(&self, st: &mut [u32], p: usize, w: Option<u32>) {
        let r = self.regs_mut(st, p);
        let f = word(r, W_FLAGS) & !F_W_REG;
        set_word(r, W_FLAGS, if w.is_some() { f | F_W_REG } else { f });
        set_word(r, W_W_REG, w.unwrap_or(0));
    }

    /// Stopped cycles, words read, words written since the reset.
    pub(super) fn counters(&self) -> (u64, u64, u64) {
        (self.stall_cycles, self.reads, self.writes)
    }

    fn tag_index(&self, pe: usize, line: u32) -> usize {
        self.block(pe).start.saturating_add((line & self.cfg.lines.wrapping_sub(1)) as usize)
    }

    /// One clock cycle of every cache, the arbiter, the memory and the freeze controller;
    /// `ports` are the PEs' reads and pushes if the co-processor runs in it.
    fn clock(&mut self, tags: &mut [u32], ports: &[Port; PE_CACHE_MAX_PES]) {
        let run = self.phase == Phase::Run;
        // The harness's memory: a request seen starts its latency; the answer comes with ack.
        let mut ack = false;
        if self.mem_wait < 0 && self.busy {
            self.mem_wait = i64::from(self.cfg.mem_latency).wrapping_sub(1);
        }
        if self.mem_wait == 0 {
            ack = true;
        }
        if self.mem_wait >= 0 {
            self.mem_wait = self.mem_wait.wrapping_sub(1);
        }
        let mut any_hold = false;
        let mut all_ready = true;
        let mut pick: Option<usize> = None;
        for p in 0..self.pes {
            if word(self.regs(tags, p), W_FLAGS) & F_REQ != 0 && pick.is_none() {
                pick = Some(p);
            }
        }
        for p in 0..self.pes {
            let port = ports.get(p).copied().unwrap_or_default();
            let r = Regs::load(self.regs(tags, p));
            let (a, a_v) = match self.phase {
                Phase::ReplayR => (r.sav_r, r.sav_r_v),
                Phase::ReplayR2 => (r.sav_r2, r.sav_r2_v),
                _ => (port.read.unwrap_or(0), port.read.is_some() && run),
            };
            let l0 = a >> 3;
            let l1 = (a.wrapping_add(3) & self.amask) >> 3;
            let (le, lo) = if l0 & 1 == 1 { (l1, l0) } else { (l0, l1) };
            let need_e = l0 & 1 == 0 || (l1 != l0 && l1 & 1 == 0);
            let need_o = l0 & 1 == 1 || (l1 != l0 && l1 & 1 == 1);
            let hit = |t: u32, l: u32| t & VALID != 0 && (t & !VALID) == l >> self.iw;
            let miss_e = r.need_e && !hit(r.te, r.le);
            let miss_o = r.need_o && !hit(r.to, r.lo);
            let miss = r.look_v && (miss_e || miss_o);
            let look_lines = miss && (self.phase == Phase::Run || self.phase == Phase::ReplayR2);
            let push = if run { port.push } else { None };
            let m_ack = self.busy && ack && self.who == p;
            let hold = r.ms == Ms::Clear || miss || r.wb_n >= WB_DEPTH.wrapping_sub(1);
            let ready = r.ms == Ms::Idle && r.wb_n == 0 && !r.pend_e && !r.pend_o;
            any_hold |= hold;
            all_ready &= ready;

            // The tag RAMs' outputs for this cycle's address (read before this edge's write).
            let te_next = tags.get(self.tag_index(p, le)).copied().unwrap_or(0);
            let to_next = tags.get(self.tag_index(p, lo)).copied().unwrap_or(0);

            let mut n = r;
            let mut pop = false;
            // Tag writes: (line, value); the memory side's override a write's invalidation.
            let mut tw: [Option<(u32, u32)>; 2] = [None, None];
            if look_lines {
                n.pend_e = miss_e;
                n.pend_o = miss_o;
            }
            if let Some(w) = push {
                tw[0] = Some((w >> 3, 0));
            }
            match r.ms {
                Ms::Clear => {
                    let even = r.clr.wrapping_mul(2);
                    tw = [Some((even, 0)), Some((even.wrapping_add(1), 0))];
                    n.clr = r.clr.wrapping_add(1);
                    if r.clr == (self.cfg.lines / 2).wrapping_sub(1) {
                        n.ms = Ms::Idle;
                    }
                }
                Ms::Idle => {
                    if r.wb_n != 0 {
                        n.ms = Ms::Write;
                        n.req = true;
                    } else if self.phase == Phase::Fill && (r.pend_e || r.pend_o) {
                        n.ms = if r.pend_e { Ms::FillE } else { Ms::FillO };
                        n.fw = 0;
                        n.req = true;
                    }
                }
                Ms::Write => {
                    if m_ack {
                        pop = true;
                        n.req = false;
                        n.ms = Ms::Idle;
                        self.writes = self.writes.saturating_add(1);
                    }
                }
                Ms::FillE | Ms::FillO => {
                    if m_ack {
                        self.reads = self.reads.saturating_add(1);
                        n.fw = r.fw.wrapping_add(1) & 7;
                        if r.fw == 7 {
                            let line = if r.ms == Ms::FillE { r.pl_e } else { r.pl_o };
                            tw = [Some((line, VALID | (line >> self.iw))), None];
                            if r.ms == Ms::FillE {
                                n.pend_e = false;
                            } else {
                                n.pend_o = false;
                            }
                            if r.ms == Ms::FillE && r.pend_o {
                                n.ms = Ms::FillO;
                            } else {
                                n.ms = Ms::Idle;
                                n.req = false;
                            }
                        }
                    }
                }
            }
            // The edge.
            for (line, val) in tw.into_iter().flatten() {
                let i = self.tag_index(p, line);
                if let Some(t) = tags.get_mut(i) {
                    *t = val;
                }
            }
            n.te = te_next;
            n.to = to_next;
            n.le = le;
            n.lo = lo;
            n.need_e = need_e;
            n.need_o = need_o;
            n.look_v = a_v;
            n.look_a = a;
            n.wb_n = r.wb_n.wrapping_add(u32::from(push.is_some())).wrapping_sub(u32::from(pop));
            if run {
                n.sav_r = r.look_a;
                n.sav_r_v = r.look_v;
                n.sav_r2 = a;
                n.sav_r2_v = a_v;
            }
            if look_lines {
                n.pl_e = r.le;
                n.pl_o = r.lo;
            }
            n.store(self.regs_mut(tags, p));
        }
        // The arbiter: one word per grant, the lowest requesting PE first.
        let was_busy = self.busy;
        if self.busy && ack {
            self.busy = false;
        } else if !self.busy && pick.is_some() {
            self.busy = true;
        }
        if !was_busy {
            self.who = pick.unwrap_or(0);
        }
        // The freeze controller.
        if self.phase != Phase::Run {
            self.stall_cycles = self.stall_cycles.saturating_add(1);
        }
        self.phase = match self.phase {
            Phase::Run | Phase::ReplayR2 if any_hold => Phase::Fill,
            Phase::Run | Phase::ReplayR2 => Phase::Run,
            Phase::Fill if all_ready => Phase::ReplayR,
            Phase::Fill => Phase::Fill,
            Phase::ReplayR => Phase::ReplayR2,
        };
    }

    /// One enabled cycle: `exec` are the executing PEs' reads (None while they are idle:
    /// then each reads at its address register unless the controller writes it); `write`
    /// the controller's write in this cycle (PE, address), which becomes the address
    /// register too. Then the cycles the co-processor stands still, if it stops.
    fn enabled(&mut self, tags: &mut [u32], exec: Option<&[Option<u32>; PE_CACHE_MAX_PES]>, write: Option<(u8, u32)>) {
        if let Some((pe, addr)) = write {
            self.set(tags, pe, W_A_ADDR, addr & self.amask);
        }
        let mut ports = [Port::default(); PE_CACHE_MAX_PES];
        for (p, port) in ports.iter_mut().enumerate().take(self.pes) {
            let writing = write.is_some_and(|(pe, _)| pe as usize == p);
            port.read = match exec {
                Some(reads) => reads.get(p).copied().flatten(),
                None if writing => None,
                None => Some(word(self.regs(tags, p), W_A_ADDR)),
            };
            port.push = self.w_reg(tags, p);
        }
        for p in 0..self.pes {
            let w = match write {
                Some((pe, addr)) if exec.is_none() && pe as usize == p => Some(addr & self.amask),
                _ => None,
            };
            self.set_w_reg(tags, p, w);
        }
        self.clock(tags, &ports);
        // Bounded: a stop ends once every fill and write is done (at most a few thousand
        // cycles); the bound only guards against a modelling error.
        for _ in 0..1_000_000u32 {
            if self.phase == Phase::Run {
                break;
            }
            self.clock(tags, &[Port::default(); PE_CACHE_MAX_PES]);
        }
    }

    /// `n` enabled cycles in which the controller only reads.
    fn idle(&mut self, tags: &mut [u32], n: u32) {
        for _ in 0..n {
            self.enabled(tags, None, None);
        }
    }

    /// A packet without PE-memory traffic (FRAME, CLEAR): one cycle, which after a reset is
    /// the one that starts the tag clear.
    pub(super) fn other_packet(&mut self, tags: &mut [u32]) {
        self.idle(tags, 1);
    }

    /// A LOAD_PE of `len` image words into PE `pe` that the model accepted: header and count
    /// words, the image words written as they arrive, each triangle's record (at
    /// `pe_mem_words - 10 (t + 1)`) and normal (over its vertex a) after its last word.
    pub(super) fn load(&mut self, tags: &mut [u32], pe: u8, image: &[u32]) {
        let word = |i: usize| image.get(i).copied().unwrap_or(0);
        let (tris, voxels, refs) = (word(1), word(2), word(3));
        let ref_end = 5u32.wrapping_add(voxels.wrapping_mul(3)).wrapping_add(refs);
        let tri_end = ref_end.wrapping_add(tris.wrapping_mul(11));
        self.set(tags, pe, W_TRI_OFF, ref_end & self.amask);
        // Header, count, and the first image word's cycle (its write is registered).
        self.idle(tags, 3);
        let mut rec = self.words.wrapping_sub(10);
        for (i, _) in image.iter().enumerate() {
            let i = i as u32;
            self.enabled(tags, None, Some((pe, i)));
            let in_tris = i >= ref_end && i < tri_end;
            if in_tris && (i.wrapping_sub(ref_end)) % 11 == 10 {
                let tri_base = i.wrapping_sub(10);
                self.idle(tags, TRI_LOADER_IDLE);
                for j in 0..TRI_WRITES {
                    let addr = if j < 10 { rec.wrapping_add(j) } else { tri_base.wrapping_add(j.wrapping_sub(10)) };
                    self.enabled(tags, None, Some((pe, addr)));
                }
                rec = rec.wrapping_sub(10);
            }
        }
        // The ACK goes out; the last word's line, invalid now, is read back.
        self.idle(tags, 8);
    }

    /// The controller's voxel lookup of one list entry on PE `pe`: each probe's id word
    /// (`5 + 3 mid`, four cycles, three at the match), then the match's first-ref and
    /// count words.
    pub(super) fn lookup(&mut self, tags: &mut [u32], pe: u8, probes: &[u32], matched: Option<u32>) {
        for (i, &mid) in probes.iter().enumerate() {
            let last = i.wrapping_add(1) == probes.len();
            let cycles = if last && matched.is_some() { 3 } else { 4 };
            self.set_addr(tags, pe, 5u32.wrapping_add(mid.wrapping_mul(3)));
            self.idle(tags, cycles);
        }
        if let Some(mid) = matched {
            self.set_addr(tags, pe, 6u32.wrapping_add(mid.wrapping_mul(3)));
            self.idle(tags, 1);
            self.set_addr(tags, pe, 7u32.wrapping_add(mid.wrapping_mul(3)));
            self.idle(tags, 4);
        }
    }

    fn set_addr(&mut self, tags: &mut [u32], pe: u8, addr: u32) {
        self.set(tags, pe, W_A_ADDR, addr & self.amask);
    }

    /// A ray's execution (exec cycles 0 ..= `end` + 3: the stop reaches the PEs three
    /// cycles after the decision at `end`), then the result stage's reads of triangle
    /// `win_tri` on PE `win_pe` (image words 9, 10, 0, 1, 2 from exec cycle `end` + 8).
    pub(super) fn execute(&mut self, tags: &mut [u32], src: &dyn ExecSource, end: u64, win_pe: u8, win_tri: u32) {
        // The header's and the ray setup's cycles: the lookups' last reads are looked up.
        self.idle(tags, 2);
        let mut iss = [Issuer::default(); PE_CACHE_MAX_PES];
        for (p, it) in iss.iter_mut().enumerate().take(self.pes) {
            advance_entry(it, src, p);
        }
        let last_exec = end.saturating_add(3);
        let mut e = 0u64;
        while e <= last_exec {
            let mut reads = [None; PE_CACHE_MAX_PES];
            for (p, it) in iss.iter_mut().enumerate().take(self.pes) {
                if it.next == Some(e) {
                    let ref_addr = (it.first.wrapping_add(it.j)) & self.amask;
                    let tri = src.ref_word(p as u8, ref_addr);
                    it.last = [it.last[1], Some(Issued { at: e, ref_addr, tri })];
                    it.j = it.j.wrapping_add(1);
                    if it.j < it.n {
                        it.next = Some(e.saturating_add(4));
                    } else {
                        it.clock = e.saturating_add(4);
                        it.k = it.k.saturating_add(1);
                        advance_entry(it, src, p);
                    }
                }
                let rec = |t: &Issued, off: u32| {
                    self.words.wrapping_sub(off).wrapping_sub(t.tri.wrapping_mul(10)) & self.amask
                };
                for t in it.last.iter().flatten() {
                    let age = e.wrapping_sub(t.at);
                    let read = match age {
                        1 => Some(t.ref_addr),
                        4 => Some(rec(t, 10)),
                        6 => Some(rec(t, 6)),
                        7 => Some(rec(t, 2)),
                        _ => None,
                    };
                    if let (Some(r), Some(slot)) = (read, reads.get_mut(p)) {
                        *slot = Some(r);
                    }
                }
            }
            self.enabled(tags, Some(&reads), None);
            e = e.saturating_add(1);
        }
        // Stopped: the PEs read at their address registers again (exec end + 4 on); the
        // result stage moves the winner's PE's from end + 8.
        self.idle(tags, 4);
        let base = self.get(tags, win_pe, W_TRI_OFF).wrapping_add(win_tri.wrapping_mul(11));
        for off in [9u32, 10, 0, 1, 2] {
            self.set_addr(tags, win_pe, base.wrapping_add(off));
            self.idle(tags, 1);
        }
        // The result words and the reply.
        self.idle(tags, 6);
    }
}

/// Moves `it` to its PE's next list entry from `it.k` on (voxel setup 4 cycles, entries
/// without tests take the setup alone), or leaves it without a next issue.
fn advance_entry(it: &mut Issuer, src: &dyn ExecSource, p: usize) {
    while it.k < src.len() {
        let (pe, first, n) = src.entry(it.k);
        if pe as usize == p {
            let issue = it.clock.saturating_add(4);
            if n == 0 {
                it.clock = issue;
                it.k = it.k.saturating_add(1);
                continue;
            }
            it.first = first;
            it.n = n;
            it.j = 0;
            it.next = Some(issue);
            return;
        }
        it.k = it.k.saturating_add(1);
    }
    it.next = None;
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use crate::config::CoprocConfig;
    use crate::timing::TimingProfile;

    fn config() -> CoprocConfig {
        CoprocConfig {
            pe_count: 4,
            pe_mem_words: 16384,
            max_list: 256,
            timing: TimingProfile::RTL,
            ..CoprocConfig::GRIDRT
        }
    }

    /// After the reset, cold: the tag clear (lines / 2 cycles) and each PE's first read
    /// (address 0) filled, lowest PE first, then REPLAY_R and REPLAY_R2.
    #[test]
    fn the_reset_clears_the_tags_and_fills_each_pes_first_line() {
        for (lines, lat) in [(16u32, 1u32), (512, 8), (16, 23)] {
            let caches = PeCacheConfig { lines, mem_latency: lat };
            let mut tags = vec![0u32; caches.state_words(4)];
            let mut c = PeCacheTiming::new(caches, &config(), &mut tags);
            c.other_packet(&mut tags);
            let fill = 4 * 8 * (lat as u64 + 1);
            assert_eq!(c.counters(), (lines as u64 / 2 + fill + 3, 32, 0), "{lines} lines, latency {lat}");
        }
    }

    /// A read that misses one line stops the co-processor for 8 (latency + 1) + 4 cycles:
    /// the FILL's first and last cycle, 8 words of an arbitration cycle and the latency
    /// each, REPLAY_R, REPLAY_R2; a window across two lines fetches both in one stop.
    #[test]
    fn a_miss_costs_its_line_fills_and_two_replays() {
        for lat in [1u32, 8, 23] {
            let caches = PeCacheConfig { lines: 16, mem_latency: lat };
            let mut tags = vec![0u32; caches.state_words(4)];
            let mut c = PeCacheTiming::new(caches, &config(), &mut tags);
            c.other_packet(&mut tags);
            let (s0, r0, _) = c.counters();
            // Probe mid 100: the window at 305..=308, line 38 only.
            c.lookup(&mut tags, 1, &[100], None);
            let (s1, r1, _) = c.counters();
            assert_eq!((s1 - s0, r1 - r0), (8 * (lat as u64 + 1) + 4, 8), "latency {lat}");
            // Probe mid 3: the window at 14..=17, lines 1 and 2.
            c.lookup(&mut tags, 1, &[3], None);
            let (s2, r2, _) = c.counters();
            assert_eq!((s2 - s1, r2 - r1), (16 * (lat as u64 + 1) + 4, 16), "latency {lat}");
            // Read again: hits.
            c.lookup(&mut tags, 1, &[3], None);
            assert_eq!(c.counters().0, s2);
        }
    }
}
