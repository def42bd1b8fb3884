//! End to end on the LiteX SoC: the firmware on a VexRiscv soft-core with the RTL
//! co-processor, simulated cycle by cycle in Verilator (`cargo xtask soc sim`), reached only
//! through its UART's pseudo-terminal with the `gridrt` CLI, as a user would reach a board.
//!
//! `soc_sim_flashes_through_the_bootloader_and_renders_like_the_rtl_cosim`, one test because
//! the simulation is slow, on the default SoC (VexRiscv full+cfu with the f32 CFU; its
//! Verilator build is cached under target/soc/sim-cfu/) and a board's line (the host's bytes
//! paced at 3 Mbaud, a byte that arrives at a full receive FIFO lost: `cargo xtask soc sim
//! --rx-baud 3000000 --rx-overrun`):
//! - the bootloader in ROM refuses an image corrupted on the way (`BadCrc`) and one larger
//!   than main RAM (`TooLarge`) and keeps serving;
//! - `gridrt flash` writes the app built for `--board litex --target riscv32im --features
//!   cfu-float`, verifies and starts it, and resends no chunk: the bootloader and the app
//!   take one data frame at a time (their window), so no byte of the image or the scene is
//!   lost;
//! - `gridrt render --port` of a 32×24 bun_zipper_res4 frame is byte-identical to
//!   `gridrt render --sim --coproc rtl` with the same co-processor (the default SoC keeps
//!   each PE's 2²⁰ words in SDRAM behind 512-line caches; the co-processor RTL is the same
//!   in both; the soft-core runs the same firmware as the loopback simulator, whose f32 is
//!   Rust's: so every sum and product the CFU answered was the operator's, as a wrong answer
//!   changes the walk and the shading, so the image), and to `--coproc model` at the RTL's
//!   kernel and format (watertight, fixed64-q23); its upload resent no chunk;
//! - the device's per-stage `mcycle`/`minstret` are in the stats JSON: measured cycles per
//!   instruction of a real soft-core, printed per stage.
//!
//! Two harts have their own test, `soc_with_two_harts_renders_like_the_rtl_cosim`. Three
//! more run only with `GRIDRT_SOC_SIM_LONG=1` as well (each takes 11 minutes to an hour of
//! simulation: not in CI): the imac SoC (`--float-hw none`),
//! `soc_with_the_imac_renders_like_the_rtl_cosim`, and scenes beyond block RAM, bun_zipper_res3
//! (`soc_renders_a_scene_beyond_block_ram_like_the_rtl_cosim`) and stanford-bunny
//! (`soc_renders_stanford_bunny_like_the_rtl_cosim`).
//!
//! It runs only with `GRIDRT_SOC_SIM=1` (it takes minutes: see BENCHMARKS.md, "The LiteX
//! SoC"); `.ci/run` sets it. Then missing Verilator or LiteX fails the test;
//! `GRIDRT_SKIP_TOOLS=verilator,litex` skips it and says so in the test output
//! ([`gridrt_e2e::tools`]).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use gridrt_e2e::tools::{require, soc_sim_long_opted_in, soc_sim_opted_in, Tool};
use gridrt_host::compare::compare;
use gridrt_host::flash::{flash, FlashConfig, FlashError, FlashImage};
use gridrt_host::serial;
use gridrt_shared::msg;

/// Frame of the comparison (the smallest).
const WIDTH: &str = "32";
const HEIGHT: &str = "24";

/// One simulation at a time: they share the Verilated SoC's build folder, and the machine.
static ONE_SOC: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Every SoC test's start: `None` (the test returns at once; each check says why on standard
/// error) without `GRIDRT_SOC_SIM=1`, with `long` also without `GRIDRT_SOC_SIM_LONG=1`, or
/// without Verilator and LiteX; else the lock that runs one simulation at a time. The opt-ins
/// come before the tools, so that a skipped test reports no tool it did not use.
fn soc_test(test: &str, long: bool) -> Option<std::sync::MutexGuard<'static, ()>> {
    let run = soc_sim_opted_in(test)
        && (!long || soc_sim_long_opted_in(test))
        && require(test, Tool::Verilator)
        && require(test, Tool::Litex);
    run.then(|| ONE_SOC.lock().unwrap_or_else(|e| e.into_inner()))
}

/// The host's waits in the flash test, as for a line of this many baud (wall time): the
/// simulation runs the board's 3 Mbaud about 10⁴ times slower, and an expired wait resends a
/// chunk. The host does not pace its writes by `--baud`: only its waits grow.
const SLOW_LINE_BAUD: &str = "3000";

/// Seconds of wall time the started app has to answer Hello (`gridrt flash --boot-wait`): the
/// simulated app's start took about 13 s here (docs/bench-upload.md), close to the default 15
/// even before a loaded machine slows the simulation.
const SIM_BOOT_WAIT_S: &str = "600";

/// Seconds the simulation may run in all (flash, upload and render of the small frame).
const SIM_TIMEOUT_S: u32 = 2400;

/// The app for the default SoC's CPU (`cargo xtask soc sim` without `--float-hw`: VexRiscv
/// full+cfu, RV32IM without compressed instructions, the f32 CFU).
const DEFAULT_SOC_APP: [&str; 10] =
    ["--board", "litex", "--target", "riscv32im", "--features", "cfu-float", "--bin", "app", "--layout", "bootloaded"];

/// `cargo xtask firmware ARGS`; the ELF path it prints.
use gridrt_e2e::builds::{cargo, check, gridrt, repo_root, run_gridrt};

fn build_firmware(args: &[&str]) -> PathBuf {
    let out = cargo("run").args(["--package", "xtask", "--", "firmware", "--jobs", "2"]).args(args).output().unwrap();
    let stdout = check(out, &format!("cargo xtask firmware {}", args.join(" ")));
    PathBuf::from(stdout.lines().find_map(|l| l.strip_prefix("ELF: ")).expect("xtask prints the ELF path").trim())
}

/// The SoC simulation started by `cargo xtask soc sim`, its UART on a pty.
struct SocSim {
    child: Child,
    pty: String,
    /// The simulator's last count of host bytes lost at a full receive FIFO (`--rx-overrun`).
    lost: std::sync::Arc<std::sync::Mutex<Option<u64>>>,
}

/// What `serial2pty` prints with each speed report under `--rx-overrun`.
const OVERRUN_MARKER: &str = "serial2pty: overrun: ";

impl SocSim {
    /// `cargo xtask soc sim` with `args` besides the timeout.
    fn start_with(args: &[&str]) -> Self {
        let mut child = cargo("run")
            .args(["--package", "xtask", "--", "soc", "sim", "--timeout-s", &SIM_TIMEOUT_S.to_string()])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, rx) = mpsc::channel();
        let stdout = child.stdout.take().unwrap();
        let lost = std::sync::Arc::new(std::sync::Mutex::new(None));
        // The simulator's reports come on xtask's standard error: passed on, the overrun
        // count kept.
        let (stderr, seen) = (child.stderr.take().unwrap(), lost.clone());
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(n) = line.split(OVERRUN_MARKER).nth(1).and_then(|r| r.split(' ').next()?.parse().ok()) {
                    *seen.lock().unwrap() = Some(n);
                }
                eprintln!("{line}");
            }
        });
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                match line.strip_prefix("serial: ") {
                    Some(p) => {
                        let _ = tx.send(p.trim().to_string());
                    }
                    None => eprintln!("soc sim: {line}"),
                }
            }
        });
        // Generous: a fresh machine compiles the Verilated SoC first (minutes).
        let pty = rx.recv_timeout(Duration::from_secs(1200)).expect("cargo xtask soc sim prints the pty");
        Self { child, pty, lost }
    }

    /// The simulator's count of lost host bytes at its next report (every 10 s), once more
    /// has been simulated than `since` saw.
    fn lost_after(&self, since: Option<u64>) -> u64 {
        *self.lost.lock().unwrap() = None;
        let t = Instant::now();
        while t.elapsed() < Duration::from_secs(120) {
            if let Some(n) = *self.lost.lock().unwrap() {
                assert!(since.is_none_or(|s| n >= s));
                return n;
            }
            std::thread::sleep(Duration::from_millis(200));
        }
        panic!("the simulator printed no overrun count in 120 s");
    }
}

impl Drop for SocSim {
    fn drop(&mut self) {
        // `cargo run` exec()s xtask, whose simulator dies with it (PR_SET_PDEATHSIG).
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gridrt-e2e-soc-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `gridrt bench frame --configs soc` of bun_zipper_res4 with `args` (the frame's size and
/// the SoC's options); the report's only row.
fn soc_bench_row(name: &str, args: &[&str]) -> serde_json::Value {
    soc_bench_row_of("bun_zipper_res4.obj", name, args)
}

/// `soc_bench_row` of `tests/scenes/SCENE`.
fn soc_bench_row_of(scene: &str, name: &str, args: &[&str]) -> serde_json::Value {
    let dir = tempdir(name);
    let json_path = dir.join("f.json");
    let scene = repo_root().join("tests/scenes").join(scene);
    let (scene, json_arg) = (scene.display().to_string(), json_path.display().to_string());
    let mut all = vec!["bench", "frame", "--scene", &scene, "--configs", "soc", "--json", &json_arg];
    all.extend_from_slice(args);
    let log = run_gridrt(&all);
    eprintln!("{log}");
    let mut report = json(&json_path);
    let row = report["rows"][0].take();
    assert_eq!((row["config"].as_str(), row["cycles_source"].as_str()), (Some("soc"), Some("soc-sim")), "{row}");
    let mut row = row;
    row["soc_sim"] = report["soc_sim"].take();
    row
}

#[test]
fn soc_sim_flashes_through_the_bootloader_and_renders_like_the_rtl_cosim() {
    let test = "soc_sim_flashes_through_the_bootloader_and_renders_like_the_rtl_cosim";
    let Some(_one) = soc_test(test, false) else { return };
    let app = build_firmware(&DEFAULT_SOC_APP);
    // A board's line: the host's bytes paced at 3 Mbaud, and a byte that arrives while the
    // UART's 64-byte receive FIFO is full is lost, as a board's RS232 PHY loses it.
    let sim = SocSim::start_with(&["--baud", "3000000", "--rx-baud", "3000000", "--rx-overrun"]);
    let started = Instant::now();

    // Corrupted on the way: the bootloader reads the image back and refuses its CRC; an image
    // larger than main RAM is refused before a byte is written. The bootloader stays alive.
    let good = FlashImage::from_elf(&std::fs::read(&app).unwrap()).unwrap();
    let mut cfg = FlashConfig::new(sim.pty.clone());
    cfg.session = cfg.session.baud(SLOW_LINE_BAUD.parse().unwrap());
    {
        let mut port = serial::open(&sim.pty, 115_200, serial::DEFAULT_READ_TIMEOUT).unwrap();
        let mut big = good.clone();
        // Larger than main RAM (the lower 16 MiB of the board's SDRAM).
        big.data.resize(64 << 20, 0);
        let e = flash(&mut port, &FlashImage::new(big.load_addr, big.entry, big.data), &cfg, &mut |_| {}).unwrap_err();
        eprintln!("oversized image: {e}");
        assert!(matches!(e, FlashError::Rejected { reason: Some(msg::FlashError::TooLarge), .. }), "{e}");
        let mut corrupted = good.clone();
        corrupted.data.truncate(4096);
        corrupted.data[1000] ^= 0x10;
        let e = flash(&mut port, &corrupted, &cfg, &mut |_| {}).unwrap_err();
        eprintln!("corrupted image: {e}");
        assert!(matches!(e, FlashError::Rejected { reason: Some(msg::FlashError::BadCrc), .. }), "{e}");
    }
    eprintln!("refusals: {:.0} s", started.elapsed().as_secs_f64());

    let t = Instant::now();
    let app_arg = app.display().to_string();
    let log =
        run_gridrt(&["flash", "--port", &sim.pty, "--baud", SLOW_LINE_BAUD, "--boot-wait", SIM_BOOT_WAIT_S, &app_arg]);
    eprintln!("{log}flash: {:.0} s", t.elapsed().as_secs_f64());
    assert!(log.contains("verified") && log.contains("running    application"), "{log}");
    assert!(log.contains("on board 3: 4 PEs"), "the flashed app must answer, not the bootloader: {log}");
    assert!(log.contains("1048576"), "the default SoC keeps 2^20 words per PE in SDRAM: {log}");
    // Nothing of the image was lost on the board's line (a lost byte costs its chunk a
    // resend). The host's `Hello` probes while the app starts (its .bss cleared, nothing
    // read) may be lost: counted here, and not against the upload.
    assert!(log.contains(" 0 chunks resent"), "the flash resent nothing: {log}");
    let after_flash = sim.lost_after(None);
    eprintln!("bytes lost before the upload (the app's start): {after_flash}");

    let dir = tempdir("render");
    let p = |p: &Path| p.display().to_string();
    let scene = p(&repo_root().join("tests/scenes/bun_zipper_res4.obj"));
    let (soc_png, soc_json, sim_png, sim_json) =
        (dir.join("soc.png"), dir.join("soc.json"), dir.join("rtl.png"), dir.join("rtl.json"));
    let frame = ["--scene", &scene, "--width", WIDTH, "--height", HEIGHT];
    let t = Instant::now();
    let timeout = SIM_TIMEOUT_S.to_string();
    // The host's waits for the slow line, and a minute per exchange besides: no region is
    // asked for again while the simulated device renders (such a request would arrive while
    // it is busy, and its bytes could be lost).
    let mut soc_args = vec!["render", "--port", &sim.pty, "--timeout", &timeout];
    soc_args.extend(["--baud", SLOW_LINE_BAUD, "--turnaround", "60000"]);
    let (soc_out, soc_stats) = (p(&soc_png), p(&soc_json));
    soc_args.extend(frame);
    soc_args.extend(["--out", &soc_out, "--stats", &soc_stats]);
    eprintln!("{}", run_gridrt(&soc_args));
    eprintln!(
        "soc render: {:.0} s (simulation running {:.0} s)",
        t.elapsed().as_secs_f64(),
        started.elapsed().as_secs_f64()
    );

    let (sim_out, sim_stats) = (p(&sim_png), p(&sim_json));
    // The same co-processor: the SoC's default keeps each PE's 2²⁰ words in SDRAM behind
    // caches of 512 lines (rtl/README.md §4.6).
    let pe_memory = ["--pe-mem-words", "1048576"];
    let mut rtl_args = vec!["render", "--sim", "--coproc", "rtl", "--pe-cache-lines", "512"];
    rtl_args.extend(pe_memory);
    rtl_args.extend(frame);
    rtl_args.extend(["--out", &sim_out, "--stats", &sim_stats]);
    run_gridrt(&rtl_args);

    let rgb = |path: &Path| image::open(path).unwrap().to_rgb8().into_raw();
    let cmp = compare(&rgb(&soc_png), &rgb(&sim_png), None, None).unwrap();
    eprintln!("soc vs --sim --coproc rtl: identical {}, psnr_db {:?}", cmp.identical, cmp.psnr_db);
    assert!(cmp.identical, "the SoC's frame must equal the RTL co-simulation's: {cmp:?}");
    assert_eq!(std::fs::read(&soc_png).unwrap(), std::fs::read(&sim_png).unwrap(), "PNG bytes");

    // The same frame from the co-processor model at the RTL's kernel, format and timing
    // (`SimConfig::RTL` of the loopback): the SoC matches the model too, not only the RTL.
    let (model_png, model_json) = (dir.join("model.png"), dir.join("model.json"));
    let (model_out, model_stats) = (p(&model_png), p(&model_json));
    let mut model_args = vec!["render", "--sim", "--coproc", "model", "--kernel", "watertight"];
    model_args.extend(["--format", "fixed64-q23", "--timing", "rtl"]);
    model_args.extend(pe_memory);
    model_args.extend(frame);
    model_args.extend(["--out", &model_out, "--stats", &model_stats]);
    run_gridrt(&model_args);
    assert_eq!(std::fs::read(&soc_png).unwrap(), std::fs::read(&model_png).unwrap(), "SoC vs --coproc model PNG bytes");

    let (soc, rtl) = (json(&soc_json), json(&sim_json));
    let upload_cycles = soc["device_counters"]["upload_cycles"].as_u64().unwrap_or(0);
    let upload_bytes = soc["upload_wire_bytes"].as_u64().unwrap();
    eprintln!("upload on the paced line: {upload_bytes} wire bytes in {upload_cycles} cycles; link {}", soc["link"]);
    // On the paced line the upload takes at least its bytes' line time (167 cycles each).
    let line_cycles = upload_bytes as f64 * 10.0 * 50e6 / 3e6;
    assert!(upload_cycles as f64 >= line_cycles * 0.9, "{upload_cycles} cycles for {upload_bytes} bytes");
    // A byte lost from a data frame fails its CRC, and the host sends its chunk again.
    assert_eq!(soc["link"]["upload_chunks_resent"], 0, "the upload resent nothing: {}", soc["link"]);
    assert_eq!(soc["link"]["device_bad_frames"], 0, "the device saw no corrupt frame: {}", soc["link"]);
    let after = sim.lost_after(Some(after_flash));
    eprintln!("bytes lost during the upload and render: {}", after - after_flash);
    assert_eq!((&rtl["kernel"], &rtl["format"]), (&"watertight".into(), &"fixed64-q23".into()));
    for k in ["primary_rays", "shadow_rays", "coproc_rays", "list_entries", "intersection_tests"] {
        assert_eq!(soc[k], rtl[k], "{k}");
    }
    // Measured cycles per instruction of each firmware stage on the VexRiscv full+cfu, the
    // stats kept. Not for `gridrt bench frame --cpu-measured`, whose rows model the imac.
    let kept = repo_root().join("target/soc/render-32x24-stats-cfu.json");
    std::fs::copy(&soc_json, &kept).unwrap();
    eprintln!("SoC stats: {}", kept.display());
    let counters = &soc["device_counters"];
    for stage in ["raygen", "traverse", "fsl_io", "shade", "encode"] {
        let c = counters[format!("stage_{stage}_cycles")].as_u64().unwrap();
        let i = counters[format!("stage_{stage}_instret")].as_u64().unwrap();
        assert!(i > 0 && c >= i, "{stage}: {c} cycles for {i} instructions");
        eprintln!("{stage:>8}: {c:>10} cycles {i:>10} instructions  CPI {:.3}", c as f64 / i as f64);
    }
}

/// `gridrt bench frame --configs soc` on a tiny frame: the `soc` row is measured on the
/// simulated SoC (`cycles_source` "soc-sim", the SoC's own frame cycles), identical to
/// `--sim --coproc rtl`, and its line keeps time: the cycles from the frame's first byte on
/// the UART to its transmit FIFO draining equal the frame's bytes × 10 × clock ÷ baud
/// within one byte time. In rgb888 a row's bytes take longer on the line than the next row
/// takes to render, so the line never idles and the span is the bytes' line time.
#[test]
fn soc_row_link_cycles_are_the_frames_bytes_at_the_baud_rate() {
    let test = "soc_row_link_cycles_are_the_frames_bytes_at_the_baud_rate";
    let Some(_one) = soc_test(test, false) else { return };
    let row = soc_bench_row("bench", &["--width", "8", "--height", "6", "--encoding", "rgb888"]);
    // The default SoC's CPU.
    assert_eq!((row["target"].as_str(), row["float_hw"].as_str()), (Some("riscv32im"), Some("cfu")));
    assert_eq!(row["identical_to_rtl_sim"], true, "the SoC's frame equals --sim --coproc rtl");
    let frame_cycles = row["frame_cycles"].as_u64().unwrap();
    let link_cycles = row["link_cycles"].as_u64().unwrap() as f64;
    let bytes = row["frame_tx_bytes"].as_u64().unwrap() as f64;
    let (clock_hz, baud) = (row["clock_mhz"].as_f64().unwrap() * 1e6, row["baud"].as_f64().unwrap());
    let byte_time = 10.0 * clock_hz / baud;
    // 8×6 rgb888: at least the pixels' bytes, and framing on top.
    assert!(bytes >= 8.0 * 6.0 * 3.0, "{bytes} bytes for 144 bytes of pixels");
    let expected = bytes * byte_time;
    eprintln!("link: {link_cycles} cycles for {bytes} bytes; {expected:.0} expected ({byte_time:.1} per byte)");
    assert!((link_cycles - expected).abs() <= byte_time, "{link_cycles} cycles vs {expected:.0} ± {byte_time:.0}");
    assert!(frame_cycles as f64 >= link_cycles, "the frame holds its line time: {frame_cycles} < {link_cycles}");
    let speed = row["soc_sim"]["sim_cycles_per_s"].as_f64().unwrap();
    eprintln!("simulation speed: {speed:.0} cycles/s");
    assert!(speed > 0.0);
}

/// The SoC without floating point in hardware, the smaller CPU for small boards
/// (`--float-hw none`: VexRiscv imac, f32 in soft float, the firmware for riscv32imac):
/// `gridrt bench frame --configs soc --soc-float-hw none` renders the 32×24 frame
/// byte-identical to `--sim --coproc rtl` and to the f64 reference. The row says which CPU
/// ran. The default SoC (the CFU) runs in the other tests. Needs `GRIDRT_SOC_SIM_LONG=1`
/// besides `GRIDRT_SOC_SIM=1` (11 minutes here, a Verilator build of its own among them): not
/// in CI, whose SoC step it took past 45 minutes.
#[test]
fn soc_with_the_imac_renders_like_the_rtl_cosim() {
    let test = "soc_with_the_imac_renders_like_the_rtl_cosim";
    let Some(_one) = soc_test(test, true) else { return };
    let row = soc_bench_row("bench-imac", &["--soc-float-hw", "none", "--width", WIDTH, "--height", HEIGHT]);
    assert_eq!(row["target"], "riscv32imac");
    assert_eq!((row["float_hw"].as_str(), row["cpu_profile"].as_str()), (Some("none"), Some("vexriscv-imac")));
    assert_eq!(row["identical_to_rtl_sim"], true, "the imac SoC's frame equals --sim --coproc rtl");
    assert_eq!(row["identical"], true, "and the f64 reference");
}

/// Two harts (`--harts 2`: a worker VexRiscv, full+cfu like the first, with its own port on
/// the co-processor claims rows beside the first hart): `gridrt bench frame --configs soc
/// --soc-harts 2` renders the 32×24 frame byte-identical to `--sim --coproc rtl` with the
/// same work counted (rays, list entries, tests: `bench frame` refuses a soc row whose counts
/// differ), so every row the worker traced reached the first hart whole and in order, and
/// through the shared co-processor each hart got its own answers.
#[test]
fn soc_with_two_harts_renders_like_the_rtl_cosim() {
    let test = "soc_with_two_harts_renders_like_the_rtl_cosim";
    let Some(_one) = soc_test(test, false) else { return };
    let row = soc_bench_row("bench-harts", &["--soc-harts", "2", "--width", WIDTH, "--height", HEIGHT]);
    assert_eq!((&row["harts"], &row["float_hw"]), (&2.into(), &"cfu".into()), "{row}");
    assert_eq!(row["identical_to_rtl_sim"], true, "the 2-hart SoC's frame equals --sim --coproc rtl");
    assert_eq!(row["identical"], true, "and the f64 reference");
    // Each hart counted its own rows: together every row of the frame, a worker among them.
    let work = row["hart_work"].as_array().unwrap_or_else(|| panic!("per-hart counters: {row}"));
    let rows: Vec<u64> = work.iter().map(|w| w["rows"].as_u64().unwrap()).collect();
    assert_eq!(rows.iter().sum::<u64>(), HEIGHT.parse::<u64>().unwrap(), "{work:?}");
    assert!(rows.len() == 2 && rows[1] > 0, "the worker traced rows: {work:?}");
    assert!(work.iter().all(|w| w["busy_cycles"].as_u64().unwrap() > 0), "{work:?}");
}

/// A scene beyond block RAM: bun_zipper_res3's fullest PE needs more than the 16 384 words of
/// a block-RAM PE (the simulator refuses it there); the default SoC, whose PE images are in
/// SDRAM behind 512-line caches, renders the 32×24 frame identical to `--sim --coproc rtl`
/// with the same PE memories and to the f64 reference (`gridrt bench frame --configs soc`).
/// Needs `GRIDRT_SOC_SIM_LONG=1` besides `GRIDRT_SOC_SIM=1`: the test takes about 11 minutes
/// here, 6 of them the upload (460 007 wire bytes at about 230 simulated cycles each), so it
/// is not in CI; the other SoC tests already keep their PE images in SDRAM.
#[test]
fn soc_renders_a_scene_beyond_block_ram_like_the_rtl_cosim() {
    let test = "soc_renders_a_scene_beyond_block_ram_like_the_rtl_cosim";
    let Some(_one) = soc_test(test, true) else { return };
    let res3 = repo_root().join("tests/scenes/bun_zipper_res3.obj");
    let bram = Command::new(gridrt())
        .args(["render", "--sim", "--pe-mem-words", "16384", "--width", WIDTH, "--height", HEIGHT, "--out"])
        .arg(tempdir("bram").join("bram.png"))
        .arg("--scene")
        .arg(&res3)
        .output()
        .unwrap();
    let why = String::from_utf8_lossy(&bram.stderr);
    assert!(!bram.status.success() && why.contains("scene too large"), "res3 must not fit block RAM: {why}");
    let row = soc_bench_row_of("bun_zipper_res3.obj", "bench-res3", &["--width", WIDTH, "--height", HEIGHT]);
    assert_eq!(row["pe_cache_lines"].as_u64(), Some(512), "{row}");
    assert_eq!(row["identical_to_rtl_sim"], true, "the SoC's res3 frame equals --sim --coproc rtl: {row}");
    assert_eq!(row["identical"], true, "and the f64 reference: {row}");
}

/// stanford-bunny (69 451 triangles, 6.3 MB of scene image, its fullest PE far beyond block
/// RAM) on the default SoC: the 32×24 frame identical to `--sim --coproc rtl` with the same
/// PE memories and caches, and to the f64 reference; the device reports the upload's cycles.
/// Needs `GRIDRT_SOC_SIM_LONG=1` besides `GRIDRT_SOC_SIM=1` (the upload is about 1.2 × 10⁹
/// simulated cycles).
#[test]
fn soc_renders_stanford_bunny_like_the_rtl_cosim() {
    let test = "soc_renders_stanford_bunny_like_the_rtl_cosim";
    let Some(_one) = soc_test(test, true) else { return };
    let row = soc_bench_row_of("stanford-bunny.obj", "bench-stanford", &["--width", WIDTH, "--height", HEIGHT]);
    assert_eq!(row["pe_cache_lines"].as_u64(), Some(512), "{row}");
    assert_eq!(row["identical_to_rtl_sim"], true, "the SoC's stanford-bunny frame equals --sim --coproc rtl: {row}");
    assert_eq!(row["identical"], true, "and the f64 reference: {row}");
    let upload = &row["soc_sim"];
    let (cycles, bytes) = (upload["upload_cycles"].as_u64().unwrap(), upload["upload_wire_bytes"].as_u64().unwrap());
    eprintln!("upload: {bytes} wire bytes in {cycles} cycles");
    assert!(bytes > 6_000_000 && cycles > bytes, "{upload}");
}
