//! The faulty line, as a user sees it: `gridrt device --port A` and `gridrt render --port B` through
//! a relay between two kernel pseudo-terminals, paced at the line rate, with bit flips, byte
//! drops and garbage bursts in both directions at BER 1e-3. The PNG equals the simulator's,
//! and stdout (a pipe, not a terminal) gets progress lines while each stage runs.
//!
//! 57 600 baud keeps each stage longer than the CLI's progress interval (the compact upload
//! of res4 is 29 KiB), and the test near 20 s; `gridrt bench link --faults` measures 115 200.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use gridrt_host::faults::relay::{PtyRelay, RelayConfig};
use gridrt_host::faults::Faults;

const BAUD: &str = "57600";

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj")
}

/// Kills the device when the test ends, however it ends.
struct Device(Child);

impl Drop for Device {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn render_over_a_noisy_paced_line_gives_the_clean_png_and_is_never_silent() {
    let dir = std::env::temp_dir().join(format!("gridrt-noisy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (noisy_png, clean_png) = (dir.join("noisy.png"), dir.join("clean.png"));
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--sim", "--encoding", "rle", "--scene"])
        .arg(scene())
        .arg("--out")
        .arg(&clean_png)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let relay = PtyRelay::start(RelayConfig {
        baud: Some(BAUD.parse().unwrap()),
        up: Faults::line(1e-3),
        down: Faults::line(1e-3),
        seed: 21,
    })
    .unwrap();
    let _device = Device(
        Command::new(env!("CARGO_BIN_EXE_gridrt"))
            .args(["device", "--baud", BAUD, "--port"])
            .arg(relay.device_path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let start = Instant::now();
    let mut render = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--baud", BAUD, "--encoding", "rle", "--port"])
        .arg(relay.host_path())
        .arg("--scene")
        .arg(scene())
        .arg("--out")
        .arg(&noisy_png)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines: Vec<(Duration, String)> = Vec::new();
    // Progress goes to stderr; stdout (the summary) is read on a thread of its own.
    let stdout = render.stdout.take().unwrap();
    let summary = std::thread::spawn(move || std::io::read_to_string(stdout).unwrap());
    for line in BufReader::new(render.stderr.take().unwrap()).lines() {
        lines.push((start.elapsed(), line.unwrap()));
    }
    let status = render.wait().unwrap();
    let end = start.elapsed();
    let stderr = summary.join().unwrap();
    let log: String = lines.iter().map(|(t, l)| format!("{:6.2} s  {l}\n", t.as_secs_f64())).collect();
    assert!(status.success(), "render failed:\n{log}{stderr}");
    let (up, down) = relay.injected();
    assert!(up.flips > 0 && down.flips > 0 && up.drops + down.drops > 0, "{up:?} {down:?}");

    // Never silent: besides the line that ends each stage (upload, render), progress lines
    // while a stage runs, naming bytes, rate and retransmits. How often they come is the
    // CLI's clock (`LINE_EVERY`), not checked here: a test checks behaviour, not speed.
    let progress = |stage: &str| {
        lines
            .iter()
            .filter(|(_, l)| {
                l.starts_with(stage) && l.contains(" in ") && (l.contains("resent") || l.contains("re-requested"))
            })
            .count()
    };
    // A stage's first line: "upload  N KiB scene image", "render  W×H frame".
    let stages = lines.iter().filter(|(_, l)| l.ends_with(" scene image") || l.ends_with(" frame")).count();
    assert!(progress("upload") >= 1 && stages >= 2, "{log}");
    assert!(progress("render") + progress("upload") > stages, "no line while a stage ran\n{log}");
    assert!(end > Duration::from_secs(8), "the line is paced: {:.1} s\n{log}", end.as_secs_f64());

    assert!(std::fs::read(&noisy_png).unwrap() == std::fs::read(&clean_png).unwrap(), "PNGs differ\n{log}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `gridrt bench link --faults` on a clean line: each phase's line bytes are the relay's
/// counts, equal to what the host's session sent and received, and the line utilisation is
/// those bytes at ten bits each over the baud rate and the phase's time (never above 1: the
/// relay paces every byte).
#[test]
fn bench_link_faults_reports_the_relays_bytes_and_their_line_utilisation() {
    let dir = std::env::temp_dir().join(format!("gridrt-faults-util-{}", std::process::id()));
    let baud = 230_400u32;
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["bench", "link", "--faults", "--bers", "0", "--width", "32", "--height", "24"])
        .args(["--encoding", "rgb888", "--baud", &baud.to_string(), "--out-dir"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("link_faults.json")).unwrap()).unwrap();
    let r = &j["rows"][0];
    let pair = |k: &str| [r[k][0].as_u64().unwrap(), r[k][1].as_u64().unwrap()];
    let (up_line, frame_line) = (pair("upload_line_bytes"), pair("frame_line_bytes"));
    assert_eq!(up_line, pair("upload_session_bytes"), "upload: relay vs session\n{r}");
    assert_eq!(frame_line, pair("frame_session_bytes"), "frame: relay vs session\n{r}");
    // The upload carries at least the scene's compact stream; the frame its 32×24 rgb888 pixels.
    assert!(up_line[0] > 20_000 && frame_line[1] > 32 * 24 * 3, "{r}");
    for (phase, bytes) in [("upload", up_line[0]), ("frame", frame_line[1])] {
        let secs = r[format!("{phase}_s")].as_f64().unwrap();
        let util = r[format!("{phase}_line_utilisation")].as_f64().unwrap();
        let want = bytes as f64 * 10.0 / (f64::from(baud) * secs);
        assert!((util - want).abs() <= 1e-9 * want, "{phase}: {util} vs {want}\n{r}");
        assert!(util > 0.0 && util <= 1.0, "{phase}: a paced line carries at most its rate: {util}\n{r}");
    }
    let csv = std::fs::read_to_string(dir.join("link_faults.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for k in ["upload_line_utilisation", "frame_line_utilisation", "upload_line_bytes_up", "frame_line_bytes_down"] {
        assert!(head.contains(&k), "CSV column {k}: {head:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
