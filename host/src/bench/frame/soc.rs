//! The `soc` row: one frame on the LiteX SoC simulated cycle by cycle (`cargo xtask soc sim`:
//! VexRiscv full+cfu or imac + the RTL co-processor in Verilator), reached through its UART's
//! pty as a board is.
//!
//! The bench flashes the application through the bootloader, uploads the scene (unpaced:
//! the upload is not part of the frame) and renders one frame. The simulated UART sends the
//! SoC's bytes at `baud` in simulated time (`soc/sim_modules/serial2pty`), so the firmware
//! waits for its line as on a board. The frame's cycles are the SoC's own `mcycle`: from the
//! render request's arrival to the frame's last byte leaving the transmit FIFO
//! ([`stat::FRAME_CYCLES`]), with the per-stage counters beside them. The image is checked
//! against `--sim --coproc rtl` (the loopback simulator with the same RTL co-processor) here
//! and against the f64 reference by the caller.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gridrt_loopback::SimConfig;
use gridrt_shared::msg::{stat, RenderRequest};

use super::run::{finish, hello_upload_render, read_banner, work_differences, DeviceRun};
use super::setup::{BenchEvent, FrameBenchError, SocClock, SocFloatHw};
use crate::flash::{flash, FlashConfig, FlashEvent, FlashImage};
use crate::grid::GridParams;
use crate::scene_image::PreparedScene;
use crate::session::{Session, SessionConfig};

/// How long the simulated SoC may take for one stage (flash, upload, render): a 320×240
/// frame of a large scene is a few billion cycles, hours at the simulation's speed.
const SOC_STAGE_TIMEOUT: Duration = Duration::from_secs(4 * 3600);

/// What `cargo xtask soc sim` prints for the speed of the simulation (`serial2pty`).
const SPEED_MARKER: &str = "serial2pty: speed ";

/// One frame on the simulated SoC, and the same frame on `--sim --coproc rtl`.
#[derive(Debug, Clone)]
pub struct SocRun {
    /// The SoC's frame (its counters: `mcycle`/`minstret` per stage and the frame's).
    pub run: DeviceRun,
    /// The loopback simulator with the RTL co-processor, same grid and request.
    pub rtl: DeviceRun,
    /// The clock and line.
    pub clock: SocClock,
    /// The CPU's floating point.
    pub float_hw: SocFloatHw,
    /// The L2 cache in front of the SDRAM, KiB, when not the SoC's default.
    pub l2_kib: Option<u32>,
    /// CPUs of the SoC (workers trace rows beside the first hart).
    pub harts: u32,
    /// Lines of each PE cache (0: PE memories in block RAM).
    pub pe_cache_lines: u32,
    /// PEs of the SoC's co-processor.
    pub pes: u16,
    /// Simulated cycles per wall-clock second during the render (the frame's cycles over
    /// the host's wall time of the render).
    pub sim_cycles_per_s: f64,
    /// The simulator's own figure since it started (`serial2pty`), when it printed one.
    pub sim_reported_cycles_per_s: Option<f64>,
    /// Wall seconds of the flash, the upload and the render.
    pub flash_s: f64,
    /// Scene upload.
    pub upload_s: f64,
    /// Render.
    pub render_s: f64,
}

/// `cargo xtask soc sim`, its UART on a pty; stopped on drop.
struct SocSim {
    child: Child,
    pty: String,
    speed: Arc<Mutex<Option<f64>>>,
}

impl SocSim {
    fn start(
        repo: &Path,
        clock: SocClock,
        (float_hw, l2_kib, harts, pe_cache_lines): (SocFloatHw, Option<u32>, u32, u32),
        progress: &mut dyn FnMut(BenchEvent),
    ) -> Result<Self, FrameBenchError> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(repo).args(["run", "--quiet", "--package", "xtask", "--", "soc", "sim"]);
        cmd.args(["--baud", &clock.baud.to_string(), "--clock-mhz", &format!("{}", clock.clock_mhz)]);
        cmd.args(["--timeout-s", &(4 * SOC_STAGE_TIMEOUT.as_secs()).to_string()]);
        cmd.args(["--float-hw", float_hw.name()]);
        if let Some(k) = l2_kib {
            cmd.args(["--l2-kib", &k.to_string()]);
        }
        cmd.args(["--harts", &harts.to_string(), "--pe-cache-lines", &pe_cache_lines.to_string()]);
        let l2 = l2_kib.map(|k| format!(" --l2-kib {k}")).unwrap_or_default();
        progress(BenchEvent::Step(format!(
            "soc: cargo xtask soc sim --baud {} --clock-mhz {} --float-hw {}{l2} --harts {harts} --pe-cache-lines {pe_cache_lines} (builds the Verilated SoC the first time: minutes)",
            clock.baud,
            clock.clock_mhz,
            float_hw.name()
        )));
        // `cargo run` exec()s xtask, which stops its simulator when it ends: both end with this
        // process even when it is killed.
        gridrt_qemu::end_with_parent(&mut cmd);
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| FrameBenchError::Device(format!("soc: cannot run cargo xtask soc sim: {e}")))?;
        let (tx, rx) = mpsc::channel::<Result<String, String>>();
        let speed = Arc::new(Mutex::new(None));
        if let Some(out) = child.stdout.take() {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(out).lines().map_while(Result::ok) {
                    if let Some(p) = line.strip_prefix("serial: ") {
                        let _ = tx.send(Ok(p.trim().to_string()));
                    }
                }
            });
        }
        if let Some(err) = child.stderr.take() {
            let (tx, speed) = (tx.clone(), speed.clone());
            std::thread::spawn(move || {
                let mut tail: Vec<String> = Vec::new();
                for line in BufReader::new(err).lines().map_while(Result::ok) {
                    if let Some(rate) = line.split(SPEED_MARKER).nth(1).and_then(parse_speed_since_start) {
                        *speed.lock().unwrap_or_else(|e| e.into_inner()) = Some(rate);
                    }
                    tail.push(line);
                    if tail.len() > 20 {
                        tail.remove(0);
                    }
                }
                let _ = tx.send(Err(tail.join("\n")));
            });
        }
        // A fresh machine builds the firmware and the Verilated SoC first.
        let outcome = rx.recv_timeout(Duration::from_secs(3600));
        let failed = match outcome {
            Ok(Ok(pty)) => return Ok(Self { child, pty, speed }),
            Ok(Err(tail)) => format!("soc: cargo xtask soc sim stopped before it printed its pty:\n{tail}"),
            Err(_) => "soc: cargo xtask soc sim printed no pty within an hour".to_string(),
        };
        let _ = child.kill();
        let _ = child.wait();
        Err(FrameBenchError::Device(failed))
    }

    fn reported_speed(&self) -> Option<f64> {
        *self.speed.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The simulated line's rate in wall-clock time (baud × simulated cycles per second ÷
    /// clock), halved for margin, at least 10 baud: what the host's waits must expect. Waits
    /// up to 30 s for the simulator's first speed report.
    fn wall_clock_line(&self, clock: SocClock) -> u32 {
        let deadline = Instant::now() + Duration::from_secs(30);
        while self.reported_speed().is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(200));
        }
        let speed = self.reported_speed().unwrap_or(50_000.0);
        let baud = f64::from(clock.baud) * speed / (clock.clock_mhz * 1e6) / 2.0;
        (baud as u32).clamp(10, clock.baud)
    }
}

impl Drop for SocSim {
    fn drop(&mut self) {
        // `cargo run` exec()s xtask; the simulator dies with it (PR_SET_PDEATHSIG).
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The rate after "since start" in `… cycles/s (running; 812345 cycles/s since start)`.
fn parse_speed_since_start(rest: &str) -> Option<f64> {
    let (_, after) = rest.split_once("; ")?;
    after.split_whitespace().next()?.parse().ok()
}

/// Runs the `soc` row's frame: the scene `loaded` prepared for the SoC's co-processor (its
/// PEs and memory from its `Hello`), `request` its render request (size, flags, encoding),
/// and the same on `--sim --coproc rtl`.
pub fn run_on_soc(
    repo: &Path,
    loaded: &crate::scene::Scene,
    request: &RenderRequest,
    (grid_m, max_voxels): (f64, u32),
    clock: SocClock,
    (float_hw, l2_kib, harts, pe_cache_lines): (SocFloatHw, Option<u32>, u32, u32),
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<(SocRun, PreparedScene), FrameBenchError> {
    let mut args = vec!["--board", "litex", "--bin", "app", "--layout", "bootloaded", "--jobs", "2"];
    args.extend(["--target", float_hw.target()]);
    if float_hw == SocFloatHw::Cfu {
        args.extend(["--features", "cfu-float"]);
    }
    progress(BenchEvent::Step(format!("soc: cargo xtask firmware {}", args.join(" "))));
    let app =
        gridrt_qemu::build_firmware(repo, &["--quiet"], &args).map_err(|e| FrameBenchError::Build(e.to_string()))?;
    let elf = std::fs::read(&app).map_err(|e| FrameBenchError::Build(format!("{}: {e}", app.display())))?;
    let image = FlashImage::from_elf(&elf).map_err(|e| FrameBenchError::Build(format!("{}: {e}", app.display())))?;

    let sim = SocSim::start(repo, clock, (float_hw, l2_kib, harts, pe_cache_lines), progress)?;
    let open = || crate::serial::open(&sim.pty, 115_200, crate::serial::DEFAULT_READ_TIMEOUT);

    let t = Instant::now();
    let mut port = open()?;
    // The bootloader's text first: then its line is idle and a `Hello` is answered at once.
    let banner = read_banner(&mut port, SOC_STAGE_TIMEOUT)
        .map_err(|what| FrameBenchError::Device(format!("soc: the bootloader: {what}")))?;
    progress(BenchEvent::Step(format!(
        "soc: bootloader up after {:.0} s: {}",
        t.elapsed().as_secs_f64(),
        banner.trim()
    )));
    let line = sim.wall_clock_line(clock);
    progress(BenchEvent::Step(format!(
        "soc: the simulated line's {} baud run at about {line} baud of wall-clock time here: the host's waits follow that",
        clock.baud
    )));
    let session_cfg = |cfg: SessionConfig| cfg.baud(line).hello_timeout(SOC_STAGE_TIMEOUT).max_probes(1000);

    let t = Instant::now();
    progress(BenchEvent::Step(format!("soc: flashing {} B through the bootloader", image.data.len())));
    {
        let mut last = Instant::now();
        let mut on = |e: FlashEvent| {
            if let FlashEvent::Written { bytes, total } = e {
                if last.elapsed() >= Duration::from_secs(5) {
                    last = Instant::now();
                    progress(BenchEvent::Step(format!("soc: flashed {bytes} of {total} B")));
                }
            }
        };
        let mut cfg = FlashConfig::new(sim.pty.clone());
        cfg.session = session_cfg(cfg.session);
        flash(&mut port, &image, &cfg, &mut on)
            .map_err(|e| FrameBenchError::Device(format!("soc: flashing the application: {e}")))?;
    }
    drop(port);
    let flash_s = t.elapsed().as_secs_f64();

    // One `RenderRequest` for the whole frame: its `Stats` are that frame's (a region
    // re-requested while the slow simulation still renders would be rendered again and
    // report its own counters).
    let cfg = session_cfg(SessionConfig::new(sim.pty.clone())).render_timeout(SOC_STAGE_TIMEOUT).regions(false);
    let mut session = Session::new(open()?, cfg);
    let info = session.hello(&mut |_| {})?;
    // The same co-processor in the loopback simulator: with PE caches, PE memories of the
    // size the SoC reports behind caches of the same lines.
    let rtl = if pe_cache_lines != 0 {
        SimConfig { pe_mem_words: info.pe_mem_words, pe_cache_lines, ..SimConfig::RTL }
    } else {
        SimConfig::RTL
    };
    if (info.pe_count, info.pe_mem_words) != (rtl.pe_count, rtl.pe_mem_words) {
        return Err(FrameBenchError::Device(format!(
            "soc: the SoC's co-processor has {} PEs of {} words; `--sim --coproc rtl` has {} of {}: not the same frame",
            info.pe_count, info.pe_mem_words, rtl.pe_count, rtl.pe_mem_words
        )));
    }
    let params = GridParams {
        m: grid_m,
        max_voxels,
        pe_count: info.pe_count,
        pe_mem_words: info.pe_mem_words,
        ..GridParams::default()
    };
    let prepared = PreparedScene::new(loaded.clone(), &params)?;
    // Refused here, before minutes of simulated upload, as `gridrt render` refuses it.
    let voxels = prepared.grid.voxel_count();
    if voxels > info.voxel_capacity {
        let d = prepared.grid.dims;
        return Err(FrameBenchError::Device(format!(
            "soc: grid {}×{}×{} = {voxels} voxels exceeds the SoC firmware's capacity of {} voxels; use a smaller --grid-m",
            d[0], d[1], d[2], info.voxel_capacity
        )));
    }
    let mut req = prepared.scene.settings.with_size(request.width, request.height).to_request(request.frame);
    req.flags = request.flags;
    req.encoding = request.encoding;

    let t = Instant::now();
    let pes = (info.pe_count, info.pe_mem_words);
    let (frame, upload_bytes, render_ms) = hello_upload_render(&mut session, &prepared, &req, "soc", pes, progress)?;
    let upload_s = t.elapsed().as_secs_f64() - render_ms / 1e3;
    let reported = sim.reported_speed();
    drop(session);
    drop(sim);
    let run = finish(frame, upload_bytes, render_ms, String::new());
    let frame_cycles = run.stat(stat::FRAME_CYCLES);
    if frame_cycles == 0 {
        return Err(FrameBenchError::Device(
            "soc: the SoC reported no frame cycles (a firmware without the frame counter?)".into(),
        ));
    }

    progress(BenchEvent::Step("soc: the same frame on --sim --coproc rtl".into()));
    gridrt_loopback::prepare(&rtl).map_err(|e| FrameBenchError::Device(format!("the RTL co-processor: {e}")))?;
    let rtl_run = super::run::run_on_loopback_with(rtl, &prepared, &req, "rtl-sim", progress)?;
    let diff = work_differences(&run, &rtl_run);
    if !diff.is_empty() || run.stat(stat::COPROC_CYCLES) != rtl_run.stat(stat::COPROC_CYCLES) {
        return Err(FrameBenchError::Mismatch(format!(
            "soc and --sim --coproc rtl did different work for the same frame: {diff:?}, co-processor cycles {} vs {}",
            run.stat(stat::COPROC_CYCLES),
            rtl_run.stat(stat::COPROC_CYCLES)
        )));
    }
    let render_s = render_ms / 1e3;
    Ok((
        SocRun {
            sim_cycles_per_s: if render_s > 0.0 { frame_cycles as f64 / render_s } else { 0.0 },
            sim_reported_cycles_per_s: reported,
            run,
            rtl: rtl_run,
            clock,
            float_hw,
            l2_kib,
            harts,
            pe_cache_lines,
            pes: info.pe_count,
            flash_s,
            upload_s,
            render_s,
        },
        prepared,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speed_line_gives_the_rate_since_start() {
        let line =
            "sim: serial2pty: speed 10485760 cycles in 10.0 s: 1048576 cycles/s (running; 998123 cycles/s since start)";
        let rest = line.split(SPEED_MARKER).nth(1).unwrap();
        assert_eq!(parse_speed_since_start(rest), Some(998_123.0));
        assert_eq!(parse_speed_since_start("garbage"), None);
    }

    #[test]
    fn routed_clock_comes_from_the_build_report_and_is_capped_at_the_target() {
        let c = SocClock::from_build_report(r#"{"fmax_mhz": 49.16, "target_mhz": 50}"#, 115_200).unwrap();
        assert_eq!((c.clock_mhz, c.source, c.baud), (49.16, "routed", 115_200));
        let fast = SocClock::from_build_report(r#"{"fmax_mhz": 64.1, "target_mhz": 50}"#, 115_200).unwrap();
        assert_eq!(fast.clock_mhz, 50.0);
        assert!(SocClock::from_build_report(r#"{"fmax_mhz": null}"#, 115_200).is_err());
        assert!(SocClock::from_build_report("not json", 115_200).is_err());
    }
}
