//! The bench itself: the frame, the reference, the runs, the cross-checks and the rows.

use std::path::Path;

use gridrt_shared::msg::{stat, PixelEncoding, RenderRequest};

use super::report::{self, FrameReport};
use super::run::{self, run_native, run_on_loopback, run_on_qemu, work_differences, DeviceRun};
use super::setup::{
    kernel, BenchEvent, BenchOptions, Configuration, CoprocCycles, FrameBenchError, Image, MeasuredCpi, SocFloatHw,
    Target,
};
use super::soc;
use crate::compare::compare;
use crate::grid::GridParams;
use crate::plan::Plan;
use crate::reference::{self, Reference, Stages};
use crate::scene_image::PreparedScene;
use gridrt_firmware::device::Stage;

/// The scene prepared for the qemu-virt board's PEs, and the render request of the frame:
/// the scene's view at `width`×`height`, the stages it needs (as `gridrt render` derives
/// them), `encoding`; the grid's resolution multiplier `grid_m` (GridRT Eq. 6.1) and its most
/// voxels `max_voxels` ([`GridParams::max_voxels`]).
pub fn prepare(
    scene: &Path,
    width: u16,
    height: u16,
    encoding: PixelEncoding,
    grid_m: f64,
    max_voxels: u32,
) -> Result<(PreparedScene, RenderRequest, Plan), FrameBenchError> {
    let loaded = crate::scene::load(scene)?;
    let params = GridParams {
        m: grid_m,
        max_voxels,
        pe_count: run::QEMU_PE_COUNT,
        pe_mem_words: run::QEMU_PE_MEM_WORDS,
        ..GridParams::default()
    };
    let prepared = PreparedScene::new(loaded, &params)?;
    let plan = Plan::derive(&prepared.scene);
    let settings = prepared.scene.settings.with_size(width, height).with_shadows(plan.shadows);
    let mut req = settings.to_request(1);
    req.flags |= plan.flags();
    req.encoding = encoding;
    Ok((prepared, req, plan))
}

/// Runs every configuration × target of `opt` (`bench::frame` module docs) and assembles the
/// report.
pub fn run_bench(opt: &BenchOptions, progress: &mut dyn FnMut(BenchEvent)) -> Result<FrameReport, FrameBenchError> {
    let (prepared, req, plan) =
        prepare(&opt.scene, opt.width, opt.height, opt.encoding, opt.grid_m, opt.grid_max_voxels)?;
    // The RTL's PEs hold `SimConfig::RTL.pe_mem_words` each: a scene whose fullest PE
    // needs more gets no `rtl` row (the QEMU board's 2¹⁹ words would describe no hardware).
    let skipped = rtl_skip_reason(&prepared).filter(|_| opt.configs.contains(&Configuration::Rtl));
    let without_rtl;
    let opt = match &skipped {
        Some(why) => {
            progress(BenchEvent::Step(format!("rtl: no row: {why}")));
            without_rtl = BenchOptions {
                configs: opt.configs.iter().copied().filter(|&c| c != Configuration::Rtl).collect(),
                ..opt.clone()
            };
            &without_rtl
        }
        None => opt,
    };
    // The SoC first: on the imac, its per-stage CPI, measured, then describes the modelled
    // riscv32imac rows.
    let soc = if opt.configs.contains(&Configuration::Soc) {
        let loaded = crate::scene::load(&opt.scene)?;
        Some(soc::run_on_soc(
            &opt.repo,
            &loaded,
            &req,
            (opt.grid_m, opt.grid_max_voxels),
            opt.soc_clock(),
            (opt.soc_float_hw, opt.soc_l2_kib, opt.soc_harts, opt.soc_pe_cache_lines),
            progress,
        )?)
    } else {
        None
    };
    // A CFU build's CPI is not the imac's, and a frame on two harts times no stage: only a
    // soft-float, single-hart SoC describes the imac rows.
    let measured = soc
        .as_ref()
        .filter(|_| opt.measured_cpi.is_none() && opt.soc_float_hw == SocFloatHw::None && opt.soc_harts == 1)
        .map(|(s, _)| MeasuredCpi {
            core: "vexriscv-imac".into(),
            source: "this run's soc row".into(),
            by_stage: Stage::ALL
                .iter()
                .map(|&st| {
                    let name = crate::stats::stage_name(st).to_string();
                    (name, (s.run.stat(st.cycles_key()), s.run.stat(st.instret_key())))
                })
                .filter(|(_, (c, i))| *i > 0 && c >= i)
                .collect(),
        });
    // The default soc row (the CFU) leaves them at --cpu-profile: say so, not only in JSON.
    let modelled = opt.configs.iter().any(|&c| !matches!(c, Configuration::Soc | Configuration::HostNative));
    if soc.is_some() && measured.is_none() && opt.measured_cpi.is_none() && modelled {
        progress(BenchEvent::Step(format!(
            "soc: the modelled rows keep --cpu-profile {}: only an imac soc row on one hart \
             (--soc-float-hw none --soc-harts 1) gives them its measured CPI",
            opt.cpu.name
        )));
    }
    let with_soc_cpi;
    let opt = match measured {
        Some(m) => {
            with_soc_cpi = BenchOptions { measured_cpi: Some(m), ..opt.clone() };
            &with_soc_cpi
        }
        None => opt,
    };
    progress(BenchEvent::Step(format!(
        "{}: {} triangles, grid {:?}, {} PEs; {}×{}, plan [{}]",
        opt.scene.display(),
        prepared.grid.triangle_count,
        prepared.grid.dims,
        prepared.grid.pe_count,
        opt.width,
        opt.height,
        plan.names().join(", ")
    )));

    progress(BenchEvent::Step("f64 reference render".into()));
    let start = std::time::Instant::now();
    let settings = prepared.scene.settings.with_size(opt.width, opt.height).with_shadows(plan.shadows);
    let stages = Stages {
        shadows: plan.shadows,
        reflections: plan.reflections,
        textures: plan.textures,
        specular: plan.specular,
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(2);
    let reference =
        reference::render(&Reference::new(&prepared.scene, &prepared.grid.bounds), &settings, stages, threads);
    let reference_ms = start.elapsed().as_secs_f64() * 1e3;
    let check = |rgb: &[u8]| compare(rgb, &reference.rgb, None, None);

    // Co-processor cycles per profile, on the loopback, at the configuration's kernel.
    let mut models: Vec<(Configuration, DeviceRun)> = Vec::new();
    for &c in &opt.configs {
        if let CoprocCycles::Model(profile) = c.coproc() {
            models.push((c, run_on_loopback(profile, c.kernel(), &prepared, &req, c.name(), progress)?));
        }
    }

    // One QEMU run per firmware image the configurations need, per target.
    let mut images: Vec<Image> = Vec::new();
    for image in opt.configs.iter().filter_map(|c| c.image()) {
        if !images.contains(&image) {
            images.push(image);
        }
    }
    let mut runs: Vec<(Target, Image, DeviceRun)> = Vec::new();
    for &target in &opt.targets {
        for &image in &images {
            let label = format!("{} {}", target.name(), image.name());
            let mut args = vec!["--target", target.name(), "--jobs", "2"];
            for f in image.features() {
                args.extend_from_slice(&["--features", f]);
            }
            progress(BenchEvent::Step(format!("{label}: cargo xtask firmware {}", args.join(" "))));
            let elf = gridrt_qemu::build_firmware(&opt.repo, &["--quiet"], &args)
                .map_err(|e| FrameBenchError::Build(e.to_string()))?;
            let run = run_on_qemu(&elf, &prepared, &req, &label, progress)?;
            runs.push((target, image, run));
        }
    }
    // The same frame, the same work: every QEMU run against the loopback of its kernel
    // (GridRT's profile for the default images, the rtl profile for the RTL's), the
    // configuration's run or one for the check alone.
    let mut checks: Vec<(Configuration, DeviceRun)> = Vec::new();
    for (target, image, run) in &mut runs {
        let against = if *image == Image::CoprocRtl { Configuration::Rtl } else { Configuration::Gridrt };
        if !models.iter().chain(&checks).any(|(c, _)| *c == against) {
            let CoprocCycles::Model(profile) = against.coproc() else { continue };
            let sim = run_on_loopback(profile, against.kernel(), &prepared, &req, "check", progress)?;
            checks.push((against, sim));
        }
        if let Some((_, sim)) = models.iter().chain(&checks).find(|(c, _)| *c == against) {
            check_same_work(&format!("{} {}", target.name(), image.name()), run, sim, *image)?;
            clean_line(run, sim);
        }
    }

    let native = if opt.configs.contains(&Configuration::HostNative) {
        Some(run_native(&prepared, &req, opt.native_warmup, opt.native_runs, progress)?)
    } else {
        None
    };

    let mut rows = Vec::new();
    for &c in &opt.configs {
        match c.coproc() {
            CoprocCycles::SocSim => {
                if let Some((s, _)) = &soc {
                    rows.push(report::soc_row(s, &check(&s.run.frame.rgb)?));
                }
            }
            CoprocCycles::HostWall => {
                if let Some(n) = &native {
                    rows.push(report::native_row(n, &check(&n.frame.rgb)?));
                }
            }
            cycles => {
                for &target in &opt.targets {
                    let Some((_, _, run)) = runs.iter().find(|(t, i, _)| *t == target && Some(*i) == c.image()) else {
                        continue;
                    };
                    let model = match cycles {
                        CoprocCycles::Model(p) => models.iter().find(|(m, _)| *m == c).map(|(_, r)| (p, r)),
                        _ => None,
                    };
                    rows.push(report::device_row(c, target, run, model, &check(&run.frame.rgb)?, opt));
                }
            }
        }
    }
    report::distance_from_soc(&mut rows);
    // The loopback's upload has no resends (QEMU's slow UART makes some): the scene's wire bytes.
    let upload_bytes = models
        .first()
        .map(|m| m.1.upload_bytes)
        .or(runs.first().map(|r| r.2.upload_bytes))
        .or(soc.as_ref().map(|(s, _)| s.run.upload_bytes));
    let (kind, format) = kernel();
    Ok(FrameReport {
        scene: opt.scene.display().to_string(),
        width: opt.width,
        height: opt.height,
        clock_mhz: opt.clock_mhz,
        baud: opt.baud,
        encoding: format!("{:?}", opt.encoding).to_lowercase(),
        kernel: format!("{kind:?}").to_lowercase(),
        number_format: format!("{format:?}").to_lowercase(),
        triangles: prepared.grid.triangle_count,
        grid: prepared.grid.dims,
        grid_m: opt.grid_m,
        grid_max_voxels: opt.grid_max_voxels,
        pe_count: prepared.grid.pe_count,
        plan: plan.names().iter().map(|s| s.to_string()).collect(),
        tx_buffer_bytes: opt.tx_buffer_bytes,
        cpu_profile: opt.cpu.name.to_string(),
        cpi: opt.cpu.cpi,
        cpi_citation: opt.cpu.citation.to_string(),
        upload_bytes,
        upload_ms: upload_bytes.map(|b| b as f64 * 10.0 / opt.baud.max(1) as f64 * 1e3),
        reference_ms,
        qemu: gridrt_qemu::version(),
        skipped: skipped.map(|why| vec![report::SkippedRow { config: Configuration::Rtl.name().into(), why }]).unwrap_or_default(),
        soc_sim: soc.as_ref().map(|(s, _)| {
            let mut r = report::SocSimReport {
                sim_cycles_per_s: s.sim_cycles_per_s,
                sim_reported_cycles_per_s: s.sim_reported_cycles_per_s,
                flash_s: s.flash_s,
                upload_s: s.upload_s,
                render_s: s.render_s,
                upload_line: "unpaced: the host-to-SoC line runs faster than the baud rate in simulation; the upload is not part of the frame".into(),
                upload_wire_bytes: 0,
                upload_cycles: 0,
                upload_feed_cycles: 0,
                upload_parse_cycles: 0,
                upload_cycles_per_wire_byte: 0.0,
                upload_device_ms: 0.0,
                upload_line_ms: 0.0,
            };
            r.upload(&s.run, s.clock.clock_mhz, s.clock.baud);
            r
        }),
        rows,
    })
}

/// Why the RTL co-processor cannot hold `prepared`, if it cannot: its fullest PE image against
/// the RTL's words per PE (`SimConfig::RTL`, the build `--coproc rtl` simulates).
pub fn rtl_skip_reason(prepared: &PreparedScene) -> Option<String> {
    let words = gridrt_loopback::SimConfig::RTL.pe_mem_words;
    let fullest = prepared.grid.pe_images.iter().map(Vec::len).max().unwrap_or(0);
    (fullest as u64 > u64::from(words))
        .then(|| format!("the scene's fullest PE image is {fullest} words; the RTL's PEs hold {words} words each"))
}

/// The link bytes of `run` become those of the loopback run `sim` of the same frame (proved
/// the same work and image): QEMU's slow UART makes the session re-request regions, and
/// those resent bytes are not the frame's on a clean line.
fn clean_line(run: &mut DeviceRun, sim: &DeviceRun) {
    run.frame.bytes_tx = sim.frame.bytes_tx;
    run.frame.bytes_rx = sim.frame.bytes_rx;
    run.frame.spans_reported = sim.frame.spans_reported;
    run.tail_bytes = sim.tail_bytes;
}

/// Fails unless the QEMU run `run` of `image` did the work of the loopback run `sim` (the
/// image's kernel and profile) for the same frame: the same work counters, cycles and image;
/// a soft-core-only run sends no FSL words and runs its own tests (up to each winner), so
/// those are not compared.
fn check_same_work(label: &str, run: &DeviceRun, sim: &DeviceRun, image: Image) -> Result<(), FrameBenchError> {
    let mut diff = work_differences(run, sim);
    if image == Image::SoftCoreOnly {
        diff.retain(|(k, _, _)| !k.starts_with("fsl_words") && k != "intersection_tests");
    } else if run.stat(stat::COPROC_CYCLES) != sim.stat(stat::COPROC_CYCLES) {
        diff.push(("coproc_cycles".into(), run.stat(stat::COPROC_CYCLES), sim.stat(stat::COPROC_CYCLES)));
    }
    let images = if run.frame.rgb == sim.frame.rgb { "" } else { " (and the images differ)" };
    if diff.is_empty() && images.is_empty() {
        return Ok(());
    }
    Err(FrameBenchError::Mismatch(format!(
        "{label} on QEMU and the loopback did different work for the same frame: {diff:?}{images}"
    )))
}
