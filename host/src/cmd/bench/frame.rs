//! `gridrt bench frame`: the whole-frame time on the modelled board, per configuration ×
//! soft-core target (model and measurements: [`gridrt_host::bench::frame`]).
//!
//! Builds the firmware images with `cargo xtask firmware` (run it from the repository),
//! boots each on QEMU, renders the frame over its UART, renders it on the loopback simulator
//! per co-processor profile and natively, checks every image against the f64 reference, and
//! writes the rows as JSON (`--json`) and, with `--out-dir DIR`, `frame.csv` and `frame.svg`.

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};
use gridrt_host::bench::frame::{
    run_bench, write_csv, write_svg, BenchEvent, BenchOptions, Configuration, CpuProfile, FrameReport, MeasuredCpi,
    SocFloatHw, Target,
};
use gridrt_host::session::ProgressEvent;

use crate::cmd::render::Encoding;

/// The SoC's target clock (`soc/gridrt_soc/soc.py` `SYS_CLK_FREQ`).
const SOC_TARGET_MHZ: f64 = 50.0;

/// Arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (.obj, .ply, or a .toml scene file).
    #[arg(long, value_name = "PATH")]
    scene: PathBuf,
    /// Frame width.
    #[arg(long, default_value_t = 320)]
    width: u16,
    /// Frame height.
    #[arg(long, default_value_t = 240)]
    height: u16,
    /// Clock of the soft-core and the co-processor (one clock domain, as in the SoC), MHz,
    /// for every row. Default: the routed clock of --soc-build, else the SoC's 50 MHz target.
    #[arg(long, value_name = "MHZ")]
    clock_mhz: Option<f64>,
    /// A `cargo xtask soc build --json` report of the SoC as built: its routed clock (capped
    /// at its target) becomes the clock of every row (`clock_source` "routed").
    #[arg(long, value_name = "REPORT.json")]
    soc_build: Option<PathBuf>,
    /// Line rate of the UART (8N1): the SoC's (the `soc` row's simulated line runs at it).
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Pixel encoding of the answer.
    #[arg(long, value_enum, default_value_t = Encoding::Rle)]
    encoding: Encoding,
    /// The grid's resolution, for every row.
    #[command(flatten)]
    grid: crate::cmd::common::GridResolution,
    /// The `soc` row's CPU: cfu (default: VexRiscv full+cfu with the f32 CFU, the firmware
    /// for riscv32im) or none (VexRiscv imac, f32 in soft float: the smaller CPU, for small
    /// boards). cfu is the default because it measured 12.5 % fewer frame cycles than none on
    /// 1 hart and 3.5 % on 4 (docs/bench-frame.md, "Where the harts' time goes"). Only none's
    /// soc row calibrates the modelled riscv32imac rows (their CPU is the imac).
    #[arg(long, value_enum, default_value_t = SocFloat::Cfu)]
    soc_float_hw: SocFloat,
    /// The `soc` row's L2 cache in front of the SDRAM that holds main RAM, KiB (a power of
    /// two; default: the SoC's, 8).
    #[arg(long, value_name = "KIB", value_parser = clap::value_parser!(u32).range(1..=256))]
    soc_l2_kib: Option<u32>,
    /// The `soc` row's CPUs, 1 to 4 (worker VexRiscvs trace rows beside the first; such a
    /// frame reports no per-stage counters and does not calibrate the modelled rows).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4))]
    soc_harts: u32,
    /// The `soc` row's PE memories: each PE's 2²⁰ words in the SDRAM behind a cache of this
    /// many 8-word lines (a power of two, 4..=4096; default 512, the SoC's: `cargo xtask soc
    /// sim --pe-cache-lines`, rtl/README.md section 4.6), so that scenes beyond block RAM load; 0:
    /// block RAM, 16 384 words per PE. `--sim --coproc rtl`, which the row is checked
    /// against, uses the same.
    #[arg(long, value_name = "LINES", default_value_t = 512, value_parser = crate::cmd::common::pe_cache_lines)]
    soc_pe_cache_lines: u32,
    /// Write the report here (JSON).
    #[arg(long, value_name = "JSON")]
    json: PathBuf,
    /// Also write frame.csv and frame.svg (stacked bars) into this folder.
    #[arg(long = "out-dir", alias = "out", value_name = "DIR")]
    out: Option<PathBuf>,
    /// Configurations, in report order: soft-core-only, gridrt, pipelined, rtl, host-native,
    /// and soc (the LiteX SoC simulated cycle by cycle in Verilator, measured by its own
    /// counters: a 320×240 frame takes 10–40 minutes here; not in the default list). A scene
    /// whose fullest PE exceeds the RTL's 16384 words per PE gets no rtl row, and says why.
    #[arg(long, value_delimiter = ',', default_value = "soft-core-only,gridrt,pipelined,rtl,host-native")]
    configs: Vec<String>,
    /// Soft-core targets: riscv32imac, riscv32imafc.
    #[arg(long, value_delimiter = ',', default_value = "riscv32imac,riscv32imafc")]
    targets: Vec<String>,
    /// Soft-core profile of the modelled rows: vexriscv-imac (the imac SoC's CPU, CPI measured
    /// on the simulated SoC; with a soc row of `--soc-float-hw none`, each stage's CPI from
    /// that run), picorv32 (CPI 4.1, documented) or cpi1 (one instruction per cycle).
    #[arg(long, default_value = "vexriscv-imac", value_name = "NAME")]
    cpu_profile: String,
    /// Per-stage CPI measured on a soft-core: the `--stats` JSON of `gridrt render --port` on
    /// the LiteX SoC with the imac (`cargo xtask soc sim --float-hw none`; the CFU's CPI is
    /// another CPU's). The riscv32imac rows then charge each stage's instructions at its
    /// measured CPI (`cpu_source` "rtl"); the riscv32imafc rows keep --cpu-profile (that core
    /// has no FPU).
    #[arg(long, value_name = "STATS.json")]
    cpu_measured: Option<PathBuf>,
    /// Bytes the board's UART holds while the line drains them (16: the NS16550A / UART Lite
    /// FIFO the firmware fills by polling).
    #[arg(long, default_value_t = 16, value_name = "BYTES")]
    tx_buffer: u64,
    /// host-native: untimed frames before the timed ones.
    #[arg(long, default_value_t = 1)]
    native_warmup: u32,
    /// host-native: timed frames (the best is reported).
    #[arg(long, default_value_t = 3)]
    native_runs: u32,
    /// The gridrt repository (builds the firmware images with `cargo xtask firmware`).
    #[arg(long, default_value = ".", value_name = "DIR")]
    repo: PathBuf,
}

/// `--soc-float-hw`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SocFloat {
    None,
    Cfu,
}

/// Prints steps as they start and, at most every 5 s, how far an upload or render is; a
/// ticker thread says what is still running when nothing was printed for 10 s (a render on
/// QEMU reports its rows only at the end), so a long run is never silent, with or without a
/// terminal.
struct Reporter {
    started: Instant,
    last: Instant,
    /// What runs now.
    current: String,
    done: bool,
}

impl Reporter {
    fn say(&mut self, line: &str) {
        eprintln!("[{:6.1} s] {line}", self.started.elapsed().as_secs_f64());
        self.last = Instant::now();
    }

    fn handle(&mut self, e: BenchEvent) {
        match e {
            BenchEvent::Step(s) => {
                self.current = s.clone();
                self.say(&s);
            }
            BenchEvent::Session { run, event } => {
                let line = match event {
                    ProgressEvent::UploadStarted { total } => Some(format!("{run}: uploading {total} B")),
                    ProgressEvent::RenderStarted { width, height } => {
                        Some(format!("{run}: rendering {width}×{height}"))
                    }
                    ProgressEvent::Uploaded { bytes, total } if self.last.elapsed() >= Duration::from_secs(5) => {
                        Some(format!("{run}: uploaded {bytes} of {total} B"))
                    }
                    ProgressEvent::RowReceived { rows_done, .. } if self.last.elapsed() >= Duration::from_secs(5) => {
                        Some(format!("{run}: {rows_done} rows received"))
                    }
                    ProgressEvent::Resend { region } => Some(format!("{run}: re-requesting {region:?}")),
                    ProgressEvent::DeviceReset => Some(format!("{run}: device reset")),
                    _ => None,
                };
                if let Some(l) = line {
                    self.current = l.clone();
                    self.say(&l);
                }
            }
        }
    }

    /// Runs on its own thread until `done`: a line when nothing was said for 10 s.
    fn tick(shared: &Mutex<Reporter>) {
        loop {
            std::thread::sleep(Duration::from_secs(1));
            let mut r = shared.lock().unwrap_or_else(|e| e.into_inner());
            if r.done {
                return;
            }
            if r.last.elapsed() >= Duration::from_secs(10) {
                let line = format!("{} (still running)", r.current);
                r.say(&line);
            }
        }
    }
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        let configs = self
            .configs
            .iter()
            .map(|c| {
                Configuration::parse(c).ok_or_else(|| {
                    let known: Vec<_> = Configuration::ALL.iter().map(|c| c.name()).collect();
                    anyhow!("unknown configuration `{c}` (known: {})", known.join(", "))
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let targets = self
            .targets
            .iter()
            .map(|t| Target::parse(t).ok_or_else(|| anyhow!("unknown target `{t}` (known: riscv32imac, riscv32imafc)")))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let cpu = CpuProfile::parse(&self.cpu_profile).ok_or_else(|| {
            let known: Vec<_> = CpuProfile::ALL.iter().map(|p| p.name).collect();
            anyhow!("unknown soft-core profile `{}` (known: {})", self.cpu_profile, known.join(", "))
        })?;
        let measured_cpi = match &self.cpu_measured {
            Some(path) => {
                let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
                Some(
                    MeasuredCpi::from_stats_json("vexriscv-imac", &path.display().to_string(), &text)
                        .map_err(|e| anyhow!(e))?,
                )
            }
            None => None,
        };
        let (clock_mhz, clock_source) = match (&self.soc_build, self.clock_mhz) {
            (Some(_), Some(_)) => bail!("--clock-mhz and --soc-build both set the clock: give one"),
            (Some(path), None) => {
                let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
                let c = gridrt_host::bench::frame::SocClock::from_build_report(&text, self.baud)
                    .map_err(|e| anyhow!("{}: {e}", path.display()))?;
                (c.clock_mhz, c.source)
            }
            (None, Some(mhz)) => (mhz, "option"),
            (None, None) => (SOC_TARGET_MHZ, "target"),
        };
        if !(clock_mhz > 0.0 && clock_mhz.is_finite()) || self.baud == 0 {
            bail!("--clock-mhz and --baud must be positive");
        }
        if configs.iter().any(|c| c.on_soft_core()) && !self.repo.join("firmware/image/Cargo.toml").is_file() {
            bail!(
                "{} is not the gridrt repository: the soft-core configurations build their firmware with \
                 `cargo xtask firmware` (run from the repository, or give --repo DIR)",
                self.repo.display()
            );
        }
        for path in std::iter::once(self.json.parent()).flatten().chain(self.out.as_deref()) {
            if !path.as_os_str().is_empty() {
                std::fs::create_dir_all(path).with_context(|| format!("creating {}", path.display()))?;
            }
        }
        let opt = BenchOptions {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            clock_mhz,
            clock_source,
            baud: self.baud,
            encoding: self.encoding.into(),
            grid_m: self.grid.grid_m,
            grid_max_voxels: self.grid.grid_max_voxels,
            soc_l2_kib: self.soc_l2_kib,
            soc_harts: self.soc_harts,
            soc_pe_cache_lines: self.soc_pe_cache_lines,
            soc_float_hw: match self.soc_float_hw {
                SocFloat::None => SocFloatHw::None,
                SocFloat::Cfu => SocFloatHw::Cfu,
            },
            tx_buffer_bytes: self.tx_buffer,
            cpu,
            measured_cpi,
            configs,
            targets,
            native_warmup: self.native_warmup,
            native_runs: self.native_runs,
            repo: self.repo.clone(),
        };
        let reporter =
            Mutex::new(Reporter { started: Instant::now(), last: Instant::now(), current: String::new(), done: false });
        let lock = || reporter.lock().unwrap_or_else(|e| e.into_inner());
        // The bench runs on this thread: QEMU dies with the thread that booted it.
        let report = std::thread::scope(|s| {
            s.spawn(|| Reporter::tick(&reporter));
            let r = run_bench(&opt, &mut |e| lock().handle(e));
            lock().done = true;
            r
        })?;
        std::fs::write(&self.json, serde_json::to_string_pretty(&report)? + "\n")
            .with_context(|| format!("writing {}", self.json.display()))?;
        if let Some(dir) = &self.out {
            write_csv(&dir.join("frame.csv"), &report)
                .with_context(|| format!("writing {}/frame.csv", dir.display()))?;
            write_svg(&dir.join("frame.svg"), &report)
                .map_err(|e| anyhow!("writing {}/frame.svg: {e}", dir.display()))?;
        }
        print_table(&report);
        let mut wrote = vec![self.json.display().to_string()];
        if let Some(dir) = &self.out {
            wrote.push(format!("{}/{{frame.csv, frame.svg}}", dir.display()));
        }
        println!("wrote {}", wrote.join(", "));
        Ok(())
    }
}

fn print_table(r: &FrameReport) {
    println!(
        "{} {}×{}, {} MHz, {} baud, {}, {} (CPI {}), upload {} B = {:.0} ms (not in the frame)",
        r.scene,
        r.width,
        r.height,
        r.clock_mhz,
        r.baud,
        r.encoding,
        r.cpu_profile,
        r.cpi,
        r.upload_bytes.unwrap_or(0),
        r.upload_ms.unwrap_or(0.0)
    );
    if let Some(s) = &r.soc_sim {
        println!(
            "soc simulation: {:.0} cycles/s during the render (simulator's own figure: {}); flash {:.0} s, upload {:.0} s, render {:.0} s",
            s.sim_cycles_per_s,
            s.sim_reported_cycles_per_s.map_or_else(|| "none".into(), |v| format!("{v:.0} cycles/s")),
            s.flash_s,
            s.upload_s,
            s.render_s
        );
        if s.upload_cycles > 0 {
            println!(
                "soc upload (measured cycles): {} wire B in {} cycles, {:.1} cycles/B ({:.1} % in input handling, {:.1} % in the scene parser and loader): {:.0} ms at the clock; the line at the baud rate {:.0} ms (modelled)",
                s.upload_wire_bytes,
                s.upload_cycles,
                s.upload_cycles_per_wire_byte,
                100.0 * s.upload_feed_cycles as f64 / s.upload_cycles as f64,
                100.0 * s.upload_parse_cycles as f64 / s.upload_cycles as f64,
                s.upload_device_ms,
                s.upload_line_ms
            );
        }
    }
    println!(
        "{:<15} {:<13} {:>10} {:>10} {:>10} {:>9} {:>10} {:>8}  {:<9} {:>7}  {:<10}",
        "config",
        "target",
        "instr/ray",
        "cpu ms",
        "coproc ms",
        "link ms",
        "frame ms",
        "fps",
        "cycles",
        "vs soc",
        "image"
    );
    for row in &r.rows {
        let image = if row.identical {
            "identical".to_string()
        } else {
            row.psnr_db.map_or_else(|| "?".into(), |p| format!("{p:.1} dB"))
        };
        println!(
            "{:<15} {:<13} {:>10} {:>10.1} {:>10.1} {:>9.1} {:>10.1} {:>8.2}  {:<9} {:>7}  {image}",
            row.config,
            row.target,
            row.instructions_per_primary_ray.map_or_else(|| "-".into(), |v| format!("{v:.0}")),
            row.cpu_ms,
            row.coproc_ms,
            row.link_ms,
            row.frame_ms,
            row.fps,
            row.board.cycles_source.as_deref().unwrap_or("wall"),
            row.board.vs_soc.map_or_else(|| "-".into(), |v| format!("{:+.1}%", v * 100.0)),
        );
    }
    for row in &r.rows {
        for (h, w) in row.board.hart_work.iter().flatten().enumerate() {
            println!(
                "{:<15} hart {h}: {} rows, busy {:.1} % of the frame, waited {:.1} %",
                row.config,
                w.rows,
                w.busy_share * 100.0,
                w.wait_share * 100.0
            );
        }
    }
    for s in &r.skipped {
        println!("{:<15} no row: {}", s.config, s.why);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    #[test]
    fn the_soc_row_runs_the_cfu_unless_told_none() {
        let parse = |more: &[&str]| {
            let base = ["frame", "--scene", "a.obj", "--json", "f.json"];
            Cli::try_parse_from(base.iter().chain(more)).unwrap().args
        };
        assert_eq!(parse(&[]).soc_float_hw, SocFloat::Cfu);
        assert_eq!(parse(&["--soc-float-hw", "none"]).soc_float_hw, SocFloat::None);
        assert_eq!(parse(&[]).soc_harts, 1);
        assert_eq!(parse(&[]).soc_pe_cache_lines, 512);
        assert_eq!(parse(&["--soc-pe-cache-lines", "0"]).soc_pe_cache_lines, 0);
        assert!(Cli::try_parse_from(["frame", "--scene", "a.obj", "--json", "f.json", "--soc-pe-cache-lines", "3"])
            .is_err());
    }
}
