//! Frames as a stream through a real serial line: `gridrt device` behind the project's paced
//! relay (`gridrt_host::faults::relay`, two kernel pseudo-terminals, every byte one 8N1 byte
//! time at 3 000 000 baud) and `gridrt render --port … --frames N --orbit 360 --out-dir`
//! on the other end write the same numbered PNGs, byte for byte, as `gridrt render --sim`
//! of the same stream; the statistics name every frame and the stream's fps and line
//! utilisation, which a paced line bounds by 1.
//!
//! The full-size stream (30 frames of bun_zipper_res4 at 320×240 over the 3 Mbaud relay) is the same test by hand
//! (minutes; it prints fps and line utilisation, BENCHMARKS.md):
//!
//! ```sh
//! GRIDRT_STREAM_FULL=1 cargo test -p gridrt-e2e --test stream -- --nocapture
//! ```

use std::path::{Path, PathBuf};
use std::process::{Child, Command};

use gridrt_e2e::builds::{check, gridrt, repo_root};
use gridrt_host::faults::relay::{PtyRelay, RelayConfig};

const BAUD: u32 = 3_000_000;

/// Frames, width and height: 4 at 64×48, or with `GRIDRT_STREAM_FULL=1` 30 at 320×240.
fn size() -> (usize, &'static str, &'static str) {
    if std::env::var("GRIDRT_STREAM_FULL").is_ok_and(|v| v == "1") {
        (30, "320", "240")
    } else {
        (4, "64", "48")
    }
}

/// Kills a helper process when the test ends, however it ends.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gridrt-e2e-stream-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stream_args<'a>(out: &'a str, stats: &'a str, frames: &'a str) -> Vec<&'a str> {
    let (_, w, h) = size();
    vec![
        "render",
        "--scene",
        "tests/scenes/bun_zipper_res4.obj",
        "--width",
        w,
        "--height",
        h,
        "--encoding",
        "rle",
        "--frames",
        frames,
        "--orbit",
        "360",
        "--out-dir",
        out,
        "--stats",
        stats,
    ]
}

fn pngs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect();
    v.sort();
    v
}

#[test]
fn a_stream_over_the_paced_line_equals_the_simulated_stream() {
    let (frames_n, ..) = size();
    let dir = tempdir("relay");
    let (line_dir, sim_dir) = (dir.join("line"), dir.join("sim"));
    let (line_stats, sim_stats) = (dir.join("line.json"), dir.join("sim.json"));
    let relay = PtyRelay::start(RelayConfig::clean(Some(BAUD))).unwrap();
    let dev = relay.device_path().display().to_string();
    let host = relay.host_path().display().to_string();
    let baud = BAUD.to_string();
    let _device = KillOnDrop(
        Command::new(gridrt())
            .args(["device", "--port", &dev, "--baud", &baud, "--pe-mem-words", "524288"])
            .spawn()
            .unwrap(),
    );
    let frames = frames_n.to_string();
    let (l, ls) = (line_dir.display().to_string(), line_stats.display().to_string());
    let mut args = stream_args(&l, &ls, &frames);
    args.extend(["--port", &host, "--baud", &baud]);
    let out = Command::new(gridrt()).args(&args).current_dir(repo_root()).output().unwrap();
    let stdout = check(out, "gridrt render --port (relay)");
    eprintln!("{stdout}");

    let (s, ss) = (sim_dir.display().to_string(), sim_stats.display().to_string());
    let mut args = stream_args(&s, &ss, &frames);
    args.extend(["--sim", "--pe-mem-words", "524288"]);
    check(Command::new(gridrt()).args(&args).current_dir(repo_root()).output().unwrap(), "gridrt render --sim");

    let (line, sim) = (pngs(&line_dir), pngs(&sim_dir));
    let names: Vec<String> = (0..frames_n).map(|i| format!("frame-{i:04}.png")).collect();
    assert_eq!(line.iter().map(|p| p.0.clone()).collect::<Vec<_>>(), names, "numbered PNGs, nothing else");
    assert_eq!(sim.iter().map(|p| p.0.clone()).collect::<Vec<_>>(), names);
    for ((name, a), (_, b)) in line.iter().zip(&sim) {
        assert!(a == b, "{name}: the line's PNG differs from the simulator's");
    }
    // The orbit moves the camera: no two frames alike.
    for (i, a) in line.iter().enumerate() {
        for b in &line[i + 1..] {
            assert!(a.1 != b.1, "{} and {} are the same picture", a.0, b.0);
        }
    }

    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(&line_stats).unwrap()).unwrap();
    let per_frame = stats["frames"].as_array().expect("`frames`: one object per frame");
    assert_eq!(per_frame.len(), frames_n);
    let mut wire = 0;
    for (i, f) in per_frame.iter().enumerate() {
        assert_eq!(f["index"].as_u64(), Some(i as u64));
        assert!(f["frame_ms"].as_f64().unwrap() > 0.0 && f["fps"].as_f64().unwrap() > 0.0, "{f}");
        assert!(f["wire_rx"].as_u64().unwrap() > 0, "{f}");
        wire += f["wire_rx"].as_u64().unwrap();
    }
    assert_eq!(stats["wire_rx"].as_u64(), Some(wire), "the stream's bytes are its frames'");
    let (fps, util, elapsed) = (
        stats["fps"].as_f64().unwrap(),
        stats["line_utilisation"].as_f64().unwrap(),
        stats["elapsed_s"].as_f64().unwrap(),
    );
    assert!((fps - frames_n as f64 / elapsed).abs() < 1e-6 * fps, "fps = frames / elapsed: {stats}");
    // Bytes ÷ (baud/10 × elapsed): positive, and a paced line cannot carry more than itself
    // (a little slack for the first bytes already on their way when the clock starts).
    assert!((wire as f64 / (BAUD as f64 / 10.0 * elapsed) - util).abs() < 1e-9, "{stats}");
    assert!(util > 0.0 && util <= 1.02, "line_utilisation {util}");
    eprintln!(
        "over the relay at {BAUD} baud: {frames_n} frames in {elapsed:.2} s, {fps:.2} fps, line utilisation {util:.3}, {wire} B from the board"
    );
    let sim: serde_json::Value = serde_json::from_slice(&std::fs::read(&sim_stats).unwrap()).unwrap();
    eprintln!("the same stream on --sim (unpaced): {:.2} fps", sim["fps"].as_f64().unwrap());
    drop(relay);
    let _ = std::fs::remove_dir_all(&dir);
}
