//! The report of `gridrt bench frame`: one row per configuration × target, and its CSV and
//! SVG (stacked bars of the frame's critical path).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use gridrt_coproc::TimingProfile;
use gridrt_firmware::device::Stage;
use gridrt_shared::msg::{stat, STAT_HARTS};
use serde::Serialize;

use super::run::DeviceRun;
use super::setup::{kernel, BenchOptions, Configuration, SocFloatHw, Target};
use super::soc::SocRun;
use super::timeline::{timeline, FrameWork};
use crate::compare::Comparison;
use crate::stats::stage_name;

/// The whole report (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct FrameReport {
    /// Scene file.
    pub scene: String,
    /// Frame width.
    pub width: u16,
    /// Frame height.
    pub height: u16,
    /// Clock of the soft-core and the co-processor.
    pub clock_mhz: f64,
    /// Line rate (8N1).
    pub baud: u32,
    /// Pixel encoding of the answer.
    pub encoding: String,
    /// Intersection kernel of every configuration but `rtl` (each row names its own).
    pub kernel: String,
    /// Its number format.
    pub number_format: String,
    /// Triangles of the scene.
    pub triangles: u32,
    /// Grid resolution.
    pub grid: [u16; 3],
    /// Its multiplier m (GridRT Eq. 6.1).
    pub grid_m: f64,
    /// Its most voxels (a mesh with more gets a smaller m: `GridParams::max_voxels`).
    pub grid_max_voxels: u32,
    /// PEs.
    pub pe_count: u16,
    /// Stages the frame runs.
    pub plan: Vec<String>,
    /// Bytes the board's UART holds while the line drains them (the timeline's buffer).
    pub tx_buffer_bytes: u64,
    /// Soft-core profile of the modelled rows.
    pub cpu_profile: String,
    /// Its cycles per instruction.
    pub cpi: f64,
    /// Where the CPI comes from.
    pub cpi_citation: String,
    /// Wire bytes of the scene upload (both directions), not part of any frame: the
    /// loopback's, without the resends QEMU's slow UART causes.
    pub upload_bytes: Option<u64>,
    /// The upload at the baud rate (modelled).
    pub upload_ms: Option<f64>,
    /// Time of the f64 reference render on this machine.
    pub reference_ms: f64,
    /// `qemu-system-riscv32 --version`.
    pub qemu: Option<String>,
    /// Configurations asked for that get no row, and why.
    pub skipped: Vec<SkippedRow>,
    /// The simulated SoC's run, with a `soc` row.
    pub soc_sim: Option<SocSimReport>,
    /// One row per configuration × target.
    pub rows: Vec<FrameRow>,
}

/// A configuration asked for that gets no row.
#[derive(Debug, Clone, Serialize)]
pub struct SkippedRow {
    /// Configuration name.
    pub config: String,
    /// Why it has no row.
    pub why: String,
}

/// How the `soc` row's simulation went on this machine (wall-clock figures: measured here).
#[derive(Debug, Clone, Serialize)]
pub struct SocSimReport {
    /// Simulated cycles per wall-clock second during the render (the frame's cycles over the
    /// host's wall time of the render).
    pub sim_cycles_per_s: f64,
    /// The simulator's own figure since it started (`serial2pty`), when it printed one.
    pub sim_reported_cycles_per_s: Option<f64>,
    /// Wall seconds of the flash through the bootloader.
    pub flash_s: f64,
    /// Of the scene upload.
    pub upload_s: f64,
    /// Of the render.
    pub render_s: f64,
    /// How the host-to-SoC line is simulated.
    pub upload_line: String,
    /// Wire bytes of the upload, both directions (measured on the pty).
    pub upload_wire_bytes: u64,
    /// The SoC's cycles of the upload (`mcycle`, `stat::UPLOAD_CYCLES`; measured), with the
    /// line unpaced: what the firmware needs, without waiting for the line.
    pub upload_cycles: u64,
    /// Of those, in the device's input handling (`UPLOAD_FEED_CYCLES`); the rest read the UART.
    pub upload_feed_cycles: u64,
    /// Of the feed cycles, in the scene parser and loader (`UPLOAD_PARSE_CYCLES`).
    pub upload_parse_cycles: u64,
    /// `upload_cycles` per wire byte.
    pub upload_cycles_per_wire_byte: f64,
    /// `upload_cycles` at the SoC's clock: the firmware's own upload time (measured cycles).
    pub upload_device_ms: f64,
    /// The wire bytes at the baud rate (modelled): the line's time. On the board the upload
    /// takes at least the larger of the two.
    pub upload_line_ms: f64,
}

impl SocSimReport {
    /// The upload's figures of a `soc` run: measured cycles, the line modelled at `baud`.
    pub(crate) fn upload(&mut self, run: &DeviceRun, clock_mhz: f64, baud: u32) {
        self.upload_wire_bytes = run.upload_bytes;
        self.upload_cycles = run.stat(stat::UPLOAD_CYCLES);
        self.upload_feed_cycles = run.stat(stat::UPLOAD_FEED_CYCLES);
        self.upload_parse_cycles = run.stat(stat::UPLOAD_PARSE_CYCLES);
        self.upload_cycles_per_wire_byte = self.upload_cycles as f64 / run.upload_bytes.max(1) as f64;
        self.upload_device_ms = self.upload_cycles as f64 / (clock_mhz * 1e3);
        self.upload_line_ms = run.upload_bytes as f64 * 10.0 / f64::from(baud.max(1)) * 1e3;
    }
}

/// One configuration on one target.
#[derive(Debug, Clone, Serialize)]
pub struct FrameRow {
    /// Configuration name.
    pub config: String,
    /// Soft-core target (`riscv32imac`, `riscv32imafc`), or this CPU's architecture.
    pub target: String,
    /// Firmware instructions of the frame per primary ray (the link wrapper excluded).
    pub instructions_per_primary_ray: Option<f64>,
    /// `"qemu"` (QEMU `-icount shift=0`); later `"rtl"`; `null` for host-native.
    pub instructions_source: Option<String>,
    /// Soft-core busy time (modelled), or the measured wall time (host-native).
    pub cpu_ms: f64,
    /// Co-processor time of the frame (modelled).
    pub coproc_ms: f64,
    /// Line time of the render, both directions (modelled); on `soc` the line's busy time
    /// for the frame's bytes the SoC counted (`frame_tx_bytes` at the baud rate).
    pub link_ms: f64,
    /// The frame ([`timeline`]), or the measured wall time (host-native).
    pub frame_ms: f64,
    /// Frames per second.
    pub fps: f64,
    /// PSNR against the f64 reference, `null` when identical.
    pub psnr_db: Option<f64>,
    /// Byte-identical to the f64 reference.
    pub identical: bool,
    /// `"model"` or `"measured"`.
    pub frame_ms_source: String,
    /// Soft-core profile (`null` for host-native).
    pub cpu_profile: Option<String>,
    /// Its CPI.
    pub cpi: Option<f64>,
    /// `"cpi-model"` (instructions × the profile's CPI); `"rtl"`: instructions of each stage ×
    /// that stage's CPI measured on a cycle-accurate soft-core (`bench frame --cpu-measured`;
    /// `cpi` is then the frame's effective CPI).
    pub cpu_source: Option<String>,
    /// With `cpu_source` = `"rtl"`: the measured CPI per stage.
    pub cpi_by_stage: Option<BTreeMap<String, f64>>,
    /// Firmware instructions of the frame (the link wrapper excluded).
    pub instructions: Option<u64>,
    /// Per stage (`raygen`, `traverse`, `fsl_io`, `shade`, `encode`), per primary ray. With a
    /// co-processor `fsl_io` is the firmware's puts and gets (the wrapper taken out); in
    /// `soft-core-only` it holds the intersection itself (no FSL words).
    pub instructions_per_primary_ray_by_stage: Option<BTreeMap<String, f64>>,
    /// The qemu-virt link wrapper's own instructions in the frame (not charged above).
    pub link_wrapper_instructions: Option<u64>,
    /// The same per primary ray.
    pub link_wrapper_instructions_per_primary_ray: Option<f64>,
    /// Intersection kernel and number format that ran (`watertight/f32`; the RTL's
    /// `watertight/fixed64q23` in the `rtl` row).
    pub kernel: Option<String>,
    /// Co-processor timing profile, with its kernel-true cycles per test.
    pub coproc_profile: Option<String>,
    /// Cycles per ray–triangle test of that profile for the kernel that ran.
    pub coproc_test_cycles: Option<u32>,
    /// Clock the co-processor cycles are converted at, MHz.
    pub coproc_clock_mhz: Option<f64>,
    /// Where that clock comes from (`--clock-mhz`, or the `rtl` profile's while no synthesis
    /// of the RTL has an fmax).
    pub coproc_clock_source: Option<String>,
    /// Co-processor cycles of the frame.
    pub coproc_cycles: u64,
    /// Rays in flight in the co-processor (from the device, 1 when it does not say).
    pub rays_in_flight: u32,
    /// Co-processor time the soft-core waits for with one ray in flight.
    pub coproc_wait_ms: f64,
    /// Soft-core and co-processor together.
    pub work_ms: f64,
    /// Line time hidden behind the work.
    pub link_hidden_ms: f64,
    /// Camera rays.
    pub primary_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Reflection rays.
    pub reflection_rays: u64,
    /// Rays intersected (by the co-processor or, soft-core-only, by the firmware).
    pub coproc_rays: u64,
    /// Traversal-list entries.
    pub list_entries: u64,
    /// FSL words, both directions.
    pub fsl_words: u64,
    /// Ray–triangle tests (charged by the co-processor; run by the soft-core).
    pub intersection_tests: u64,
    /// Host → device wire bytes of the render.
    pub link_bytes_tx: u64,
    /// Device → host wire bytes of the render.
    pub link_bytes_rx: u64,
    /// Wall time of the run on this machine: QEMU's render, or the native frame.
    pub wall_ms: f64,
    /// The board the row describes and where its cycles come from.
    #[serde(flatten)]
    pub board: BoardFields,
}

/// The board of a row: its clock, line, PEs and harts, and where the frame's cycles come
/// from; on the `soc` row the SoC's own measurements.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BoardFields {
    /// `"soc-sim"`: the SoC's own counters in its cycle-accurate simulation; `"model"`:
    /// modelled; `null`: host-native (wall time).
    pub cycles_source: Option<String>,
    /// Cycles of the frame: on `soc` from the render request's arrival to the frame's last
    /// byte leaving the UART's transmit FIFO (`mcycle`); modelled rows: frame time × clock.
    pub frame_cycles: Option<u64>,
    /// The clock the row's cycles are converted at, MHz.
    pub clock_mhz: Option<f64>,
    /// `"routed"` (a `cargo xtask soc build --json` report, `--soc-build`), `"target"` (the
    /// SoC's target clock) or `"option"` (`--clock-mhz`).
    pub clock_source: Option<String>,
    /// Harts of the soft-core.
    pub harts: Option<u32>,
    /// `soc`: floating point in hardware on its CPU, `"none"` or `"cfu"`.
    pub float_hw: Option<String>,
    /// `soc`: KiB of the L2 cache in front of its SDRAM when `--soc-l2-kib` set one (null: the
    /// SoC's default, 8).
    pub l2_kib: Option<u32>,
    /// `soc`: PE memories as caches of N 8-word lines in front of the SDRAM (null: block RAM).
    pub pe_cache_lines: Option<u32>,
    /// PEs of the co-processor.
    pub pes: Option<u16>,
    /// Line rate of the UART (8N1).
    pub baud: Option<u32>,
    /// `soc`: cycles from the frame's first byte written to the UART to its transmit FIFO
    /// draining (measured; the frame's line time when the line is the bottleneck).
    pub link_cycles: Option<u64>,
    /// `soc`: bytes the SoC wrote to the UART in that span (measured).
    pub frame_tx_bytes: Option<u64>,
    /// `soc`: simulated cycles per wall-clock second during the render on this machine.
    pub sim_cycles_per_s: Option<f64>,
    /// `soc`: byte-identical to `gridrt render --sim --coproc rtl` of the same frame.
    pub identical_to_rtl_sim: Option<bool>,
    /// `soc` with several harts: where each hart's time went (measured, the device's
    /// `hartN_*` counters), the first hart first; null on one hart.
    pub hart_work: Option<Vec<HartShare>>,
    /// Modelled rows of a run with a `soc` row: this row's frame time ÷ the `soc` row's − 1
    /// (the same frame at the same clock and baud; the model's error where the row models
    /// the SoC, `rtl` on riscv32imac).
    pub vs_soc: Option<f64>,
}

/// One hart's part of a frame on the SoC (device keys `HART_*_BASE + h`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HartShare {
    /// Rows it traced.
    pub rows: u64,
    /// Cycles it spent tracing them.
    pub busy_cycles: u64,
    /// Cycles it waited: the first hart for the next row, a worker for a free row slot.
    pub wait_cycles: u64,
    /// `busy_cycles` ÷ the frame's cycles.
    pub busy_share: f64,
    /// `wait_cycles` ÷ the frame's cycles.
    pub wait_share: f64,
}

/// The per-hart counters of a frame shared by several harts (none when it has none).
fn hart_work(run: &DeviceRun, frame_cycles: u64) -> Option<Vec<HartShare>> {
    let shares: Vec<HartShare> = (0..STAT_HARTS)
        .map(|h| {
            let (busy, wait) = (run.stat(stat::HART_BUSY_BASE + h), run.stat(stat::HART_WAIT_BASE + h));
            let share = |cycles: u64| cycles as f64 / frame_cycles.max(1) as f64;
            HartShare {
                rows: run.stat(stat::HART_ROWS_BASE + h),
                busy_cycles: busy,
                wait_cycles: wait,
                busy_share: share(busy),
                wait_share: share(wait),
            }
        })
        .collect();
    let last = shares.iter().rposition(|s| s.rows > 0)?;
    (last > 0).then(|| shares[..=last].to_vec())
}

fn per_stage(run: &DeviceRun, wrapper: u64) -> (u64, BTreeMap<String, f64>) {
    let primary = run.stat(stat::PRIMARY_RAYS).max(1) as f64;
    let mut total = 0u64;
    let by_stage = Stage::ALL
        .iter()
        .map(|&s| {
            let mut n = run.stat(s.instret_key());
            if s == Stage::FslIo {
                n = n.saturating_sub(wrapper);
            }
            total += n;
            (stage_name(s).to_string(), n as f64 / primary)
        })
        .collect();
    (total, by_stage)
}

/// The qemu-virt link wrapper's instructions in the frame, and how many of them the `fsl_io`
/// counter still holds. An image that excludes the wrapper itself reports it
/// ([`stat::LINK_WRAPPER_INSTRUCTIONS`], none left in `fsl_io`); an older one leaves it in
/// `fsl_io` and prints its cost per FSL word in the banner (every wrapped put and get is one
/// word: the virtual co-processor never makes the firmware poll).
fn link_wrapper(run: &DeviceRun) -> (Option<u64>, u64) {
    let reported = run.stat(stat::LINK_WRAPPER_INSTRUCTIONS);
    if reported > 0 {
        return (Some(reported), 0);
    }
    let words = run.stat(stat::FSL_WORDS_OUT) + run.stat(stat::FSL_WORDS_IN);
    let banner = run.wrapper_per_word.map(|k| k * words);
    (banner, banner.unwrap_or(0))
}

/// `psnr_db` and `identical` of a comparison with the reference.
fn quality(c: &Comparison) -> (Option<f64>, bool) {
    (c.psnr_db, c.identical)
}

/// The row of a configuration on the soft-core: instructions from the QEMU run `run`,
/// co-processor cycles from the loopback run `model` with its profile.
pub(crate) fn device_row(
    config: Configuration,
    target: Target,
    run: &DeviceRun,
    model: Option<(TimingProfile, &DeviceRun)>,
    cmp: &Comparison,
    opt: &BenchOptions,
) -> FrameRow {
    let words = run.stat(stat::FSL_WORDS_OUT) + run.stat(stat::FSL_WORDS_IN);
    let (wrapper, in_fsl_io) = link_wrapper(run);
    let (instructions, by_stage) = per_stage(run, in_fsl_io);
    let primary = run.stat(stat::PRIMARY_RAYS).max(1) as f64;
    let (kind, format) = config.kernel();
    let (profile, coproc_cycles) = match model {
        Some((p, sim)) => (Some(p.for_kernel(kind, format)), sim.stat(stat::COPROC_CYCLES)),
        None => (None, 0),
    };
    let (coproc_clock_hz, coproc_clock_source) = config.coproc_clock(opt.clock_mhz);
    // Measured CPI per stage for the soft-float image (a core without FPU measured it);
    // else the profile's one CPI. Not for soft-core-only: its `fsl_io` holds the whole
    // soft-float intersection, code the measurement never ran (its rows keep the profile's
    // CPI, as a model).
    let measured =
        opt.measured_cpi.as_ref().filter(|_| target == Target::Riscv32imac && config != Configuration::SoftCoreOnly);
    let cpi_by_stage: Option<BTreeMap<String, f64>> =
        measured.map(|m| by_stage.keys().filter_map(|s| Some((s.clone(), m.cpi(s)?))).collect());
    let cpu_cycles = match &cpi_by_stage {
        Some(cpi) => by_stage.iter().map(|(s, per_ray)| per_ray * primary * cpi.get(s).copied().unwrap_or(1.0)).sum(),
        None => instructions as f64 * opt.cpu.cpi,
    };
    let work = FrameWork {
        coproc_clock_hz,
        cpu_cycles,
        coproc_cycles: coproc_cycles as f64,
        coproc_request_cycles: profile.map_or(0.0, |p| run.stat(stat::FSL_WORDS_OUT) as f64 * p.word_in_cycles as f64),
        coproc_rays: run.stat(stat::COPROC_RAYS),
        rays_in_flight: run.rays_in_flight(),
        clock_hz: opt.clock_mhz * 1e6,
        baud: opt.baud,
        request_bytes: run.frame.bytes_tx,
        answer_bytes: run.frame.bytes_rx,
        tail_bytes: run.tail_bytes,
        bursts: run.frame.spans_reported as u64,
        tx_buffer_bytes: opt.tx_buffer_bytes,
    };
    let t = timeline(&work);
    let (psnr_db, identical) = quality(cmp);
    FrameRow {
        config: config.name().into(),
        target: target.name().into(),
        instructions_per_primary_ray: Some(instructions as f64 / primary),
        instructions_source: Some("qemu".into()),
        cpu_ms: t.cpu_s * 1e3,
        coproc_ms: t.coproc_s * 1e3,
        link_ms: t.link_s * 1e3,
        frame_ms: t.frame_s * 1e3,
        fps: t.fps(),
        psnr_db,
        identical,
        frame_ms_source: "model".into(),
        cpu_profile: Some(measured.map_or_else(|| opt.cpu.name.to_string(), |m| m.core.clone())),
        cpi: Some(if measured.is_some() { cpu_cycles / instructions.max(1) as f64 } else { opt.cpu.cpi }),
        cpu_source: Some(if measured.is_some() { "rtl" } else { "cpi-model" }.into()),
        cpi_by_stage,
        instructions: Some(instructions),
        instructions_per_primary_ray_by_stage: Some(by_stage),
        link_wrapper_instructions: wrapper,
        link_wrapper_instructions_per_primary_ray: wrapper.map(|w| w as f64 / primary),
        kernel: Some(kernel_name(kind, format)),
        coproc_profile: profile.map(|p| p.name.to_string()),
        coproc_test_cycles: profile.map(|p| p.test_issue_cycles),
        coproc_clock_mhz: profile.map(|_| coproc_clock_hz / 1e6),
        coproc_clock_source: profile.map(|_| coproc_clock_source.to_string()),
        coproc_cycles,
        rays_in_flight: work.rays_in_flight,
        coproc_wait_ms: t.coproc_wait_s * 1e3,
        work_ms: t.work_s * 1e3,
        link_hidden_ms: t.link_hidden_s * 1e3,
        primary_rays: run.stat(stat::PRIMARY_RAYS),
        shadow_rays: run.stat(stat::SHADOW_RAYS),
        reflection_rays: run.stat(stat::REFLECTION_RAYS),
        coproc_rays: run.stat(stat::COPROC_RAYS),
        list_entries: run.stat(stat::LIST_ENTRIES),
        fsl_words: words,
        intersection_tests: run.stat(stat::INTERSECTION_TESTS),
        link_bytes_tx: run.frame.bytes_tx,
        link_bytes_rx: run.frame.bytes_rx,
        wall_ms: run.wall_ms,
        board: BoardFields {
            cycles_source: Some("model".into()),
            frame_cycles: Some((t.frame_s * opt.clock_mhz * 1e6).round() as u64),
            clock_mhz: Some(opt.clock_mhz),
            clock_source: Some(opt.clock_source.to_string()),
            harts: Some(1),
            pes: Some(super::run::QEMU_PE_COUNT),
            baud: Some(opt.baud),
            ..BoardFields::default()
        },
    }
}

/// The `soc` row: every figure measured by the SoC's own counters in its cycle-accurate
/// simulation (`soc` module); the image compared with the f64 reference (`cmp`).
pub(crate) fn soc_row(soc: &SocRun, cmp: &Comparison) -> FrameRow {
    let run = &soc.run;
    let hz = soc.clock.clock_mhz * 1e6;
    let ms = |cycles: u64| cycles as f64 / hz * 1e3;
    let primary = run.stat(stat::PRIMARY_RAYS).max(1) as f64;
    let (mut cycles, mut instructions) = (0u64, 0u64);
    let mut by_stage = BTreeMap::new();
    let mut cpi_by_stage = BTreeMap::new();
    for s in Stage::ALL {
        let (c, i) = (run.stat(s.cycles_key()), run.stat(s.instret_key()));
        cycles += c;
        instructions += i;
        by_stage.insert(stage_name(s).to_string(), i as f64 / primary);
        if i > 0 {
            cpi_by_stage.insert(stage_name(s).to_string(), c as f64 / i as f64);
        }
    }
    let frame_cycles = run.stat(stat::FRAME_CYCLES);
    let link_cycles = run.stat(stat::LINK_CYCLES);
    let coproc_cycles = run.stat(stat::COPROC_CYCLES);
    let frame_ms = ms(frame_cycles);
    let (psnr_db, identical) = quality(cmp);
    let (kind, format) = Configuration::Soc.kernel();
    let profile = TimingProfile::RTL.for_kernel(kind, format);
    let words = run.stat(stat::FSL_WORDS_OUT) + run.stat(stat::FSL_WORDS_IN);
    // A frame shared between harts times no stage (only the whole frame): no instruction
    // figures rather than zeros.
    let timed = instructions > 0;
    FrameRow {
        config: Configuration::Soc.name().into(),
        target: soc.float_hw.target().into(),
        instructions_per_primary_ray: timed.then(|| instructions as f64 / primary),
        instructions_source: Some("soc-sim".into()),
        cpu_ms: ms(cycles),
        coproc_ms: ms(coproc_cycles),
        // The line's busy time: the frame's bytes at the baud rate (the span from its first
        // byte to the drain is `link_cycles`, which includes the line's idle gaps).
        link_ms: run.stat(stat::FRAME_TX_BYTES) as f64 * 10.0 / f64::from(soc.clock.baud.max(1)) * 1e3,
        frame_ms,
        fps: if frame_ms > 0.0 { 1e3 / frame_ms } else { 0.0 },
        psnr_db,
        identical,
        frame_ms_source: "measured".into(),
        cpu_profile: Some(soc.float_hw.cpu().into()),
        cpi: timed.then(|| cycles as f64 / instructions as f64),
        cpu_source: Some("soc-sim".into()),
        cpi_by_stage: timed.then_some(cpi_by_stage),
        instructions: timed.then_some(instructions),
        instructions_per_primary_ray_by_stage: timed.then_some(by_stage),
        link_wrapper_instructions: None,
        link_wrapper_instructions_per_primary_ray: None,
        kernel: Some(kernel_name(kind, format)),
        coproc_profile: Some(profile.name.to_string()),
        coproc_test_cycles: Some(profile.test_issue_cycles),
        coproc_clock_mhz: Some(soc.clock.clock_mhz),
        coproc_clock_source: Some(format!("one clock with the soft-core ({})", soc.clock.source)),
        coproc_cycles,
        rays_in_flight: run.rays_in_flight(),
        coproc_wait_ms: ms(run.stat(Stage::FslIo.cycles_key())),
        work_ms: ms(cycles),
        link_hidden_ms: (ms(cycles)
            + run.stat(stat::FRAME_TX_BYTES) as f64 * 10.0 / f64::from(soc.clock.baud.max(1)) * 1e3
            - frame_ms)
            .max(0.0),
        primary_rays: run.stat(stat::PRIMARY_RAYS),
        shadow_rays: run.stat(stat::SHADOW_RAYS),
        reflection_rays: run.stat(stat::REFLECTION_RAYS),
        coproc_rays: run.stat(stat::COPROC_RAYS),
        list_entries: run.stat(stat::LIST_ENTRIES),
        fsl_words: words,
        intersection_tests: run.stat(stat::INTERSECTION_TESTS),
        link_bytes_tx: run.frame.bytes_tx,
        link_bytes_rx: run.frame.bytes_rx,
        wall_ms: run.wall_ms,
        board: BoardFields {
            cycles_source: Some("soc-sim".into()),
            frame_cycles: Some(frame_cycles),
            clock_mhz: Some(soc.clock.clock_mhz),
            clock_source: Some(soc.clock.source.into()),
            harts: Some(soc.harts),
            float_hw: Some(soc.float_hw.name().into()),
            l2_kib: soc.l2_kib,
            pe_cache_lines: Some(soc.pe_cache_lines).filter(|&n| n != 0),
            pes: Some(soc.pes),
            baud: Some(soc.clock.baud),
            link_cycles: Some(link_cycles),
            frame_tx_bytes: Some(run.stat(stat::FRAME_TX_BYTES)),
            sim_cycles_per_s: Some(soc.sim_cycles_per_s),
            identical_to_rtl_sim: Some(run.frame.rgb == soc.rtl.frame.rgb),
            hart_work: hart_work(run, frame_cycles),
            vs_soc: None,
        },
    }
}

/// Sets `vs_soc` on every modelled row when `rows` has a `soc` row.
pub(crate) fn distance_from_soc(rows: &mut [FrameRow]) {
    // The modelled rows model one soft-float VexRiscv imac: a CFU build is another CPU, two
    // harts another board.
    let soft = |r: &&FrameRow| r.board.float_hw.as_deref() != Some(SocFloatHw::Cfu.name()) && r.board.harts == Some(1);
    let Some(soc_ms) = rows.iter().filter(soft).find(|r| r.config == Configuration::Soc.name()).map(|r| r.frame_ms)
    else {
        return;
    };
    for r in rows.iter_mut().filter(|r| r.board.cycles_source.as_deref() == Some("model")) {
        r.board.vs_soc = (soc_ms > 0.0).then(|| r.frame_ms / soc_ms - 1.0);
    }
}

/// `kind/format` as reports name them.
fn kernel_name(kind: gridrt_coproc::KernelKind, format: gridrt_coproc::NumberFormat) -> String {
    format!("{kind:?}/{format:?}").to_lowercase()
}

/// The host-native row: measured wall time, no link.
pub(crate) fn native_row(run: &DeviceRun, cmp: &Comparison) -> FrameRow {
    let (psnr_db, identical) = quality(cmp);
    let ms = run.wall_ms;
    FrameRow {
        config: Configuration::HostNative.name().into(),
        target: std::env::consts::ARCH.into(),
        instructions_per_primary_ray: None,
        instructions_source: None,
        cpu_ms: ms,
        coproc_ms: 0.0,
        link_ms: 0.0,
        frame_ms: ms,
        fps: if ms > 0.0 { 1e3 / ms } else { f64::INFINITY },
        psnr_db,
        identical,
        frame_ms_source: "measured".into(),
        cpu_profile: None,
        cpi: None,
        cpu_source: None,
        cpi_by_stage: None,
        instructions: None,
        instructions_per_primary_ray_by_stage: None,
        link_wrapper_instructions: None,
        link_wrapper_instructions_per_primary_ray: None,
        kernel: Some(kernel_name(kernel().0, kernel().1)),
        coproc_profile: None,
        coproc_test_cycles: None,
        coproc_clock_mhz: None,
        coproc_clock_source: None,
        coproc_cycles: 0,
        rays_in_flight: 1,
        coproc_wait_ms: 0.0,
        work_ms: ms,
        link_hidden_ms: 0.0,
        primary_rays: run.stat(stat::PRIMARY_RAYS),
        shadow_rays: run.stat(stat::SHADOW_RAYS),
        reflection_rays: run.stat(stat::REFLECTION_RAYS),
        coproc_rays: run.stat(stat::COPROC_RAYS),
        list_entries: run.stat(stat::LIST_ENTRIES),
        fsl_words: 0,
        intersection_tests: run.stat(stat::INTERSECTION_TESTS),
        link_bytes_tx: 0,
        link_bytes_rx: 0,
        wall_ms: ms,
        board: BoardFields::default(),
    }
}

fn opt_num(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(String::new, |v| format!("{v:.digits$}"))
}

/// Writes the rows as CSV (one line per row; per-stage instructions per primary ray as
/// columns).
pub fn write_csv(path: &Path, report: &FrameReport) -> std::io::Result<()> {
    let stages: Vec<&str> = Stage::ALL.iter().map(|&s| stage_name(s)).collect();
    let mut s = String::from(
        "config,target,instructions_per_primary_ray,instructions_source,cpu_ms,coproc_ms,link_ms,frame_ms,fps,psnr_db,identical,frame_ms_source,",
    );
    for st in &stages {
        let _ = write!(s, "{st}_per_primary_ray,");
    }
    s.push_str("link_wrapper_per_primary_ray,kernel,coproc_profile,coproc_test_cycles,coproc_clock_mhz,coproc_cycles,rays_in_flight,coproc_wait_ms,work_ms,link_hidden_ms,cpu_profile,cpi,intersection_tests,wall_ms\n");
    for r in &report.rows {
        let _ = write!(
            s,
            "{},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.4},{},{},{},",
            r.config,
            r.target,
            opt_num(r.instructions_per_primary_ray, 1),
            r.instructions_source.as_deref().unwrap_or(""),
            r.cpu_ms,
            r.coproc_ms,
            r.link_ms,
            r.frame_ms,
            r.fps,
            opt_num(r.psnr_db, 2),
            r.identical,
            r.frame_ms_source
        );
        for st in &stages {
            let v = r.instructions_per_primary_ray_by_stage.as_ref().and_then(|m| m.get(*st).copied());
            let _ = write!(s, "{},", opt_num(v, 1));
        }
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{:.3},{:.3},{:.3},{},{},{},{:.1}",
            opt_num(r.link_wrapper_instructions_per_primary_ray, 1),
            r.kernel.as_deref().unwrap_or(""),
            r.coproc_profile.as_deref().unwrap_or(""),
            r.coproc_test_cycles.map_or_else(String::new, |c| c.to_string()),
            opt_num(r.coproc_clock_mhz, 1),
            r.coproc_cycles,
            r.rays_in_flight,
            r.coproc_wait_ms,
            r.work_ms,
            r.link_hidden_ms,
            r.cpu_profile.as_deref().unwrap_or(""),
            opt_num(r.cpi, 2),
            r.intersection_tests,
            r.wall_ms
        );
    }
    std::fs::write(path, s)
}

/// The three parts of a row's frame time that add up to it: soft-core busy, co-processor
/// not hidden behind it, link not hidden behind the work (ms).
pub fn critical_path(r: &FrameRow) -> [f64; 3] {
    let cpu = r.cpu_ms.min(r.work_ms);
    [cpu, (r.work_ms - cpu).max(0.0), (r.frame_ms - r.work_ms).max(0.0)]
}

/// Writes an SVG of horizontal stacked bars: per row, the frame time split into
/// [`critical_path`]'s parts, its total written at the end.
pub fn write_svg(path: &Path, report: &FrameReport) -> Result<(), String> {
    use plotters::prelude::*;
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let n = report.rows.len().max(1);
    let height = 140 + 46 * n as u32;
    let root = SVGBackend::new(path, (980, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let xmax = report.rows.iter().map(|r| r.frame_ms).fold(1e-3, f64::max) * 1.25;
    let labels: Vec<String> = report.rows.iter().map(|r| format!("{} / {}", r.config, r.target)).collect();
    let name = Path::new(&report.scene).file_name().map_or(report.scene.clone(), |s| s.to_string_lossy().into_owned());
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Frame time, {name} {}×{}, {} MHz, {} baud, {} (CPI {})",
                report.width, report.height, report.clock_mhz, report.baud, report.cpu_profile, report.cpi
            ),
            ("sans-serif", 18),
        )
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(230)
        .build_cartesian_2d(0f64..xmax, 0f64..n as f64)
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(n * 2 + 1)
        .y_label_formatter(&|y| {
            let k = y - 0.5;
            if (k - k.round()).abs() < 1e-6 && k >= 0.0 {
                labels.get(n - 1 - k.round() as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .x_desc("frame time (ms); modelled except host-native (measured wall time)")
        .draw()
        .map_err(|x| e(&x))?;
    let parts = [
        ("soft-core", RGBColor(70, 110, 200)),
        ("co-processor, not overlapped", RGBColor(230, 140, 40)),
        ("UART, not overlapped", RGBColor(90, 170, 90)),
    ];
    for (k, &(label, colour)) in parts.iter().enumerate() {
        let bars: Vec<_> = report
            .rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let p = critical_path(r);
                let x0: f64 = p[..k].iter().sum();
                let y = (n - 1 - i) as f64;
                Rectangle::new([(x0, y + 0.15), (x0 + p[k], y + 0.85)], colour.filled())
            })
            .collect();
        chart
            .draw_series(bars)
            .map_err(|x| e(&x))?
            .label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.filled()));
    }
    chart
        .draw_series(report.rows.iter().enumerate().map(|(i, r)| {
            let y = (n - 1 - i) as f64 + 0.5;
            let q = if r.identical { "identical".to_string() } else { opt_num(r.psnr_db, 1) + " dB" };
            let style = ("sans-serif", 13).into_font().into_text_style(&root).pos(Pos::new(HPos::Left, VPos::Center));
            Text::new(format!(" {:.1} ms ({:.2} fps, {q})", r.frame_ms, r.fps), (r.frame_ms, y), style)
        }))
        .map_err(|x| e(&x))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.85))
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    Ok(())
}
