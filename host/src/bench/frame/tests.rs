//! The bench's rows and JSON on a small frame, without QEMU: the loopback stands in for the
//! QEMU run (same device code), with per-stage instruction counters set by hand.

use std::path::Path;

use gridrt_coproc::TimingProfile;
use gridrt_firmware::device::Stage;
use gridrt_shared::msg::{stat, PixelEncoding};

use super::report::{device_row, native_row};
use super::*;
use crate::compare::compare;

fn res4() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes/bun_zipper_res4.obj"))
}

fn options() -> BenchOptions {
    BenchOptions {
        scene: res4().into(),
        width: 16,
        height: 12,
        clock_mhz: 100.0,
        clock_source: "option",
        baud: 921_600,
        encoding: PixelEncoding::Rle,
        grid_m: 1.0,
        grid_max_voxels: crate::grid::MAX_VOXELS,
        soc_float_hw: SocFloatHw::None,
        soc_l2_kib: None,
        soc_harts: 1,
        soc_pe_cache_lines: 0,
        tx_buffer_bytes: 16,
        cpu: CpuProfile::PICORV32,
        measured_cpi: None,
        configs: Configuration::ALL.to_vec(),
        targets: Target::ALL.to_vec(),
        native_warmup: 0,
        native_runs: 1,
        repo: ".".into(),
    }
}

/// An image that excludes its link wrapper itself reports it as a stat: the row takes that
/// and leaves `fsl_io` as counted (the banner's per-word cost is not subtracted again).
#[test]
fn a_wrapper_the_device_reports_is_not_taken_out_twice() {
    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let mut run = run_on_loopback(TimingProfile::GRIDRT, kernel(), &prepared, &req, "t", quiet).unwrap();
    let sim = run.clone();
    for s in Stage::ALL {
        run.frame.stats.insert(s.instret_key(), 1000);
    }
    run.frame.stats.insert(stat::LINK_WRAPPER_INSTRUCTIONS, 777);
    run.wrapper_per_word = Some(30);
    let cmp = compare(&run.frame.rgb, &run.frame.rgb, None, None).unwrap();
    let row =
        device_row(Configuration::Gridrt, Target::Riscv32imafc, &run, Some((TimingProfile::GRIDRT, &sim)), &cmp, &opt);
    assert_eq!(row.instructions, Some(5 * 1000));
    assert_eq!(row.link_wrapper_instructions, Some(777));
}

/// Every field of the frame report, plus the ones this bench adds, with the arithmetic of a
/// co-processor row worked out from its inputs.
#[test]
fn a_device_row_charges_the_firmware_without_the_wrapper_and_serialises_every_issue_field() {
    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let mut run = run_on_loopback(TimingProfile::GRIDRT, kernel(), &prepared, &req, "t", quiet).unwrap();
    let sim = run.clone();
    // As if QEMU had counted: 1000 instructions per stage, the wrapper 30 per FSL word.
    for s in Stage::ALL {
        run.frame.stats.insert(s.instret_key(), 1000 + run.stat(stat::FSL_WORDS_OUT) * 100);
    }
    run.wrapper_per_word = Some(30);
    let words = run.stat(stat::FSL_WORDS_OUT) + run.stat(stat::FSL_WORDS_IN);
    assert!(words > 0 && 30 * words < 1000 + run.stat(stat::FSL_WORDS_OUT) * 100);
    let cmp = compare(&run.frame.rgb, &run.frame.rgb, None, None).unwrap();
    let row =
        device_row(Configuration::Gridrt, Target::Riscv32imafc, &run, Some((TimingProfile::GRIDRT, &sim)), &cmp, &opt);

    let per_stage = 1000 + run.stat(stat::FSL_WORDS_OUT) * 100;
    let instructions = 5 * per_stage - 30 * words;
    assert_eq!(row.instructions, Some(instructions));
    assert_eq!(row.link_wrapper_instructions, Some(30 * words));
    let primary = run.stat(stat::PRIMARY_RAYS) as f64;
    assert_eq!(primary, 16.0 * 12.0);
    assert!((row.instructions_per_primary_ray.unwrap() - instructions as f64 / primary).abs() < 1e-9);
    // 4.1 cycles per instruction at 100 MHz.
    assert!((row.cpu_ms - instructions as f64 * 4.1 / 100e6 * 1e3).abs() < 1e-9, "{row:?}");
    // Kernel-true: watertight f32 on GridRT's PE.
    assert_eq!(row.coproc_test_cycles, Some(1188));
    assert_eq!(row.coproc_cycles, sim.stat(stat::COPROC_CYCLES));
    assert!((row.coproc_ms - row.coproc_cycles as f64 / 100e6 * 1e3).abs() < 1e-9);
    let link_bytes = (run.frame.bytes_tx + run.frame.bytes_rx) as f64;
    assert!((row.link_ms - link_bytes * 10.0 / 921_600.0 * 1e3).abs() < 1e-9);
    // One ray in flight: frame = request + cpu + wait + answer − hidden.
    assert_eq!(row.rays_in_flight, 1);
    let want = run.frame.bytes_tx as f64 * 10.0 / 921_600.0 * 1e3
        + row.cpu_ms
        + row.coproc_wait_ms
        + run.frame.bytes_rx as f64 * 10.0 / 921_600.0 * 1e3
        - row.link_hidden_ms;
    assert!((row.frame_ms - want).abs() < 1e-9, "{} vs {want}", row.frame_ms);
    assert!((row.fps - 1e3 / row.frame_ms).abs() < 1e-9);
    let parts = critical_path(&row);
    assert!((parts.iter().sum::<f64>() - row.frame_ms).abs() < 1e-9);

    let v = serde_json::to_value(&row).unwrap();
    for key in [
        "config",
        "target",
        "instructions_per_primary_ray",
        "instructions_source",
        "cpu_ms",
        "coproc_ms",
        "link_ms",
        "frame_ms",
        "fps",
        "psnr_db",
        "identical",
        "cpu_profile",
        "cpi",
        "cpu_source",
        "link_wrapper_instructions_per_primary_ray",
        "instructions_per_primary_ray_by_stage",
    ] {
        assert!(v.get(key).is_some(), "row lacks {key}: {v}");
    }
    assert_eq!(v["config"], "gridrt");
    assert_eq!(v["target"], "riscv32imafc");
    assert_eq!(v["instructions_source"], "qemu");
    assert_eq!(v["cpu_source"], "cpi-model");
    assert_eq!(v["psnr_db"], serde_json::Value::Null);
    assert_eq!(v["identical"], true);
    let stages = v["instructions_per_primary_ray_by_stage"].as_object().unwrap();
    assert_eq!(stages.len(), 5);
    assert!((stages["fsl_io"].as_f64().unwrap() - (per_stage - 30 * words) as f64 / primary).abs() < 1e-9);
}

/// `--cpu-measured`: the soft-float rows charge each stage's instructions at that stage's
/// measured CPI (`cpu_source` = `"rtl"`); the hard-float rows keep the profile (the measured
/// core has no FPU); stats without per-stage cycles are refused.
#[test]
fn measured_cpi_charges_each_stage_at_its_own_cpi_on_the_soft_float_target_only() {
    let stats = serde_json::json!({ "device_counters": {
        "stage_raygen_cycles": 2000, "stage_raygen_instret": 1000,
        "stage_traverse_cycles": 3000, "stage_traverse_instret": 1000,
        "stage_fsl_io_cycles": 5000, "stage_fsl_io_instret": 1000,
        "stage_shade_cycles": 1500, "stage_shade_instret": 1000,
        "stage_encode_cycles": 1000, "stage_encode_instret": 1000,
    }});
    let measured = MeasuredCpi::from_stats_json("vexriscv-imac", "soc.json", &stats.to_string()).unwrap();
    assert_eq!(measured.cpi("fsl_io"), Some(5.0));
    let mut opt = options();
    opt.measured_cpi = Some(measured);
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let mut run = run_on_loopback(TimingProfile::GRIDRT, kernel(), &prepared, &req, "t", quiet).unwrap();
    let sim = run.clone();
    for s in Stage::ALL {
        run.frame.stats.insert(s.instret_key(), 960);
    }
    run.frame.stats.insert(stat::LINK_WRAPPER_INSTRUCTIONS, 1);
    let cmp = compare(&run.frame.rgb, &run.frame.rgb, None, None).unwrap();
    let model = Some((TimingProfile::GRIDRT, &sim));
    let soft = device_row(Configuration::Gridrt, Target::Riscv32imac, &run, model, &cmp, &opt);
    // 960 instructions per stage at CPI 2 + 3 + 5 + 1.5 + 1 at 100 MHz.
    assert!((soft.cpu_ms - 960.0 * 12.5 / 100e6 * 1e3).abs() < 1e-9, "{soft:?}");
    assert_eq!(soft.cpu_source.as_deref(), Some("rtl"));
    assert_eq!(soft.cpu_profile.as_deref(), Some("vexriscv-imac"));
    assert!((soft.cpi.unwrap() - 12.5 / 5.0).abs() < 1e-12);
    assert_eq!(soft.cpi_by_stage.as_ref().unwrap()["traverse"], 3.0);
    let hard = device_row(Configuration::Gridrt, Target::Riscv32imafc, &run, model, &cmp, &opt);
    assert_eq!((hard.cpu_source.as_deref(), hard.cpi), (Some("cpi-model"), Some(4.1)));
    assert!(hard.cpi_by_stage.is_none());

    let qemu_stats = serde_json::json!({ "device_counters": { "stage_raygen_instret": 1000 } });
    let e = MeasuredCpi::from_stats_json("vexriscv-imac", "q.json", &qemu_stats.to_string()).unwrap_err();
    assert!(e.contains("stage_raygen_cycles"), "{e}");
}

/// The host-native run is the soft-core-only firmware compiled for this CPU: the same image
/// as the loopback, the tests only up to each winner, and a row with no instruction source.
#[test]
fn host_native_renders_the_loopbacks_image_and_reports_measured_wall_time() {
    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let sim = run_on_loopback(TimingProfile::GRIDRT, kernel(), &prepared, &req, "t", quiet).unwrap();
    let native = run_native(&prepared, &req, 0, 2, quiet).unwrap();
    assert_eq!(native.frame.rgb, sim.frame.rgb);
    for k in [stat::PRIMARY_RAYS, stat::SHADOW_RAYS, stat::COPROC_RAYS, stat::LIST_ENTRIES] {
        assert_eq!(native.stat(k), sim.stat(k), "{}", crate::stats::stat_name(k));
    }
    assert_eq!(native.stat(stat::FSL_WORDS_OUT), 0);
    assert!(native.stat(stat::INTERSECTION_TESTS) <= sim.stat(stat::INTERSECTION_TESTS));
    assert!(native.wall_ms > 0.0);
    let cmp = compare(&native.frame.rgb, &sim.frame.rgb, None, None).unwrap();
    let v = serde_json::to_value(native_row(&native, &cmp)).unwrap();
    assert_eq!(v["config"], "host-native");
    assert_eq!(v["instructions_source"], serde_json::Value::Null);
    assert_eq!(v["instructions_per_primary_ray"], serde_json::Value::Null);
    assert_eq!(v["frame_ms_source"], "measured");
    assert_eq!(v["frame_ms"], v["cpu_ms"]);
    assert_eq!(v["link_ms"], 0.0);
}

/// The CSV has the issue's columns and a line per row; the SVG a bar label per row.
#[test]
fn csv_and_svg_have_a_line_and_a_bar_label_per_row() {
    let opt = options();
    let (prepared, req, _) = prepare(res4(), 8, 6, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let sim = run_on_loopback(TimingProfile::PIPELINED, kernel(), &prepared, &req, "t", quiet).unwrap();
    let cmp = compare(&sim.frame.rgb, &sim.frame.rgb, None, None).unwrap();
    let rows = vec![
        device_row(
            Configuration::Pipelined,
            Target::Riscv32imac,
            &sim,
            Some((TimingProfile::PIPELINED, &sim)),
            &cmp,
            &opt,
        ),
        native_row(&sim, &cmp),
    ];
    let report = FrameReport {
        scene: "tests/scenes/bun_zipper_res4.obj".into(),
        width: 8,
        height: 6,
        clock_mhz: 100.0,
        baud: 921_600,
        encoding: "rle".into(),
        kernel: "watertight".into(),
        number_format: "f32".into(),
        triangles: 946,
        grid: [11, 11, 9],
        grid_m: 1.0,
        grid_max_voxels: crate::grid::MAX_VOXELS,
        pe_count: 4,
        plan: vec!["shadows".into()],
        tx_buffer_bytes: 16,
        cpu_profile: "picorv32".into(),
        cpi: 4.1,
        cpi_citation: String::new(),
        upload_bytes: Some(1),
        upload_ms: Some(0.0),
        reference_ms: 0.0,
        qemu: None,
        skipped: Vec::new(),
        soc_sim: None,
        rows,
    };
    let dir = std::env::temp_dir().join(format!("gridrt-frame-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_csv(&dir.join("frame.csv"), &report).unwrap();
    write_svg(&dir.join("frame.svg"), &report).unwrap();
    let csv = std::fs::read_to_string(dir.join("frame.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[0].starts_with(
        "config,target,instructions_per_primary_ray,instructions_source,cpu_ms,coproc_ms,link_ms,frame_ms,fps,psnr_db,identical"
    ));
    assert!(lines[1].starts_with("pipelined,riscv32imac,") && lines[2].starts_with("host-native,"), "{csv}");
    let columns = lines[0].split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == columns), "{csv}");
    let svg = std::fs::read_to_string(dir.join("frame.svg")).unwrap();
    for label in ["pipelined / riscv32imac", "host-native / ", "soft-core", "UART, not overlapped"] {
        assert!(svg.contains(label), "the plot lacks {label}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn configurations_targets_and_profiles_parse_their_names() {
    for c in Configuration::ALL {
        assert_eq!(Configuration::parse(c.name()), Some(c));
    }
    assert_eq!(Configuration::parse("rtl"), Some(Configuration::Rtl));
    assert_eq!(Configuration::parse("rtl-synth"), None);
    for t in Target::ALL {
        assert_eq!(Target::parse(t.name()), Some(t));
    }
    assert_eq!(CpuProfile::parse("picorv32").map(|p| p.cpi), Some(4.1));
    assert_eq!(CpuProfile::parse("cpi1").map(|p| p.cpi), Some(1.0));
    assert!(matches!(Configuration::Gridrt.coproc(), CoprocCycles::Model(p) if p == TimingProfile::GRIDRT));
    assert_eq!(Configuration::SoftCoreOnly.coproc(), CoprocCycles::None);
}

/// The `rtl` row is the RTL's: its kernel and format (the image of `--coproc rtl`), the cycles
/// of [`TimingProfile::RTL`] on the loopback, converted at the board's one clock (the SoC runs
/// both on `sys_clk`); every other configuration keeps its kernel.
#[test]
fn the_rtl_row_runs_the_rtls_kernel_and_charges_its_profile_at_the_boards_one_clock() {
    use gridrt_coproc::{KernelKind, NumberFormat};
    assert!(matches!(Configuration::Rtl.coproc(), CoprocCycles::Model(p) if p == TimingProfile::RTL));
    assert_eq!(Configuration::Rtl.kernel(), (KernelKind::Watertight, NumberFormat::Fixed64Q23));
    assert_eq!(Configuration::Rtl.image(), Some(Image::CoprocRtl));
    assert_eq!(Image::CoprocRtl.features(), &["coproc-rtl"]);
    for c in [Configuration::SoftCoreOnly, Configuration::Gridrt, Configuration::Pipelined] {
        assert_eq!(c.kernel(), kernel(), "{c:?}");
    }

    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let quiet = &mut |_| {};
    let sim = run_on_loopback(TimingProfile::RTL, Configuration::Rtl.kernel(), &prepared, &req, "t", quiet).unwrap();
    let cmp = compare(&sim.frame.rgb, &sim.frame.rgb, None, None).unwrap();
    let row = device_row(Configuration::Rtl, Target::Riscv32imafc, &sim, Some((TimingProfile::RTL, &sim)), &cmp, &opt);
    assert_eq!(row.kernel.as_deref(), Some("watertight/fixed64q23"));
    assert_eq!(row.coproc_profile.as_deref(), Some("rtl"));
    // A test every fourth cycle per PE: four PEs share one pipeline.
    assert_eq!(row.coproc_test_cycles, Some(gridrt_coproc::RTL_PES_PER_PIPELINE));
    assert_eq!(row.coproc_clock_mhz, Some(100.0));
    assert!(row.coproc_clock_source.as_deref().unwrap().contains("one clock domain"));
    assert!(row.coproc_cycles > 0);
    // Co-processor and soft-core cycles at the bench's 100 MHz.
    assert!((row.coproc_ms - row.coproc_cycles as f64 / 100e6 * 1e3).abs() < 1e-9, "{row:?}");
    let instructions = row.instructions.unwrap() as f64;
    assert!((row.cpu_ms - instructions * 4.1 / 100e6 * 1e3).abs() < 1e-9, "{row:?}");
}

/// The soft-core-only image runs the intersection in `fsl_io`, code the SoC's measurement
/// never ran: its rows keep the profile's CPI even when a measured per-stage CPI is given.
#[test]
fn measured_cpi_is_not_charged_to_the_soft_core_only_rows() {
    let stats = serde_json::json!({ "device_counters": {
        "stage_raygen_cycles": 2000, "stage_raygen_instret": 1000,
        "stage_traverse_cycles": 3000, "stage_traverse_instret": 1000,
        "stage_fsl_io_cycles": 5000, "stage_fsl_io_instret": 1000,
        "stage_shade_cycles": 1500, "stage_shade_instret": 1000,
        "stage_encode_cycles": 1000, "stage_encode_instret": 1000,
    }});
    let mut opt = options();
    opt.measured_cpi = Some(MeasuredCpi::from_stats_json("vexriscv-imac", "soc.json", &stats.to_string()).unwrap());
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let run = run_on_loopback(TimingProfile::GRIDRT, kernel(), &prepared, &req, "t", &mut |_| {}).unwrap();
    let cmp = compare(&run.frame.rgb, &run.frame.rgb, None, None).unwrap();
    let row = device_row(Configuration::SoftCoreOnly, Target::Riscv32imac, &run, None, &cmp, &opt);
    assert_eq!((row.cpu_source.as_deref(), row.cpi), (Some("cpi-model"), Some(4.1)));
    assert!(row.cpi_by_stage.is_none());
}

/// A `soc` run of `harts` at 50 MHz and 115 200 baud around the given frames.
fn soc_run(run: DeviceRun, rtl: DeviceRun, harts: u32) -> super::soc::SocRun {
    super::soc::SocRun {
        run,
        rtl,
        clock: SocClock { clock_mhz: 50.0, source: "target", baud: 115_200 },
        float_hw: SocFloatHw::None,
        l2_kib: None,
        harts,
        pe_cache_lines: 0,
        pes: 4,
        sim_cycles_per_s: 1e6,
        sim_reported_cycles_per_s: None,
        flash_s: 1.0,
        upload_s: 1.0,
        render_s: 50.0,
    }
}

/// The `soc` row takes every figure from the SoC's own counters at the row's clock, and the
/// modelled rows of the same run state their distance from it.
#[test]
fn the_soc_row_is_the_socs_counters_and_modelled_rows_state_their_distance_from_it() {
    use super::report::{distance_from_soc, soc_row};
    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let mut run =
        run_on_loopback(TimingProfile::RTL, Configuration::Soc.kernel(), &prepared, &req, "t", &mut |_| {}).unwrap();
    let rtl = run.clone();
    for (k, s) in Stage::ALL.iter().enumerate() {
        run.frame.stats.insert(s.instret_key(), 1000);
        run.frame.stats.insert(s.cycles_key(), 1000 * (k as u64 + 2));
    }
    run.frame.stats.insert(stat::FRAME_CYCLES, 50_000_000);
    run.frame.stats.insert(stat::LINK_CYCLES, 10_000_000);
    run.frame.stats.insert(stat::FRAME_TX_BYTES, 2304);
    let soc = soc_run(run, rtl, 1);
    let cmp = compare(&soc.run.frame.rgb, &soc.run.frame.rgb, None, None).unwrap();
    let row = soc_row(&soc, &cmp);
    assert_eq!((row.config.as_str(), row.target.as_str()), ("soc", "riscv32imac"));
    assert_eq!(row.board.cycles_source.as_deref(), Some("soc-sim"));
    assert_eq!((row.board.frame_cycles, row.board.link_cycles), (Some(50_000_000), Some(10_000_000)));
    // The line's busy time: 2 304 bytes × 10 bits at 115 200 baud.
    assert!((row.frame_ms - 1000.0).abs() < 1e-9 && (row.link_ms - 200.0).abs() < 1e-9, "{row:?}");
    // Stage cycles 2000 + 3000 + 4000 + 5000 + 6000 for 5000 instructions.
    assert!((row.cpu_ms - 20_000.0 / 50e6 * 1e3).abs() < 1e-12);
    assert!((row.cpi.unwrap() - 4.0).abs() < 1e-12);
    assert_eq!(row.cpi_by_stage.as_ref().unwrap()["traverse"], 3.0);
    assert_eq!(row.board.identical_to_rtl_sim, Some(true));
    assert_eq!((row.board.harts, row.board.pes, row.board.baud), (Some(1), Some(4), Some(115_200)));
    let json = serde_json::to_value(&row).unwrap();
    for key in ["config", "frame_cycles", "cycles_source", "clock_mhz", "clock_source", "harts", "pes", "baud"] {
        assert!(!json[key].is_null(), "{key} in {json}");
    }

    let mut modelled = row.clone();
    modelled.config = "rtl".into();
    modelled.frame_ms = 1100.0;
    modelled.board.cycles_source = Some("model".into());
    let mut rows = vec![row, modelled];
    distance_from_soc(&mut rows);
    assert_eq!(rows[0].board.vs_soc, None);
    assert!((rows[1].board.vs_soc.unwrap() - 0.1).abs() < 1e-12);
}

/// A frame shared between two harts times no stage: its row reports the frame's cycles and
/// no instruction figures (not zeros), and the modelled one-hart rows take no distance from
/// it.
#[test]
fn a_two_hart_soc_row_has_no_stage_figures_and_models_no_distance_from_it() {
    use super::report::{distance_from_soc, soc_row};
    let opt = options();
    let (prepared, req, _) = prepare(res4(), opt.width, opt.height, opt.encoding, 1.0, opt.grid_max_voxels).unwrap();
    let mut run =
        run_on_loopback(TimingProfile::RTL, Configuration::Soc.kernel(), &prepared, &req, "t", &mut |_| {}).unwrap();
    let rtl = run.clone();
    for s in Stage::ALL {
        run.frame.stats.insert(s.instret_key(), 0);
        run.frame.stats.insert(s.cycles_key(), 0);
    }
    run.frame.stats.insert(stat::FRAME_CYCLES, 30_000_000);
    // Where each hart's time went: the first traced 2 rows, the worker 4.
    for (h, rows, busy, wait) in [(0u8, 2, 9_000_000, 3_000_000), (1, 4, 27_000_000, 600_000)] {
        run.frame.stats.insert(stat::HART_ROWS_BASE + h, rows);
        run.frame.stats.insert(stat::HART_BUSY_BASE + h, busy);
        run.frame.stats.insert(stat::HART_WAIT_BASE + h, wait);
    }
    let soc = soc_run(run, rtl, 2);
    let cmp = compare(&soc.run.frame.rgb, &soc.run.frame.rgb, None, None).unwrap();
    let row = soc_row(&soc, &cmp);
    assert_eq!((row.board.harts, row.board.frame_cycles), (Some(2), Some(30_000_000)));
    let work = row.board.hart_work.as_ref().expect("per-hart counters on a two-hart frame");
    assert_eq!(
        work.iter().map(|w| (w.rows, w.busy_cycles, w.wait_cycles)).collect::<Vec<_>>(),
        [(2, 9_000_000, 3_000_000), (4, 27_000_000, 600_000)]
    );
    assert!((work[0].busy_share - 0.3).abs() < 1e-12 && (work[1].busy_share - 0.9).abs() < 1e-12);
    assert!((work[0].wait_share - 0.1).abs() < 1e-12 && (work[1].wait_share - 0.02).abs() < 1e-12);
    assert!((row.frame_ms - 600.0).abs() < 1e-9);
    assert_eq!((row.instructions_per_primary_ray, row.cpi, row.instructions), (None, None, None));
    assert!(row.cpi_by_stage.is_none() && row.instructions_per_primary_ray_by_stage.is_none());
    let mut modelled = row.clone();
    modelled.config = "rtl".into();
    modelled.board.cycles_source = Some("model".into());
    modelled.board.harts = Some(1);
    let mut rows = vec![row, modelled];
    distance_from_soc(&mut rows);
    assert_eq!(rows[1].board.vs_soc, None);
}

#[test]
fn a_scene_larger_than_the_rtls_pe_memory_gets_no_rtl_row() {
    let res3 = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes/bun_zipper_res3.obj"));
    // Eq. 6.1's own grid (18×17×14).
    let (big, ..) = bench::prepare(res3, 8, 6, PixelEncoding::Rle, 1.0, crate::grid::MAX_VOXELS).unwrap();
    let why = bench::rtl_skip_reason(&big).expect("res3's fullest PE exceeds the RTL's 16384 words");
    assert!(why.contains("16384"), "{why}");
    let (small, ..) = bench::prepare(res4(), 8, 6, PixelEncoding::Rle, 1.0, crate::grid::MAX_VOXELS).unwrap();
    assert_eq!(bench::rtl_skip_reason(&small), None, "res4 fits the RTL's 4 PEs");

    let opt = BenchOptions {
        scene: res3.into(),
        configs: vec![Configuration::Rtl],
        targets: vec![],
        grid_max_voxels: crate::grid::MAX_VOXELS,
        ..options()
    };
    let report = run_bench(&opt, &mut |_| {}).unwrap();
    assert!(report.rows.is_empty(), "no rtl row: {:?}", report.rows.iter().map(|r| &r.config).collect::<Vec<_>>());
    assert_eq!(report.skipped.len(), 1);
    assert_eq!(report.skipped[0].config, "rtl");
}
