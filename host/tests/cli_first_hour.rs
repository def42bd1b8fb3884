//! A new user's first hour, through the real binary: bad inputs fail at once with one line
//! and leave nothing behind, the port and the config file resolve as documented,
//! completions print, and the link bench runs from a folder outside the repository.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj")
}

/// A fresh empty folder.
fn tempdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gridrt-first-hour-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `gridrt` with no GRIDRT_* variables and no user config (XDG_CONFIG_HOME empty folder),
/// run in `cwd`.
fn gridrt(cwd: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gridrt"));
    let xdg = cwd.join("xdg-empty");
    std::fs::create_dir_all(&xdg).unwrap();
    c.current_dir(cwd).env_remove("GRIDRT_PORT").env_remove("GRIDRT_BAUD").env("XDG_CONFIG_HOME", xdg);
    c
}

/// Runs `c`, which must fail with exactly one `error: ` line on stderr; returns it.
fn one_line_failure(c: &mut Command) -> String {
    let out: Output = c.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "must fail; stderr: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "one line of error, got: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    lines[0].to_string()
}

#[test]
fn a_huge_frame_fails_at_once_with_one_line() {
    let dir = tempdir("huge");
    let start = Instant::now();
    let err = one_line_failure(
        gridrt(&dir)
            .args(["render", "--sim", "--scene"])
            .arg(scene())
            .args(["--width", "65535", "--height", "65535", "--out", "x.png"]),
    );
    assert!(start.elapsed() < Duration::from_secs(2), "took {:?}", start.elapsed());
    assert!(err.contains("--width") && err.contains("4096"), "{err}");
    for (flag, v) in [("--width", "0"), ("--width", "4097"), ("--height", "4097"), ("-W", "0")] {
        let err = one_line_failure(
            gridrt(&dir).args(["render", "--sim", "--scene"]).arg(scene()).args([flag, v, "--out", "x.png"]),
        );
        assert!(err.contains(v), "{flag} {v}: {err}");
    }
    assert!(!dir.join("x.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_outputs_fail_before_anything_is_sent_and_leave_nothing() {
    let dir = tempdir("outputs");
    // A regular file as the "port": anything sent would land in it.
    let port = dir.join("port");
    std::fs::write(&port, b"").unwrap();
    std::fs::write(dir.join("plain"), b"x").unwrap();
    std::fs::create_dir_all(dir.join("folder")).unwrap();
    for (out, says) in [
        ("folder", "is a folder"),
        ("x.jpg", "cannot write this format"),
        ("noext", "cannot write this format"),
        ("plain/x.png", "is a file, not a folder"),
    ] {
        let err = one_line_failure(
            gridrt(&dir).args(["render", "--port"]).arg(&port).arg("--scene").arg(scene()).args(["--out", out]),
        );
        assert!(err.contains(says) && err.contains("--out"), "--out {out}: {err}");
        assert_eq!(std::fs::metadata(&port).unwrap().len(), 0, "--out {out}: nothing sent");
    }
    // --stats is checked as early.
    let err = one_line_failure(
        gridrt(&dir)
            .args(["render", "--port"])
            .arg(&port)
            .arg("--scene")
            .arg(scene())
            .args(["--out", "ok.png", "--stats", "folder"]),
    );
    assert!(err.contains("--stats"), "{err}");
    let mut left: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    left.sort();
    assert_eq!(left, ["folder", "plain", "port", "xdg-empty"], "no output file and no temporary left");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_port_from_the_environment_is_named() {
    let dir = tempdir("env-port");
    let err = one_line_failure(
        gridrt(&dir)
            .env("GRIDRT_PORT", "/dev/nonexistent")
            .args(["render", "--scene"])
            .arg(scene())
            .args(["--out", "x.png"]),
    );
    assert!(err.contains("/dev/nonexistent"), "{err}");
    assert!(!dir.join("x.png").exists());
    // --sim wins over GRIDRT_PORT.
    let out = gridrt(&dir)
        .env("GRIDRT_PORT", "/dev/nonexistent")
        .args(["render", "--sim", "--scene"])
        .arg(scene())
        .args(["-W", "8", "-H", "6", "-o", "y.png"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn completions_print_for_bash_zsh_and_fish() {
    let dir = tempdir("completions");
    for shell in ["bash", "zsh", "fish"] {
        let out = gridrt(&dir).args(["completions", shell]).output().unwrap();
        assert!(out.status.success(), "{shell}");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.len() > 500 && text.contains("gridrt") && text.contains("render"), "{shell}: {text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The baud rate a `--sim` render used (its stats), with `extra` flags and environment.
fn sim_baud(dir: &Path, env: &[(&str, &str)], flags: &[&str]) -> u64 {
    let mut c = gridrt(dir);
    c.envs(env.iter().copied()).args(["render", "--sim", "--scene"]).arg(scene());
    c.args(["-W", "8", "-H", "6", "--out", "f.png", "--stats", "f.json"]).args(flags);
    let out = c.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("f.json")).unwrap()).unwrap();
    stats["link"]["baud"].as_u64().unwrap()
}

#[test]
fn flag_beats_environment_beats_config_file_beats_default() {
    let dir = tempdir("config");
    assert_eq!(sim_baud(&dir, &[], &[]), 115_200, "built-in default");
    // The user's config folder.
    let xdg = dir.join("xdg");
    std::fs::create_dir_all(xdg.join("gridrt")).unwrap();
    std::fs::write(xdg.join("gridrt/gridrt.toml"), "baud = 57600\n").unwrap();
    let xdg_s = xdg.to_str().unwrap();
    assert_eq!(sim_baud(&dir, &[("XDG_CONFIG_HOME", xdg_s)], &[]), 57_600, "user config file");
    // The current folder's file wins over the user's.
    std::fs::write(dir.join("gridrt.toml"), "baud = 9600\nport = \"/dev/gridrt-from-file\"\n").unwrap();
    assert_eq!(sim_baud(&dir, &[("XDG_CONFIG_HOME", xdg_s)], &[]), 9_600, "./gridrt.toml");
    assert_eq!(sim_baud(&dir, &[("GRIDRT_BAUD", "19200")], &[]), 19_200, "environment over file");
    assert_eq!(sim_baud(&dir, &[("GRIDRT_BAUD", "19200")], &["-b", "38400"]), 38_400, "flag over environment");
    // The port: file, then environment, then flag.
    let port_in_error = |env: &[(&str, &str)], flags: &[&str]| {
        let mut c = gridrt(&dir);
        c.envs(env.iter().copied()).args(["render", "--scene"]).arg(scene()).args(["--out", "p.png"]).args(flags);
        one_line_failure(&mut c)
    };
    assert!(port_in_error(&[], &[]).contains("/dev/gridrt-from-file"));
    let e = port_in_error(&[("GRIDRT_PORT", "/dev/gridrt-from-env")], &[]);
    assert!(e.contains("/dev/gridrt-from-env"), "{e}");
    let e = port_in_error(&[("GRIDRT_PORT", "/dev/gridrt-from-env")], &["-p", "/dev/gridrt-from-flag"]);
    assert!(e.contains("/dev/gridrt-from-flag"), "{e}");
    // A misspelt key is an error naming the file.
    std::fs::write(dir.join("gridrt.toml"), "bad = 1\n").unwrap();
    let e = port_in_error(&[], &[]);
    assert!(e.contains("gridrt.toml"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn help_speaks_the_users_words_and_documents_the_config_file() {
    let dir = tempdir("help");
    for args in [&["--help"][..], &["render", "--help"], &["bench", "--help"], &["flash", "--help"]] {
        let out = gridrt(&dir).args(args).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        for word in ["seed 0", "issue ", "§"] {
            assert!(!text.contains(word), "{args:?} --help says `{word}`:\n{text}");
        }
        if args[0] != "bench" {
            assert!(text.contains("gridrt.toml") && text.contains("GRIDRT_PORT"), "{args:?}:\n{text}");
        }
    }
    let out = gridrt(&dir).args(["bench", "--help"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("splat"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_link_runs_from_a_folder_outside_the_repository() {
    let dir = tempdir("bench-link");
    let out = gridrt(&dir)
        .args(["bench", "link", "--out-dir", "D", "--width", "64", "--height", "48", "--devices", "1,2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["link.csv", "link_multi.csv", "link.svg", "link.json"] {
        assert!(std::fs::metadata(dir.join("D").join(f)).unwrap().len() > 0, "{f}");
    }
    // The scene names stay one CSV field each.
    let csv = std::fs::read_to_string(dir.join("D/link.csv")).unwrap();
    let header_fields = csv.lines().next().unwrap().split(',').count();
    assert!(csv.lines().all(|l| l.split(',').count() == header_fields), "{csv}");
    let _ = std::fs::remove_dir_all(&dir);
}
