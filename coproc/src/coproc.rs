//! The co-processor: PE memories, the FSL word interface, arbitration and cycle accounting.
//!
//! Source: GridRT (Nery 2010, seed 004 §1.3, §2.5–2.6, §6.2) with its cross-voxel flaw fixed
//! (DESIGN.md §5, CONTRACTS.md "Ray queries"); packet formats from `gridrt_shared::fsl`.
//!
//! # Packets (host → co-processor)
//!
//! | packet | words | reply |
//! |---|---|---|
//! | LOAD_PE | `load_header(pe)`, word count N, N image words | [`load_ack`]`(pe)` |
//! | CLEAR | `CLEAR_WORD` | [`CLEAR_ACK`] |
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

use heapless::{Deque, Vec as HVec};

use gridrt_shared::fsl::{self, op, FslError, FslWord, ListEntry, RayKind, RayResult, RAY_HEADER_WORDS, VOXEL_MASK};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::{PeImage, MAX_PES, PRIM_WORDS, TRIANGLE_WORDS, VOXEL_ENTRY_WORDS};

use crate::config::{ArbitrationRule, ConfigError, CoprocConfig, LIST_CAPACITY, OUT_QUEUE_WORDS};
use crate::isect::{geometric_normal, with_kernel, Kernel, RecordStatus, Triangle};
use crate::numeric::{FixedFrame, NumberFormat, Overflow};
use crate::timing::PeTimeline;

/// The number format the PEs compute in and its fixed-point frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Numerics {
    format: NumberFormat,
    frame: FixedFrame,
}

/// Relative tolerance on a list entry's exit distance: a hit is accepted in entry k if
/// `t ≤ t_exit·(1 + T_EXIT_REL_TOL)`.
pub const T_EXIT_REL_TOL: f32 = 1.0 / 4096.0;

/// Reply to CLEAR (SPEC §4.4: `0x94000000`).
pub const CLEAR_ACK: u32 = fsl::ack_word(op::CLEAR, 0);

/// Reply to a successful LOAD_PE of `pe` (SPEC §4.4: `0x910000pe`).
pub const fn load_ack(pe: u8) -> u32 {
    fsl::ack_word(op::LOAD_PE, pe)
}

/// Counters of the model since creation or [`Coprocessor::reset_stats`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CoprocStats {
    /// Ray queries answered with a result (word or direct API; not `trace_untimed`).
    pub rays: u64,
    /// Of which with a hit.
    pub hits: u64,
    /// Ray–triangle tests charged (started before each ray completed; see `timing`).
    pub tests: u64,
    /// Cycles of answered rays and successful loads.
    pub cycles: u64,
    /// Words pushed into the model.
    pub words_in: u64,
    /// Words queued for output.
    pub words_out: u64,
    /// Protocol violations reported (word or direct API).
    pub errors: u64,
    /// Successful PE loads.
    pub loads: u64,
    /// Output words dropped because the output queue was full (the reader did not pop).
    pub out_dropped: u64,
    /// Ray–triangle tests (timed path) whose fixed-point arithmetic overflowed: reported and
    /// counted as misses, never wrapped.
    pub overflows: u64,
    /// Triangle records found degenerate at load (zero area): they never hit.
    pub degenerate_records: u64,
    /// Triangle records whose precomputed values do not fit the fixed-point storage at load
    /// (every test of them counts in `overflows`).
    pub overflow_records: u64,
}

/// What an untimed trace saw besides its result ([`Coprocessor::trace_untimed_with_info`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraceInfo {
    /// Tests performed (entries up to the winner), not saturated.
    pub tests: u64,
    /// Tests whose fixed-point arithmetic overflowed (counted as misses).
    pub overflows: u64,
}

/// Layout of one loaded PE image (offsets relative to the PE's memory base).
#[derive(Debug, Clone, Copy, Default)]
struct PeSlot {
    loaded: bool,
    len: u32,
    voxels: u32,
    ref_off: u32,
    tri_off: u32,
    /// Words before the voxel table (3 for a v1 image, 5 for v2).
    hdr: u32,
    /// Triangles T (refs ≥ T name analytic primitives, scene image v2).
    tris: u32,
    /// Offset of the primitive records.
    prim_off: u32,
}

/// Checks a PE image beyond `PeImage::parse`: voxel ids strictly increasing (so lookups can
/// binary-search) and materials that fit the 16-bit result field.
fn validate_image(words: &[u32]) -> Option<PeSlot> {
    let img = PeImage::parse(words).ok()?;
    let voxels = img.voxel_count();
    let mut prev: Option<u32> = None;
    for i in 0..voxels {
        let (id, _, _) = img.voxel_entry(i)?;
        if prev.is_some_and(|p| id <= p) {
            return None;
        }
        prev = Some(id);
    }
    for i in 0..img.triangle_count() {
        if img.triangle(i)?.material > u16::MAX as u32 {
            return None;
        }
    }
    for i in 0..img.primitive_count() {
        if img.primitive(i)?.material > u16::MAX as u32 {
            return None;
        }
    }
    let ref_off = img.header_words() + voxels * VOXEL_ENTRY_WORDS;
    let tri_off = ref_off + img.ref_table().len();
    Some(PeSlot {
        loaded: true,
        len: u32::try_from(words.len()).ok()?,
        voxels: u32::try_from(voxels).ok()?,
        ref_off: u32::try_from(ref_off).ok()?,
        tri_off: u32::try_from(tri_off).ok()?,
        hdr: u32::try_from(img.header_words()).ok()?,
        tris: u32::try_from(img.triangle_count()).ok()?,
        prim_off: u32::try_from(img.primitive_offset()).ok()?,
    })
}

/// Where an entry's references live: absolute index of its first ref word, ref count, and
/// absolute index of its PE's triangle records.
#[derive(Debug, Clone, Copy)]
struct EntryRefs {
    first: usize,
    count: u32,
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
struct Found {
    /// List position.
    k: usize,
    /// Absolute index of the triangle (or primitive) record.
    rec: usize,
    /// The record is an analytic primitive (scene image v2).
    prim: bool,
    t: f32,
    /// Tests the winning entry performed (all of them for Closest; up to the hit for Any).
    tests_in_entry: u32,
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

#[inline(always)]
fn record(rec: &[u32; TRIANGLE_WORDS]) -> Triangle {
    let f = f32::from_bits;
    [
        Vec3::new(f(rec[0]), f(rec[1]), f(rec[2])),
        Vec3::new(f(rec[3]), f(rec[4]), f(rec[5])),
        Vec3::new(f(rec[6]), f(rec[7]), f(rec[8])),
    ]
}

/// Read-only view of the PE memories (shared by the timed and untimed paths).
#[derive(Clone, Copy)]
struct View<'a> {
    cfg: &'a CoprocConfig,
    mem: &'a [u32],
    pes: &'a [PeSlot; MAX_PES],
    loaded_pes: u16,
    rule: ArbitrationRule,
    numerics: Numerics,
}

impl View<'_> {
    /// Binary search of `voxel` in PE `pe`'s voxel table.
    fn lookup(&self, pe: u8, voxel: u32) -> Option<EntryRefs> {
        let slot = self.pes.get(pe as usize)?;
        if !slot.loaded {
            return None;
        }
        let base = pe as usize * self.cfg.pe_mem_words as usize;
        let table = self.mem.get(base + slot.hdr as usize..base + slot.ref_off as usize)?;
        let (mut lo, mut hi) = (0usize, slot.voxels as usize);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            let id = *table.get(mid * VOXEL_ENTRY_WORDS)?;
            if id < voxel {
                lo = mid + 1;
            } else if id > voxel {
                hi = mid;
            } else {
                let first = *table.get(mid * VOXEL_ENTRY_WORDS + 1)? as usize;
                let count = *table.get(mid * VOXEL_ENTRY_WORDS + 2)?;
                return Some(EntryRefs {
                    first: base + slot.ref_off as usize + first,
                    count,
                    tri_base: base + slot.tri_off as usize,
                    tris: slot.tris,
                    prim_base: base + slot.prim_off as usize,
                    rec_base: base + slot.len as usize,
                });
            }
        }
        None
    }

    /// Request-level checks (ray header and ray words).
    fn check_header(&self, count: usize) -> Result<(), (FslError, u16)> {
        if self.loaded_pes == 0 {
            return Err((FslError::SceneNotLoaded, 0));
        }
        if count > self.cfg.max_list as usize {
            return Err((FslError::ListTooLong, self.cfg.max_list));
        }
        Ok(())
    }

    fn check_ray(ray: &Ray, t_max: f32) -> Result<(), (FslError, u16)> {
        let comps = [ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z];
        if let Some(i) = comps.iter().position(|c| !c.is_finite()) {
            return Err((FslError::NonFiniteRay, 1 + i as u16));
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
    fn check_entry_target(&self, k: usize, pe: u8, voxel: u32) -> Result<EntryRefs, (FslError, u16)> {
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
    fn check_entry_exit(k: usize, t_exit: f32) -> Result<(), (FslError, u16)> {
        if t_exit.is_nan() {
            let word = RAY_HEADER_WORDS + 2 * k + 1;
            return Err((FslError::NonFiniteRay, word.min(u16::MAX as usize) as u16));
        }
        Ok(())
    }

    /// Every check of a request, in wire order.
    fn validate(&self, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Result<(), (FslError, u16)> {
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
        let Some(list) = self.mem.get(refs.first..refs.first.saturating_add(refs.count as usize)) else {
            return (None, 0);
        };
        let limit = if t_max < hi { t_max } else { hi };
        let mut best: Option<(f32, usize, u32, bool)> = None;
        let mut bound = inflate(limit);
        for (i, &r) in list.iter().enumerate() {
            if r >= refs.tris {
                // Analytic primitive (scene image v2): same acceptance and arbitration.
                let rec = refs.prim_base + (r - refs.tris) as usize * PRIM_WORDS;
                let Some(words) = self.mem.get(rec..rec + PRIM_WORDS) else { continue };
                let Ok(words) = <&[u32; PRIM_WORDS]>::try_from(words) else { continue };
                let Some(t) = crate::isect::analytic::intersect(words, ray) else { continue };
                if !accept(t, t_max, hi) {
                    continue;
                }
                match kind {
                    RayKind::Any => return (Some((t, rec, true)), i as u32 + 1),
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
            let rec = refs.tri_base + r as usize * TRIANGLE_WORDS;
            let Some(words) = self.mem.get(rec..rec + TRIANGLE_WORDS) else { continue };
            let Ok(words) = <&[u32; TRIANGLE_WORDS]>::try_from(words) else { continue };
            // The kernel's record: the image's vertex words, or its load-time table entry.
            let kr = if K::USES_IMAGE { rec } else { refs.rec_base + r as usize * K::RECORD_WORDS };
            let Some(kwords) = self.mem.get(kr..kr + K::RECORD_WORDS) else { continue };
            let t = match K::intersect(pre, kwords, bound) {
                Ok(Some(t)) => t,
                Ok(None) => continue,
                Err(Overflow) => {
                    *overflows += 1;
                    continue;
                }
            };
            if !accept(t, t_max, hi) {
                continue;
            }
            match kind {
                RayKind::Any => return (Some((t, rec, false)), i as u32 + 1),
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
                    info.tests += self.lookup(e.pe, e.voxel).map_or(0, |r| r.count as u64);
                }
                info.overflows = info.tests;
                return (None, info);
            }
        };
        for (k, e) in list.iter().enumerate() {
            let Some(refs) = self.lookup(e.pe, e.voxel) else { continue };
            let (hit, n) = self.test_entry::<K>(&pre, ray, kind, refs, t_max, self.entry_hi(e), &mut info.overflows);
            info.tests += n as u64;
            if let Some((t, rec, prim)) = hit {
                return (Some(Found { k, rec, prim, t, tests_in_entry: n }), info);
            }
        }
        (None, info)
    }

    fn search_dyn(&self, kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> (Option<Found>, TraceInfo) {
        with_kernel!(self.cfg.kernel, self.numerics.format, K => self.search::<K>(kind, ray, t_max, list))
    }

    /// The result words' content for a winner (tests/cycles filled by the caller).
    fn result_of(&self, list: &[ListEntry], found: Option<Found>, ray: &Ray) -> RayResult {
        let Some(f) = found else { return RayResult::MISS };
        let Some(e) = list.get(f.k) else { return RayResult::MISS };
        if f.prim {
            let Some(words) = self.mem.get(f.rec..f.rec + PRIM_WORDS) else { return RayResult::MISS };
            let Ok(words) = <&[u32; PRIM_WORDS]>::try_from(words) else { return RayResult::MISS };
            return RayResult {
                hit: true,
                pe: e.pe,
                list_pos: f.k.min(u16::MAX as usize) as u16,
                t: f.t,
                prim: words[1],
                material: words[2] as u16,
                tests: 0,
                normal: crate::isect::analytic::normal(words, ray, f.t),
                cycles: 0,
            };
        }
        let Some(words) = self.mem.get(f.rec..f.rec + TRIANGLE_WORDS) else { return RayResult::MISS };
        let Ok(words) = <&[u32; TRIANGLE_WORDS]>::try_from(words) else { return RayResult::MISS };
        let n = geometric_normal(&record(words));
        RayResult {
            hit: true,
            pe: e.pe,
            list_pos: f.k.min(u16::MAX as usize) as u16,
            t: f.t,
            prim: words[9],
            material: words[10] as u16,
            tests: 0,
            normal: [n.x, n.y, n.z],
            cycles: 0,
        }
    }
}

/// Everything but the link buffers (split so a buffered list can be traced in place).
struct Core<'m> {
    cfg: CoprocConfig,
    mem: &'m mut [u32],
    pes: [PeSlot; MAX_PES],
    loaded_pes: u16,
    rule: ArbitrationRule,
    numerics: Numerics,
    clocks: [u64; MAX_PES],
    stats: CoprocStats,
}

impl Core<'_> {
    fn view(&self) -> View<'_> {
        let numerics = self.numerics;
        View { cfg: &self.cfg, mem: self.mem, pes: &self.pes, loaded_pes: self.loaded_pes, rule: self.rule, numerics }
    }

    fn base(&self, pe: u8) -> usize {
        pe as usize * self.cfg.pe_mem_words as usize
    }

    /// Marks `pe` empty (start of a LOAD).
    fn begin_load(&mut self, pe: u8) {
        if let Some(slot) = self.pes.get_mut(pe as usize) {
            if slot.loaded {
                self.loaded_pes -= 1;
            }
            *slot = PeSlot::default();
        }
    }

    /// Validates the `len` words already written at `pe`'s base, builds the kernel's record
    /// table after them if it needs one (module doc), and installs them.
    fn finish_load(&mut self, pe: u8, len: usize) -> Result<(), FslError> {
        let base = self.base(pe);
        let words = self.mem.get(base..base + len).ok_or(FslError::PeMemoryOverflow)?;
        let slot = validate_image(words).ok_or(FslError::PeImageMalformed)?;
        with_kernel!(self.cfg.kernel, self.numerics.format, K => {
            if !K::USES_IMAGE {
                self.build_records::<K>(base, &slot)?;
            }
        });
        let dst = self.pes.get_mut(pe as usize).ok_or(FslError::PeOutOfRange)?;
        *dst = slot;
        self.loaded_pes += 1;
        self.stats.loads += 1;
        let t = &self.cfg.timing;
        self.stats.cycles += (2 + len as u64) * t.word_in_cycles as u64 + t.word_out_cycles as u64;
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
        for i in 0..tris {
            let src = base + slot.tri_off as usize + i * TRIANGLE_WORDS;
            let words =
                self.mem.get(src..src + TRIANGLE_WORDS).and_then(|w| <&[u32; TRIANGLE_WORDS]>::try_from(w).ok());
            let tri = record(words.ok_or(FslError::PeImageMalformed)?);
            let dst = base + rec_off + i * K::RECORD_WORDS;
            let out = self.mem.get_mut(dst..dst + K::RECORD_WORDS).ok_or(FslError::PeMemoryOverflow)?;
            match K::precompute(&tri, &frame, out) {
                RecordStatus::Ok => {}
                RecordStatus::Degenerate => self.stats.degenerate_records += 1,
                RecordStatus::Overflow => self.stats.overflow_records += 1,
            }
        }
        Ok(())
    }

    fn clear(&mut self) {
        self.pes = [PeSlot::default(); MAX_PES];
        self.loaded_pes = 0;
    }

    /// The timed path: validation, functional search, PE timeline, statistics.
    fn trace_timed(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Result<RayResult, (FslError, u16)> {
        let numerics = self.numerics;
        let view = View {
            cfg: &self.cfg,
            mem: self.mem,
            pes: &self.pes,
            loaded_pes: self.loaded_pes,
            rule: self.rule,
            numerics,
        };
        view.validate(ray, t_max, list)?;
        let (found, info) = view.search_dyn(kind, ray, t_max, list);
        let mut result = view.result_of(list, found, ray);

        // Timeline (module doc of `timing`): pass 1 finds the completion time T of entries
        // 0..=w, pass 2 charges the tests every entry had started by T.
        let tests_of = |k: usize, e: &ListEntry| match found {
            Some(f) if f.k == k => f.tests_in_entry,
            _ => view.lookup(e.pe, e.voxel).map_or(0, |r| r.count),
        };
        let last = found.map_or(list.len(), |f| f.k + 1);
        let profile = self.cfg.timing;
        for e in list {
            if let Some(c) = self.clocks.get_mut(e.pe as usize) {
                *c = 0;
            }
        }
        let mut end = 0u64;
        {
            let mut tl = PeTimeline::new(&profile, &mut self.clocks);
            for (k, e) in list.iter().enumerate().take(last) {
                end = end.max(tl.schedule(e.pe, tests_of(k, e)).done);
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
            for (k, e) in list.iter().enumerate() {
                let n = tests_of(k, e);
                let at = tl.schedule(e.pe, n);
                tests += tl.started_before(at, n, end) as u64;
            }
        }
        let cycles = profile.ray_io_cycles(list.len()) + end;
        result.tests = tests.min(u16::MAX as u64) as u16;
        result.cycles = cycles.min(u32::MAX as u64) as u32;
        self.stats.rays += 1;
        self.stats.hits += result.hit as u64;
        self.stats.tests += tests;
        self.stats.cycles += cycles;
        self.stats.overflows += info.overflows;
        Ok(result)
    }
}

/// Receiver state of the inbound word stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rx {
    /// Between packets.
    Idle,
    /// After an error: dropping words up to and including the next control word.
    Discard,
    /// LOAD_PE header seen; the word count is next.
    LoadCount { pe: u8 },
    /// Receiving `declared` image words, `got` so far.
    LoadWords { pe: u8, declared: u32, got: u32 },
    /// Receiving a ray request; `idx` is the index of the next word in the packet.
    Ray { kind: RayKind, count: u16, idx: u32 },
}

/// The co-processor model. Holds no allocation: PE memories live in the caller's `backing`.
pub struct Coprocessor<'m> {
    core: Core<'m>,
    rx: Rx,
    head: [u32; RAY_HEADER_WORDS],
    pending: u32,
    list: HVec<ListEntry, LIST_CAPACITY>,
    out: Deque<FslWord, OUT_QUEUE_WORDS>,
}

impl core::fmt::Debug for Coprocessor<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Coprocessor")
            .field("config", &self.core.cfg)
            .field("loaded_pes", &self.core.loaded_pes)
            .field("rx", &self.rx)
            .field("stats", &self.core.stats)
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
        Ok(Self {
            core: Core {
                cfg: config,
                mem,
                pes: [PeSlot::default(); MAX_PES],
                loaded_pes: 0,
                rule: ArbitrationRule::default(),
                numerics: Numerics::default(),
                clocks: [0; MAX_PES],
                stats: CoprocStats::default(),
            },
            rx: Rx::Idle,
            head: [0; RAY_HEADER_WORDS],
            pending: 0,
            list: HVec::new(),
            out: Deque::new(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &CoprocConfig {
        &self.core.cfg
    }

    /// The arbitration rule in force (default [`ArbitrationRule::IntervalChecked`]).
    pub fn arbitration(&self) -> ArbitrationRule {
        self.core.rule
    }

    /// Switches the arbitration rule (GridRT's original rule is for comparisons only).
    pub fn set_arbitration(&mut self, rule: ArbitrationRule) {
        self.core.rule = rule;
    }

    /// The number format the PEs compute in (default [`NumberFormat::F32`]).
    pub fn number_format(&self) -> NumberFormat {
        self.core.numerics.format
    }

    /// The fixed-point frame in force.
    pub fn fixed_frame(&self) -> FixedFrame {
        self.core.numerics.frame
    }

    /// Selects the number format of every PE and, for the fixed-point formats, the frame that
    /// maps the scene into the format's box (`FixedFrame::for_box` of the grid box). Records
    /// depend on both, so this empties every PE like CLEAR: call it before loading.
    pub fn set_number_format(&mut self, format: NumberFormat, frame: FixedFrame) {
        self.core.numerics = Numerics { format, frame };
        self.core.clear();
    }

    /// Counters.
    pub fn stats(&self) -> &CoprocStats {
        &self.core.stats
    }

    /// Zeroes the counters.
    pub fn reset_stats(&mut self) {
        self.core.stats = CoprocStats::default();
    }

    /// True when PE `pe` holds a successfully loaded image.
    pub fn is_pe_loaded(&self, pe: u8) -> bool {
        self.core.pes.get(pe as usize).is_some_and(|s| s.loaded)
    }

    /// The loaded image of PE `pe`, if any.
    pub fn pe_image(&self, pe: u8) -> Option<&[u32]> {
        let slot = self.core.pes.get(pe as usize).filter(|s| s.loaded)?;
        let base = self.core.base(pe);
        self.core.mem.get(base..base + slot.len as usize)
    }

    /// Number of PEs holding a loaded image.
    pub fn loaded_pes(&self) -> u16 {
        self.core.loaded_pes
    }

    /// True while a packet is partly received (or being discarded after an error).
    pub fn in_packet(&self) -> bool {
        self.rx != Rx::Idle
    }

    // ---------------------------------------------------------------- direct API

    /// Loads PE `pe` with an image (same validation as a LOAD_PE packet). On error the PE is
    /// left empty (if `pe` was in range).
    pub fn load_pe(&mut self, pe: u8, words: &[u32]) -> Result<(), FslError> {
        let r = self.load_pe_inner(pe, words);
        if r.is_err() {
            self.core.stats.errors += 1;
        }
        r
    }

    fn load_pe_inner(&mut self, pe: u8, words: &[u32]) -> Result<(), FslError> {
        if pe as u16 >= self.core.cfg.pe_count {
            return Err(FslError::PeOutOfRange);
        }
        self.core.begin_load(pe);
        if words.len() > self.core.cfg.pe_mem_words as usize {
            return Err(FslError::PeMemoryOverflow);
        }
        let base = self.core.base(pe);
        let dst = self.core.mem.get_mut(base..base + words.len()).ok_or(FslError::PeMemoryOverflow)?;
        dst.copy_from_slice(words);
        self.core.finish_load(pe, words.len())
    }

    /// Empties every PE (the CLEAR packet).
    pub fn clear(&mut self) {
        self.core.clear();
    }

    /// Traces one ray with cycle accounting (same validation and semantics as a RAY packet;
    /// `result.cycles` includes the request and result words the packet would take).
    pub fn trace(&mut self, kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Result<RayResult, FslError> {
        self.core.trace_timed(kind, ray, t_max, list).map_err(|(e, _)| {
            self.core.stats.errors += 1;
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
        let view = self.core.view();
        view.validate(ray, t_max, list).map_err(|(e, _)| e)?;
        let (found, info) = view.search_dyn(kind, ray, t_max, list);
        let mut r = view.result_of(list, found, ray);
        r.tests = info.tests.min(u16::MAX as u64) as u16;
        Ok((r, info))
    }

    // ---------------------------------------------------------------- word interface

    /// Dequeues the next outbound word.
    pub fn pop(&mut self) -> Option<FslWord> {
        self.out.pop_front()
    }

    /// Outbound words waiting.
    pub fn out_len(&self) -> usize {
        self.out.len()
    }

    /// True when the output queue can take a full ray result; a driver modelling FSL
    /// back-pressure should stop pushing while this is false (words of replies that do not
    /// fit are dropped and counted in `CoprocStats::out_dropped`).
    pub fn can_push(&self) -> bool {
        OUT_QUEUE_WORDS - self.out.len() >= fsl::RESULT_WORDS
    }

    /// Consumes one inbound word; executes a packet when its last word arrives.
    pub fn push(&mut self, w: FslWord) {
        self.core.stats.words_in += 1;
        self.rx = match self.rx {
            Rx::Idle => self.on_first_word(w),
            Rx::Discard => {
                if w.control {
                    Rx::Idle
                } else {
                    Rx::Discard
                }
            }
            Rx::LoadCount { pe } => self.on_load_count(pe, w),
            Rx::LoadWords { pe, declared, got } => self.on_load_word(pe, declared, got, w),
            Rx::Ray { kind, count, idx } => self.on_ray_word(kind, count, idx, w),
        };
    }

    fn emit(&mut self, data: u32, control: bool) {
        if self.out.push_back(FslWord { data, control }).is_err() {
            self.core.stats.out_dropped += 1;
        } else {
            self.core.stats.words_out += 1;
        }
    }

    /// Reports `e` and picks the next state: packet over if `control`, else resynchronise.
    fn fail(&mut self, e: FslError, detail: u16, control: bool) -> Rx {
        self.core.stats.errors += 1;
        self.emit(e.to_word(detail), true);
        if control {
            Rx::Idle
        } else {
            Rx::Discard
        }
    }

    fn on_first_word(&mut self, w: FslWord) -> Rx {
        let ctl = w.control;
        match fsl::opcode(w.data) {
            op::LOAD_PE => {
                let pe = w.data as u8;
                if pe as u16 >= self.core.cfg.pe_count {
                    return self.fail(FslError::PeOutOfRange, pe as u16, ctl);
                }
                self.core.begin_load(pe);
                if ctl {
                    return self.fail(FslError::PacketTooShort, 0, true);
                }
                Rx::LoadCount { pe }
            }
            op::CLEAR => {
                if !ctl {
                    return self.fail(FslError::MissingControl, 0, false);
                }
                self.core.clear();
                self.emit(CLEAR_ACK, true);
                Rx::Idle
            }
            op::RAY_CLOSEST | op::RAY_ANY => {
                let kind = if fsl::opcode(w.data) == op::RAY_ANY { RayKind::Any } else { RayKind::Closest };
                let count = w.data as u16;
                if let Err((e, d)) = self.core.view().check_header(count as usize) {
                    return self.fail(e, d, ctl);
                }
                if ctl {
                    return self.fail(FslError::PacketTooShort, 0, true);
                }
                self.head[0] = w.data;
                self.list.clear();
                Rx::Ray { kind, count, idx: 1 }
            }
            other => self.fail(FslError::UnknownOpcode, other as u16, ctl),
        }
    }

    fn on_load_count(&mut self, pe: u8, w: FslWord) -> Rx {
        let n = w.data;
        if n > self.core.cfg.pe_mem_words {
            return self.fail(FslError::PeMemoryOverflow, pe as u16, w.control);
        }
        if n == 0 {
            if !w.control {
                return self.fail(FslError::MissingControl, 1, false);
            }
            return self.complete_load(pe, 0);
        }
        if w.control {
            return self.fail(FslError::PacketTooShort, 1, true);
        }
        Rx::LoadWords { pe, declared: n, got: 0 }
    }

    fn on_load_word(&mut self, pe: u8, declared: u32, got: u32, w: FslWord) -> Rx {
        let at = self.core.base(pe) + got as usize;
        // `declared ≤ pe_mem_words` was checked, so this slot exists; stay safe regardless.
        let Some(slot) = self.core.mem.get_mut(at) else {
            return self.fail(FslError::PeMemoryOverflow, pe as u16, w.control);
        };
        *slot = w.data;
        let got = got + 1;
        let index = (2 + got as u64 - 1).min(u16::MAX as u64) as u16;
        if got == declared {
            if !w.control {
                return self.fail(FslError::MissingControl, index, false);
            }
            return self.complete_load(pe, declared as usize);
        }
        if w.control {
            return self.fail(FslError::PacketTooShort, index, true);
        }
        Rx::LoadWords { pe, declared, got }
    }

    fn complete_load(&mut self, pe: u8, len: usize) -> Rx {
        match self.core.finish_load(pe, len) {
            Ok(()) => {
                self.emit(load_ack(pe), true);
                Rx::Idle
            }
            Err(e) => self.fail(e, pe as u16, true),
        }
    }

    fn on_ray_word(&mut self, kind: RayKind, count: u16, idx: u32, w: FslWord) -> Rx {
        let ctl = w.control;
        let index = idx.min(u16::MAX as u32) as u16;
        let next = Rx::Ray { kind, count, idx: idx + 1 };
        if (idx as usize) < RAY_HEADER_WORDS {
            if let Some(h) = self.head.get_mut(idx as usize) {
                *h = w.data;
            }
            if idx as usize == RAY_HEADER_WORDS - 1 {
                let (ray, t_max) = self.head_ray();
                if let Err((e, d)) = View::check_ray(&ray, t_max) {
                    return self.fail(e, d, ctl);
                }
                if count == 0 {
                    if !ctl {
                        return self.fail(FslError::MissingControl, index, false);
                    }
                    return self.execute(kind);
                }
            }
            if ctl {
                return self.fail(FslError::PacketTooShort, index, true);
            }
            return next;
        }
        let j = idx as usize - RAY_HEADER_WORDS;
        let k = j / 2;
        if j & 1 == 0 {
            self.pending = w.data;
            let e = fsl::entry_from_words(w.data, 0);
            if let Err((e, d)) = self.core.view().check_entry_target(k, e.pe, e.voxel) {
                return self.fail(e, d, ctl);
            }
            if ctl {
                return self.fail(FslError::PacketTooShort, index, true);
            }
            return next;
        }
        let e = fsl::entry_from_words(self.pending, w.data);
        if let Err((e, d)) = View::check_entry_exit(k, e.t_exit) {
            return self.fail(e, d, ctl);
        }
        if self.list.push(e).is_err() {
            return self.fail(FslError::ListTooLong, self.core.cfg.max_list, ctl);
        }
        if k + 1 == count as usize {
            if !ctl {
                return self.fail(FslError::MissingControl, index, false);
            }
            return self.execute(kind);
        }
        if ctl {
            return self.fail(FslError::PacketTooShort, index, true);
        }
        next
    }

    fn head_ray(&self) -> (Ray, f32) {
        let f = |i: usize| f32::from_bits(self.head.get(i).copied().unwrap_or(0));
        let ray = Ray { origin: Vec3::new(f(1), f(2), f(3)), dir: Vec3::new(f(4), f(5), f(6)) };
        (ray, f(7))
    }

    fn execute(&mut self, kind: RayKind) -> Rx {
        let (ray, t_max) = self.head_ray();
        match self.core.trace_timed(kind, &ray, t_max, &self.list) {
            Ok(r) => {
                let words = r.to_words();
                let last = words.len() - 1;
                for (i, &wd) in words.iter().enumerate() {
                    self.emit(wd, i == last);
                }
                Rx::Idle
            }
            Err((e, d)) => self.fail(e, d, true),
        }
    }
}
