//! Builds the end-to-end tests need, in the repository: `cargo` in the `test` profile (`cargo
//! test` has already built every dependency with it, so only the binaries are compiled) and
//! the `gridrt` binary, built once per test process.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::{Mutex, OnceLock};

/// Builds share cargo's output paths: one at a time.
pub static BUILD: Mutex<()> = Mutex::new(());

/// The repository's root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().expect("repo root")
}

/// `cargo SUBCOMMAND --quiet --profile test`, run in the repository.
pub fn cargo(subcommand: &str) -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(repo_root()).args([subcommand, "--quiet", "--profile", "test"]);
    c
}

/// The stdout of a command that must have succeeded; else a panic naming `what`, with both
/// streams.
pub fn check(out: Output, what: &str) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{what} failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The `gridrt` binary (test profile), built once.
pub fn gridrt() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let _guard = BUILD.lock().unwrap_or_else(|e| e.into_inner());
        let out = cargo("build")
            .args(["--package", "gridrt-host", "--bin", "gridrt", "--message-format=json-render-diagnostics"])
            .output()
            .unwrap();
        assert!(out.status.success(), "cargo build --bin gridrt failed:\n{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|v| v["reason"] == "compiler-artifact" && v["target"]["name"] == "gridrt")
            .find_map(|v| v["executable"].as_str().map(PathBuf::from))
            .expect("cargo reports the gridrt executable")
    })
}

/// Runs `gridrt ARGS` in the repository; its stdout.
pub fn run_gridrt(args: &[&str]) -> String {
    let out = Command::new(gridrt()).args(args).current_dir(repo_root()).output().unwrap();
    check(out, &format!("gridrt {}", args.join(" ")))
}
