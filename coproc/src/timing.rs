//! Cycle accounting: timing profiles and the per-ray timeline.
//!
//! Source: GridRT (Nery 2010) §6.3.2 and Table 6.14 for [`TimingProfile::GRIDRT`];
//! the pipelined profile is this project's model of the thesis's own future work ("pipelining
//! and more FP units per PE", GridRT's future work).
//!
//! # Timeline of one ray (what [`crate::Coprocessor::trace`] charges)
//!
//! 1. The request streams in at `word_in_cycles` per word (8 head words + 2 per entry), then
//!    `ray_setup_cycles` compute the per-ray constants every PE shares.
//! 2. Then every PE named in the list starts at time 0. Each PE works
//!    through *its own* entries in list order, one after the other: entry k starts when the
//!    PE's previous entry has issued its last test, spends `voxel_setup_cycles` (voxel-table
//!    lookup, ref-range loads), then issues its tests `test_issue_cycles` apart. Its result is
//!    known `test_latency_cycles` after its last issue (0 for a multi-cycle PE; the pipeline
//!    drain for a pipelined one).
//! 3. The winner w is the first entry in list order with an accepted hit (the interrupt chain:
//!    w suspends every PE after it and waits for "done" from those before it). The PE array
//!    finishes at T = max(completion of entries 0..=w), or of every entry on a miss. A
//!    RAY_ANY winner completes when the result of its first accepted test is known
//!    (`PeTimeline::done_after`); its PE keeps issuing the entry's remaining tests until
//!    then (it cannot know earlier), so every entry is scheduled with all its tests.
//! 4. Tests charged = tests *started* before T. Entries 0..=w always finish; an entry after w
//!    is charged the tests its PE had issued when the suspend arrived at T (a simplification:
//!    suspend is taken as instantaneous and a started test counts in full).
//! 5. Then `arbitration_cycles` (commit of the winner's result) and the 8 result words at
//!    `word_out_cycles` each.
//!
//! The cost of a test does not depend on its outcome: the thesis reports one figure per
//! intersection (648 cycles) and no early-exit profile, so the GridRT PE's early exits are not
//! modelled in time (they are in the Cramer kernel's arithmetic).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use crate::isect::KernelKind;
use crate::numeric::NumberFormat;
use gridrt_shared::fsl::{RAY_HEADER_WORDS, RESULT_WORDS};

/// Cycle costs of one co-processor design. All fields are plain numbers so a host tool can
/// build its own profile; [`TimingProfile::GRIDRT`] and [`TimingProfile::PIPELINED`] are the
/// documented presets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimingProfile {
    /// Name for reports.
    pub name: &'static str,
    /// Clock of the PE array in Hz (converts cycles to seconds; does not change cycle counts).
    pub clock_hz: u32,
    /// Cycles between the starts of two consecutive ray–triangle tests on one PE (the
    /// initiation interval; the whole test for a multi-cycle PE). Must be ≥ 1.
    pub test_issue_cycles: u32,
    /// Cycles from the issue of a PE's last test of an entry until its result is known
    /// (pipeline drain; 0 for a multi-cycle PE).
    pub test_latency_cycles: u32,
    /// Cycles a PE spends on each of its list entries before the first test.
    pub voxel_setup_cycles: u32,
    /// Cycles per inbound FSL word.
    pub word_in_cycles: u32,
    /// Cycles per outbound FSL word.
    pub word_out_cycles: u32,
    /// Cycles to resolve the interrupt chain and commit the winning result, once per ray.
    pub arbitration_cycles: u32,
    /// Cycles between the request's last word and the start of the PEs, once per ray (the
    /// per-ray constants every PE shares; 0 when the PEs start at once).
    pub ray_setup_cycles: u32,
}

/// GridRT's PE program, decoded (thesis App. C.3) and costed with thesis
/// Table 6.14. This is the instruction mix of one full pass of the triangle loop (instr. 49–124,
/// no early exit, new best taken); it documents and brackets the 648-cycle constant.
pub mod gridrt_pe {
    /// `subfp`/`addfp`: 9 setup subtractions, 5 in the cofactors, 2 in |A|, 2 in β, 3 in γ,
    /// 1 for β + γ, 2 in t.
    pub const FP_ADD_SUB: u32 = 24;
    /// `mulfp`: 10 in the cofactors, 3 in |A|, 4 in β, 6 in γ, 4 in t.
    pub const FP_MUL: u32 = 27;
    /// `cmpfp`: β ≥ 0, γ ≥ 0, β + γ ≤ 1, t ≥ 0, t < best.
    pub const FP_CMP: u32 = 5;
    /// `divfp`: the reciprocal of |A| (instr. 87).
    pub const FP_DIV: u32 = 1;
    /// `lw`: the 9 vertex words.
    pub const LOADS: u32 = 9;
    /// Integer and branch instructions: 5 conditional jumps after the compares (3 cycles
    /// each), `or` for the new best (3), 2 × `addi` for the counters (4 each), loop `cmp` and
    /// jump (3 + 3).
    pub const INT_BRANCH: u32 = 10;
    /// Table 6.14 execute cycles of the integer/branch group: 5·3 + 3 + 2·4 + 3 + 3.
    pub const INT_BRANCH_CYCLES: u32 = 32;
    /// Table 6.14: add/sub/mul/cmp in floating point.
    pub const CYCLES_FP: u32 = 6;
    /// Table 6.14: div/sqrt in floating point.
    pub const CYCLES_FP_DIV: u32 = 12;
    /// Table 6.14: load.
    pub const CYCLES_LOAD: u32 = 7;
    /// Microprogram fetch steps per instruction (μ0 load IR, μ1 PC++ and decode, μ2 dispatch;
    /// thesis App. C.1 and the `add` walk-through of §6.2.3), not included in Table 6.14.
    pub const FETCH_STEPS: u32 = 3;

    /// FP instructions of one test: 57.
    pub const FP_INSTRUCTIONS: u32 = FP_ADD_SUB + FP_MUL + FP_CMP + FP_DIV;
    /// All instructions of one test: 76.
    pub const INSTRUCTIONS: u32 = FP_INSTRUCTIONS + LOADS + INT_BRANCH;
    /// Table 6.14 execute cycles of the FP instructions: 56·6 + 12 = 348.
    pub const FP_EXECUTE_CYCLES: u32 = (FP_ADD_SUB + FP_MUL + FP_CMP) * CYCLES_FP + FP_DIV * CYCLES_FP_DIV;
    /// Table 6.14 execute cycles of one test: 348 + 63 + 32 = 443.
    pub const EXECUTE_CYCLES: u32 = FP_EXECUTE_CYCLES + LOADS * CYCLES_LOAD + INT_BRANCH_CYCLES;

    /// Thesis §6.3.2: cycles of one intersection, "including the loads".
    pub const REPORTED_TEST_CYCLES: u32 = 648;
    /// Thesis §6.3.2: of which floating-point operations.
    pub const REPORTED_FP_CYCLES: u32 = 528;
    /// The remainder: loads, integer and control.
    pub const REPORTED_OTHER_CYCLES: u32 = REPORTED_TEST_CYCLES - REPORTED_FP_CYCLES;
}

impl TimingProfile {
    /// GridRT's multi-cycle PE at 50 MHz (thesis §6.3.2); its numbers are set as follows.
    ///
    /// - `test_issue_cycles = 648`, set to the thesis's measured cost of one intersection, "528 of
    ///   them floating point" (so 120 loads/int/control). We take the measured figure rather
    ///   than our reconstruction, because the decoded PE loop ([`gridrt_pe`]: 57 FP + 9 loads +
    ///   10 int/branch = 76 instructions) comes from OCR-damaged listings and Table 6.14
    ///   excludes fetch/decode. The decode brackets the figure: Table 6.14 execute cycles give
    ///   443, and 443 + 3 fetch steps × 76 instructions = 671, so 443 ≤ 648 ≤ 671. The FP share
    ///   528 / 57 = 9.3 cycles per FP instruction = 6 (Table 6.14) + ≈3 fetch/decode/control
    ///   steps, matching the thesis's remark that FP instructions carry "additional cycles for
    ///   other control signals". 4 PEs × 50 MHz / 648 = 308.6 k tests/s, as reported.
    /// - `voxel_setup_cycles = 70` (estimate; the thesis PE had one voxel and no lookup):
    ///   binary search of a small voxel table, 2 probes × (`lw` 7 + `cmp` 3 + `je` 3), then
    ///   `lw` first ref and count (2 × 7) and an `and` for the pointer (3): 43 execute cycles +
    ///   9 instructions × 3 fetch steps = 70. About 11 % of one test, so its error matters little.
    /// - `word_in_cycles = word_out_cycles = 1`: an FSL FIFO moves one word per cycle
    ///   (thesis §6.2.2: data valid right after the write strobe).
    /// - `arbitration_cycles = 4`: the winner's commit (`st`, 4 cycles in Table 6.14) after
    ///   the interrupt FSMs have seen "done"; the 1-bit suspend/done lines are taken as
    ///   propagating within the same cycles.
    pub const GRIDRT: TimingProfile = TimingProfile {
        name: "gridrt",
        clock_hz: 50_000_000,
        test_issue_cycles: gridrt_pe::REPORTED_TEST_CYCLES,
        test_latency_cycles: 0,
        voxel_setup_cycles: 70,
        word_in_cycles: 1,
        word_out_cycles: 1,
        arbitration_cycles: 4,
        ray_setup_cycles: 0,
    };

    /// A fully pipelined PE: one test issued per cycle after a fill latency.
    ///
    /// Assumptions: the same 50 MHz clock and FP operator latencies GridRT chose (add/sub/mul
    /// 3 cycles, div 9; thesis §6.3.2) so cycle counts compare directly with
    /// [`TimingProfile::GRIDRT`] (a pipelined design would likely close timing higher: scale
    /// `clock_hz`); enough FP units to evaluate the whole kernel as a dataflow graph; triangle
    /// words read from a BRAM wide enough for one record per cycle.
    /// - `test_latency_cycles = 33`, the critical path of a Möller–Trumbore / watertight
    ///   dataflow: BRAM read 2 + sub 3 (edges) + mul 3 + sub 3 (cross) + mul 3 + add 3 + add 3
    ///   (dot) + div 9 (reciprocal) + mul 3 (t) + compare 1.
    /// - `voxel_setup_cycles = 8`: 3 dependent BRAM probes of the voxel table (2 cycles each)
    ///   and the ref-range read (2), overlapping nothing.
    /// - FSL at 1 word/cycle; `arbitration_cycles = 2` (suspend/done resolution and commit).
    pub const PIPELINED: TimingProfile = TimingProfile {
        name: "pipelined",
        clock_hz: 50_000_000,
        test_issue_cycles: 1,
        test_latency_cycles: 33,
        voxel_setup_cycles: 8,
        word_in_cycles: 1,
        word_out_cycles: 1,
        arbitration_cycles: 2,
        ray_setup_cycles: 0,
    };

    /// The RTL co-processor's default build (rtl/README.md §4.5): [`TimingProfile::rtl`] with
    /// [`RTL_PES_PER_PIPELINE`] PEs per intersection pipeline. Its RESULT words, cycles and
    /// test counts included, are those of `--coproc rtl` (`rtl/tests/cosim.rs`).
    ///
    /// Over whole frames (bun_zipper_res4, 4 PEs; BENCHMARKS.md "Co-processor RTL") it takes
    /// several times the cycles per co-processor ray of [`TimingProfile::PIPELINED`]: that
    /// profile describes no built design, so frame-time figures of the RTL (`bench frame`'s
    /// `rtl` configuration) take this one.
    pub const RTL: TimingProfile = TimingProfile::rtl(RTL_PES_PER_PIPELINE);

    /// The RTL co-processor with `pes_per_pipeline` PEs sharing each intersection pipeline
    /// (the HDL's `PES_PER_PIPELINE`, 1..=4; 0 counts as 1), measured in its Verilator
    /// simulation (rtl/README.md §4.5). Its own clock is whatever the FPGA closes (`cargo
    /// xtask rtl synth`); 50 MHz here, GridRT's, so figures compare directly.
    /// - `test_issue_cycles = pes_per_pipeline`: the pipeline takes one test per cycle, from
    ///   its PEs in turn (64 MULT18X18D per pipeline: 4 PEs with a pipeline each do not fit
    ///   the ECP5-85F, rtl/README.md §4.3, §5).
    /// - `voxel_setup_cycles = max(2, pes_per_pipeline)`: the voxel lookup happens while the
    ///   list streams in; an entry's ref range is in the PE's queue, two cycles to take it,
    ///   rounded up so that every issue falls on a multiple of the issue interval.
    /// - `test_latency_cycles = 66 + pes_per_pipeline`: from the end of the last test's issue
    ///   slot: the ref word and the record read (2 + 4; with 4 PEs per pipeline the record
    ///   in three parts, the last read 3 cycles later), the record's parts to the pipeline
    ///   (a register, then one cycle per part after the first), the merge register beside
    ///   the pipeline (1), the 57-stage test (shear 6, edges 5, determinant and weights 6,
    ///   depth 6, normalisation 2, a 27-step restoring divider, rounding 3), the lanes'
    ///   realignment (the slot less one cycle), acceptance and the entry's winner (3), less
    ///   one. Each stage holds at most one wide carry chain so the clock can close
    ///   (rtl/README.md §5).
    /// - `ray_setup_cycles = 25`: the dominant axis, six pipelined f32 → fixed conversions,
    ///   the two shear divisions (2 quotient bits per cycle), and the start of the PEs.
    /// - `arbitration_cycles = 8`: the first-hit decision (each PE's first open and first
    ///   hit entry registered, their minimum registered, then compared), the winner's result
    ///   and triangle (two memory reads), before the first RESULT word.
    pub const fn rtl(pes_per_pipeline: u32) -> TimingProfile {
        let share = if pes_per_pipeline == 0 { 1 } else { pes_per_pipeline };
        TimingProfile {
            name: if share == RTL_PES_PER_PIPELINE {
                "rtl"
            } else {
                match share {
                    1 => "rtl-pipeline-per-pe",
                    2 => "rtl-2-pes-per-pipeline",
                    3 => "rtl-3-pes-per-pipeline",
                    _ => "rtl-4-pes-per-pipeline",
                }
            },
            clock_hz: 50_000_000,
            test_issue_cycles: share,
            test_latency_cycles: 66_u32.saturating_add(share),
            voxel_setup_cycles: if share > 2 { share } else { 2 },
            word_in_cycles: 1,
            word_out_cycles: 1,
            arbitration_cycles: 8,
            ray_setup_cycles: 25,
        }
    }

    /// Sustained ray–triangle tests per second of `pes` PEs that are always busy
    /// (the thesis's "77 k per PE, 308 k for 4 PEs" figure).
    pub fn tests_per_second(&self, pes: u32) -> f64 {
        pes as f64 * self.clock_hz as f64 / self.test_issue_cycles.max(1) as f64
    }

    /// Cycles of a ray that do not depend on the tests: request words of a `list_len`-entry
    /// list, ray setup, arbitration and the result words. (Voxel setup is charged on the PE
    /// timeline.)
    pub fn ray_io_cycles(&self, list_len: usize) -> u64 {
        // Saturating: a list length comes off the link (bounded by `max_list` there).
        let words_in = (list_len as u64).saturating_mul(2).saturating_add(RAY_HEADER_WORDS as u64);
        words_in
            .saturating_mul(self.word_in_cycles as u64)
            .saturating_add(self.ray_setup_cycles as u64)
            .saturating_add(self.arbitration_cycles as u64)
            .saturating_add((RESULT_WORDS as u64).saturating_mul(self.word_out_cycles as u64))
    }

    /// Seconds for `cycles` at this profile's clock.
    pub fn seconds(&self, cycles: u64) -> f64 {
        cycles as f64 / self.clock_hz.max(1) as f64
    }
}

/// PEs per intersection pipeline of the RTL co-processor's default build (the HDL's
/// `PES_PER_PIPELINE`, `cargo xtask rtl --pes-per-pipeline`): one pipeline serves 4 PEs on
/// the ECP5-85F (rtl/README.md §5).
pub const RTL_PES_PER_PIPELINE: u32 = 4;

/// Cycles of one operation class on GridRT's multi-cycle PE, per number format: the basis of
/// the per-kernel cycle model [`test_cycles`].
///
/// - `f32` is derived from the thesis (so the f32 Cramer test costs the reported 648 by
///   construction): Table 6.14 gives 6 execute cycles per FP add/sub/
///   mul/cmp and 12 per div; the measured 528 FP cycles of the 57 FP instructions of the PE
///   loop leave `(528 − 348)/57 = 3.16` cycles of fetch/decode/control per instruction
///   (≈ 9.16 per FP op "incl. fetch"). Loads cost 7 (Table 6.14) and the loop's integer and
///   branch work the remaining 57 cycles of the measured 648 (120 − 9 loads · 7).
/// - The fixed-point rows are this project's **estimates** for an integer datapath in the
///   same microcoded PE (same fetch overhead, loads and loop overhead): `Fixed32Q16` — 3-cycle
///   ALU ops (Table 6.14's integer `cmp`/`add`), a 32×32→64 DSP multiply with round and
///   narrow-check in 4, a radix-2 restoring divider in 34 (32 iterations + 2);
///   `Fixed64Q23` — 64-bit ALU ops as two chained 32-bit halves in 4, a 64×64 product from
///   four DSP partial products with accumulation and rounding in 8, a radix-2 divider in 66.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpCycles {
    /// Add/sub.
    pub add: f64,
    /// Multiply (fixed point: with the rounding shift and range check).
    pub mul: f64,
    /// Divide / reciprocal.
    pub div: f64,
    /// Compare / sign test.
    pub cmp: f64,
    /// One record word loaded from PE memory.
    pub load: f64,
    /// Integer, branch and loop control per test.
    pub overhead: f64,
}

/// Fetch/decode/control cycles per instruction: `(528 − 348)/57` (see [`OpCycles`]).
pub const FETCH_CYCLES: f64 =
    (gridrt_pe::REPORTED_FP_CYCLES - gridrt_pe::FP_EXECUTE_CYCLES) as f64 / gridrt_pe::FP_INSTRUCTIONS as f64;

impl OpCycles {
    /// The operation costs of `format` (see the type doc).
    pub fn of(format: NumberFormat) -> OpCycles {
        let (add, mul, div) = match format {
            NumberFormat::F32 => {
                (gridrt_pe::CYCLES_FP as f64, gridrt_pe::CYCLES_FP as f64, gridrt_pe::CYCLES_FP_DIV as f64)
            }
            NumberFormat::Fixed32Q16 => (3.0, 4.0, 34.0),
            NumberFormat::Fixed64Q23 => (4.0, 8.0, 66.0),
        };
        OpCycles {
            add: add + FETCH_CYCLES,
            mul: mul + FETCH_CYCLES,
            div: div + FETCH_CYCLES,
            cmp: add + FETCH_CYCLES,
            load: gridrt_pe::CYCLES_LOAD as f64,
            overhead: (gridrt_pe::REPORTED_OTHER_CYCLES - gridrt_pe::LOADS * gridrt_pe::CYCLES_LOAD) as f64,
        }
    }
}

/// Modelled cycles of one full ray–triangle test (no early exit) of `kind` in `format` on
/// GridRT's multi-cycle PE: its operation count ([`KernelKind::ops`]) costed with
/// [`OpCycles::of`], plus its record loads and the loop overhead. GridRT's own PE program
/// (57 FP ops, 9 loads) comes out at exactly the thesis's 648 cycles.
pub fn test_cycles(kind: KernelKind, format: NumberFormat) -> f64 {
    let ops = kind.ops(format);
    let c = OpCycles::of(format);
    ops.add as f64 * c.add
        + ops.mul as f64 * c.mul
        + ops.div as f64 * c.div
        + ops.cmp as f64 * c.cmp
        + kind.record_words(format) as f64 * c.load
        + c.overhead
}

impl TimingProfile {
    /// This profile with the test cost of `kind` in `format`: for a multi-cycle profile (one
    /// test at a time: `test_issue_cycles > 1` and no pipeline, `test_latency_cycles == 0`)
    /// the issue interval becomes [`test_cycles`] (rounded); a pipelined profile (a fixed
    /// datapath: [`TimingProfile::PIPELINED`], [`TimingProfile::RTL`]) is returned unchanged.
    /// [`TimingProfile::GRIDRT`] itself keeps the thesis's measured 648 cycles whatever the
    /// kernel, so existing cycle figures do not move; use this to compare kernels.
    pub fn for_kernel(&self, kind: KernelKind, format: NumberFormat) -> TimingProfile {
        if self.test_issue_cycles <= 1 || self.test_latency_cycles > 0 {
            return *self;
        }
        let cycles = libm::round(test_cycles(kind, format)).clamp(1.0, u32::MAX as f64) as u32;
        TimingProfile { test_issue_cycles: cycles, ..*self }
    }
}

/// Timeline of one list entry as seen by [`PeTimeline`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct EntryTime {
    /// When the entry's first test is issued.
    pub first_issue: u64,
    /// When the entry's result is known.
    pub done: u64,
}

/// Per-PE running clocks of one ray (step 2 of the module timeline).
pub(crate) struct PeTimeline<'a> {
    profile: &'a TimingProfile,
    clocks: &'a mut [u64],
}

impl<'a> PeTimeline<'a> {
    /// A timeline over the given per-PE clock array (reset by the caller for the PEs used).
    pub fn new(profile: &'a TimingProfile, clocks: &'a mut [u64]) -> Self {
        Self { profile, clocks }
    }

    /// Schedules the next entry of PE `pe` with `tests` tests.
    pub fn schedule(&mut self, pe: u8, tests: u32) -> EntryTime {
        let p = self.profile;
        let Some(clock) = self.clocks.get_mut(pe as usize) else {
            return EntryTime { first_issue: 0, done: 0 };
        };
        // Saturating: `tests` counts references of link-named voxels.
        let first_issue = clock.saturating_add(p.voxel_setup_cycles as u64);
        let issue_end = first_issue.saturating_add((tests as u64).saturating_mul(p.test_issue_cycles.max(1) as u64));
        *clock = issue_end;
        let done = if tests > 0 { issue_end.saturating_add(p.test_latency_cycles as u64) } else { issue_end };
        EntryTime { first_issue, done }
    }

    /// When the result of the first `m` tests of an entry scheduled at `at` is known (a
    /// RAY_ANY entry whose `m`-th test is its first accepted one).
    pub fn done_after(&self, at: EntryTime, m: u32) -> u64 {
        let p = self.profile;
        let issue_end = at.first_issue.saturating_add((m as u64).saturating_mul(p.test_issue_cycles.max(1) as u64));
        if m > 0 {
            issue_end.saturating_add(p.test_latency_cycles as u64)
        } else {
            issue_end
        }
    }

    /// Tests of an entry scheduled at `at` with `tests` tests that were started before `end`.
    pub fn started_before(&self, at: EntryTime, tests: u32, end: u64) -> u32 {
        if end <= at.first_issue {
            return 0;
        }
        let ii = self.profile.test_issue_cycles.max(1) as u64;
        let started = end.saturating_sub(at.first_issue).div_ceil(ii);
        started.min(tests as u64) as u32
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    /// The decoded PE loop (thesis App. C.3) brackets the thesis's 648 cycles: Table 6.14
    /// execute cycles alone are below it, execute + 3 microprogram fetch steps per
    /// instruction are above it.
    #[test]
    fn gridrt_decoded_pe_loop_brackets_648_cycles() {
        use gridrt_pe::*;
        assert_eq!(FP_INSTRUCTIONS, 57);
        assert_eq!(INSTRUCTIONS, 76);
        assert_eq!(FP_EXECUTE_CYCLES, 348);
        assert_eq!(EXECUTE_CYCLES, 443);
        let with_fetch = EXECUTE_CYCLES + FETCH_STEPS * INSTRUCTIONS;
        assert!(EXECUTE_CYCLES < REPORTED_TEST_CYCLES && REPORTED_TEST_CYCLES < with_fetch, "{with_fetch}");
        assert_eq!(REPORTED_OTHER_CYCLES, 120);
        // 528 / 57 ≈ 9.26: Table 6.14's 6 cycles + ≈ 3 fetch/control steps per FP instruction.
        let per_fp = REPORTED_FP_CYCLES as f64 / FP_INSTRUCTIONS as f64;
        assert!((per_fp - (CYCLES_FP + FETCH_STEPS) as f64).abs() < 0.5, "{per_fp}");
        assert_eq!(TimingProfile::GRIDRT.test_issue_cycles, REPORTED_TEST_CYCLES);
    }

    /// Every profile charges each kernel × format the cycles of its op count (rounded), and the
    /// kernels order as their op counts say.
    #[test]
    fn for_kernel_charges_each_kernel_its_rounded_model_cycles_and_projection_kernels_are_cheapest() {
        for f in NumberFormat::ALL {
            for k in KernelKind::ALL {
                let cy = test_cycles(k, f);
                assert!(cy > 200.0 && cy < 2000.0, "{k:?} {f:?}: {cy}");
                assert_eq!(TimingProfile::GRIDRT.for_kernel(k, f).test_issue_cycles, libm::round(cy) as u32);
                assert_eq!(TimingProfile::PIPELINED.for_kernel(k, f), TimingProfile::PIPELINED);
                assert_eq!(TimingProfile::RTL.for_kernel(k, f), TimingProfile::RTL);
            }
            // The projection tests (29 ops) are far cheaper per test than the others.
            assert!(test_cycles(KernelKind::Wald, f) < test_cycles(KernelKind::MollerTrumbore, f));
        }
        // Robust watertight f32 costs more than the PE's plain Cramer program.
        assert!(test_cycles(KernelKind::Watertight, NumberFormat::F32) > gridrt_pe::REPORTED_TEST_CYCLES as f64);
    }

    #[test]
    fn timeline_runs_a_pes_entries_back_to_back_and_counts_started_tests() {
        let p = TimingProfile::GRIDRT;
        let mut clocks = [0u64; 4];
        let mut tl = PeTimeline::new(&p, &mut clocks);
        let a = tl.schedule(0, 2);
        let b = tl.schedule(1, 10);
        let c = tl.schedule(0, 3);
        assert_eq!(a, EntryTime { first_issue: 70, done: 70 + 2 * 648 });
        assert_eq!(b.first_issue, 70);
        assert_eq!(c.first_issue, a.done + 70);
        // Suspended when a is done: PE 1 had started 2 tests (at 70 and 718), PE 0 none of c.
        assert_eq!(tl.started_before(b, 10, a.done), 2);
        assert_eq!(tl.started_before(c, 3, a.done), 0);
        assert_eq!(tl.started_before(a, 2, a.done), 2);
    }

    /// Every RTL sharing issues on multiples of its interval (the voxel setup is one, at least
    /// 2 cycles), so the PEs of a pipeline never issue in the same cycle once their lanes are
    /// staggered; the default build is the one named "rtl", and each sharing has its own name.
    #[test]
    fn rtl_profiles_issue_on_multiples_of_their_sharing() {
        let mut names = Vec::new();
        for share in 1..=4u32 {
            let p = TimingProfile::rtl(share);
            assert_eq!(p.test_issue_cycles, share);
            assert!(p.voxel_setup_cycles >= 2 && p.voxel_setup_cycles.is_multiple_of(share), "{p:?}");
            let mut clocks = [0u64; 1];
            let mut tl = PeTimeline::new(&p, &mut clocks);
            for tests in [3, 0, 1, 5] {
                let at = tl.schedule(0, tests);
                assert_eq!(at.first_issue % share as u64, 0, "{p:?}");
            }
            names.push(p.name);
        }
        assert_eq!(TimingProfile::rtl(RTL_PES_PER_PIPELINE), TimingProfile::RTL);
        assert_eq!(TimingProfile::RTL.name, "rtl");
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), 4);
        assert_eq!(TimingProfile::rtl(0), TimingProfile::rtl(1));
    }
}
