//! `gridrt render --out-dir DIR --frames N --orbit DEGREES` through the real binary: numbered
//! PNGs and per-frame statistics; bad input refused in one line before anything is sent; the
//! new flags explained by `--help`; progress lines on a non-terminal stderr.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bunny() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj")
}

fn gridrt(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gridrt")).args(args).output().unwrap()
}

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gridrt-cli-stream-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A failed run's stderr: one line, starting `error:`.
fn one_line_error(out: &Output) -> String {
    assert!(!out.status.success(), "should fail: {}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    err
}

#[test]
fn a_sim_stream_writes_numbered_pngs_and_per_frame_stats() {
    let dir = tempdir("ok");
    let (out, stats) = (dir.join("frames"), dir.join("s.json"));
    let scene = bunny().display().to_string();
    let (o, s) = (out.display().to_string(), stats.display().to_string());
    let run = gridrt(&[
        "render",
        "--sim",
        "--scene",
        &scene,
        "-W",
        "40",
        "-H",
        "30",
        "--frames",
        "3",
        "--orbit",
        "90",
        "--out-dir",
        &o,
        "--stats",
        &s,
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let mut names: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    assert_eq!(names, ["frame-0000.png", "frame-0001.png", "frame-0002.png"]);
    // Non-terminal stderr: one progress line per frame, no protocol structs.
    for i in 1..=3 {
        assert!(stderr.contains(&format!("frame {i}/3 in ")), "{stderr}");
    }
    assert!(!stderr.contains("Sack {") && !stderr.contains("RegionEnd {"), "{stderr}");
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    let frames = j["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f["index"].as_u64(), Some(i as u64));
        for key in ["frame_ms", "fps", "wire_rx"] {
            assert!(f[key].as_f64().is_some_and(|v| v > 0.0), "frame {i}: {key} in {f}");
        }
        // Requests leave ahead of their frame on the simulator: the last frame sends none.
        assert!(f["wire_tx"].as_u64().is_some(), "frame {i}: wire_tx in {f}");
    }
    let tx: u64 = frames.iter().map(|f| f["wire_tx"].as_u64().unwrap()).sum();
    assert_eq!(j["wire_tx"].as_u64(), Some(tx));
    assert!(tx >= 3 * 97, "three requests: {tx} B");
    for key in ["fps", "line_utilisation", "elapsed_s"] {
        assert!(j[key].as_f64().is_some_and(|v| v > 0.0), "{key} in {j}");
    }
    assert_eq!(j["camera_path"].as_str(), Some("orbit 90°"));
    // Frame 0 is the scene's own camera: the single-frame render's picture.
    let single = dir.join("single.png");
    let one =
        gridrt(&["render", "--sim", "--scene", &scene, "-W", "40", "-H", "30", "--out", single.to_str().unwrap()]);
    assert!(one.status.success());
    let (a, b) = (image::open(&single).unwrap().to_rgb8(), image::open(out.join("frame-0000.png")).unwrap().to_rgb8());
    assert!(a == b, "frame 0 of the orbit is the scene's camera");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn apng_holds_every_frame_of_the_stream_in_order() {
    let dir = tempdir("apng");
    let (out, apng) = (dir.join("frames"), dir.join("orbit.png"));
    let scene = bunny().display().to_string();
    let (o, a) = (out.display().to_string(), apng.display().to_string());
    let args = ["render", "--sim", "--scene", &scene, "-W", "40", "-H", "30", "--frames", "3", "--orbit", "90"];
    let run = gridrt(&[&args[..], &["--out-dir", &o, "--apng", &a, "--apng-fps", "12.5"]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let pngs: Vec<Vec<u8>> =
        (0..3).map(|i| image::open(out.join(format!("frame-{i:04}.png"))).unwrap().to_rgb8().into_raw()).collect();
    assert!(pngs[0] != pngs[1] && pngs[1] != pngs[2], "the orbit's frames differ, so order shows");
    let file = std::io::Cursor::new(std::fs::read(&apng).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let actl = reader.info().animation_control.unwrap();
    assert_eq!((actl.num_frames, actl.num_plays), (3, 0));
    let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
    for (i, want) in pngs.iter().enumerate() {
        let got = reader.next_frame(&mut buf).unwrap();
        let fctl = reader.info().frame_control.unwrap();
        assert_eq!((fctl.width, fctl.height, fctl.x_offset, fctl.y_offset), (40, 30, 0, 0), "frame {i}");
        assert_eq!((fctl.delay_num, fctl.delay_den), (80, 1000), "frame {i}: 1 / 12.5 fps");
        assert_eq!(got.color_type, png::ColorType::Rgb);
        assert!(&buf[..got.buffer_size()] == want.as_slice(), "frame {i} differs from frame-{i:04}.png");
    }
    assert!(reader.next_frame(&mut buf).is_err(), "no fourth frame");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_stream_input_is_one_line_before_anything_is_sent() {
    let dir = tempdir("bad");
    let scene = bunny().display().to_string();
    let o = dir.join("o").display().to_string();
    // A port that does not exist: an error about the input must come first.
    let base = ["render", "--port", "/dev/gridrt-no-such-port", "--scene", &scene];
    let run = |extra: &[&str]| one_line_error(&gridrt(&[&base[..], extra].concat()));
    let e = run(&["--out-dir", &o, "--frames", "0"]);
    assert!(e.contains("--frames") && e.contains("0 frames is not in 1..=100000"), "{e}");
    let e = run(&["--out-dir", &o, "--frames", "100001"]);
    assert!(e.contains("not in 1..=100000"), "{e}");
    let e = run(&["--out-dir", &o, "--frames", "lots"]);
    assert!(e.contains("`lots` is not a number of frames"), "{e}");
    let e = run(&["--out-dir", &o, "--frames", "3", "--orbit", "NaN"]);
    assert!(e.contains("--orbit") && e.contains("not in -3600..=3600"), "{e}");
    let e = run(&["--out-dir", &o, "--frames", "3", "--orbit", "1e9"]);
    assert!(e.contains("not in -3600..=3600"), "{e}");
    let e = run(&["--frames", "3", "--out", "a.png"]);
    assert!(e.contains("--out-dir"), "--frames needs --out-dir: {e}");
    let e = run(&["--out-dir", &o, "--out", "a.png"]);
    assert!(e.contains("--out") && e.contains("cannot be used with"), "{e}");
    // An --out-dir that cannot be made: under a file.
    let file = dir.join("plain");
    std::fs::write(&file, b"x").unwrap();
    let under = file.join("frames").display().to_string();
    let e = run(&["--out-dir", &under, "--frames", "3"]);
    assert!(e.contains("--out-dir") && e.contains("is a file, not a folder"), "{e}");
    assert!(!e.contains("gridrt-no-such-port"), "the output is checked before the port: {e}");
    let e = run(&["--out-dir", &o, "--frames", "3", "--apng", &file.join("a.png").display().to_string()]);
    assert!(e.contains("--apng") && e.contains("is a file, not a folder"), "{e}");
    assert!(!e.contains("gridrt-no-such-port"), "--apng is checked before the port: {e}");
    let e = run(&["--out-dir", &o, "--apng", "a.png", "--apng-fps", "0"]);
    assert!(e.contains("--apng-fps") && e.contains("0 fps is not in 0.01..=1000"), "{e}");
    let e = run(&["--out", "a.png", "--apng", "a.png"]);
    assert!(e.contains("--out-dir"), "--apng needs --out-dir: {e}");
    // A camera path through the scene: refused before the simulator starts.
    let toml = dir.join("path.toml");
    std::fs::write(
        &toml,
        "[[objects]]\ntype = \"sphere\"\n\n[[camera_path]]\neye = [0, 0, -3]\ntarget = [0, 0, 0]\n\n[[camera_path]]\neye = [0, 0, 3]\ntarget = [0, 0, 0]\n",
    )
    .unwrap();
    let out = gridrt(&["render", "--sim", "--scene", toml.to_str().unwrap(), "--out-dir", &o, "--frames", "3"]);
    let e = one_line_error(&out);
    assert!(e.contains("camera path") && e.contains("frame 1"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn help_explains_the_stream_flags() {
    let out = gridrt(&["render", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in [
        "--out-dir <DIR>",
        "--frames <N>",
        "--orbit <DEGREES>",
        "--view [<PORT>]",
        "--apng <FILE>",
        "--apng-fps <FPS>",
        "animated PNG",
        "frame-0000.png",
        "line_utilisation",
    ] {
        assert!(help.contains(flag), "--help lacks `{flag}`");
    }
    let out = gridrt(&["bench", "stream", "--help"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("--bauds"), "bench stream --help");
}
