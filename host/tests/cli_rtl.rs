//! Issue-11 acceptance through the real binary: `gridrt render --sim --coproc rtl` with no
//! further flags renders the 64×48 bun_zipper_res4 frame, its stats record the kernel and
//! format, and the PNG is byte-identical to `--coproc model` with that kernel and format (with
//! `--timing rtl` even the test and cycle counts are the same). The RTL render runs the model
//! beside the RTL (`GRIDRT_RTL_LOCKSTEP=1`): every reply word of every scene ray, each RESULT
//! word included, is compared with the model's, and a difference fails the render.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj")
}

/// Renders with `flags`; returns the PNG bytes and the stats. `lockstep`: the model runs
/// beside the RTL and every reply word must be the model's.
fn render(tag: &str, flags: &[&str], lockstep: bool) -> (Vec<u8>, serde_json::Value) {
    render_scene(&scene(), ("64", "48"), tag, flags, lockstep)
}

/// The turnaround each render allows, in ms: a minute, so the host never asks for a region
/// again while the device renders it. Under load the Verilated co-processor's pauses exceeded
/// the learned pace, the host asked again, and the device's PE-cache counters counted the
/// regions rendered twice (`frame_stall_cycles` 4.1 M against the model's 0.7 M, 9 regions
/// resent, with two busy loops beside the render).
const NO_REREQUEST_MS: &str = "60000";

/// `render` of `scene` at `size`.
fn render_scene(
    scene: &Path,
    (width, height): (&str, &str),
    tag: &str,
    flags: &[&str],
    lockstep: bool,
) -> (Vec<u8>, serde_json::Value) {
    // One render at a time: on a 2-core machine, parallel co-simulations only slow each other.
    static ONE_RENDER: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one = ONE_RENDER.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("gridrt-cli-rtl-{}-{tag}", std::process::id()));
    let (png, json) = (dir.join("a.png"), dir.join("a.json"));
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--sim", "--scene"])
        .arg(scene)
        .args(["--width", width, "--height", height, "--out"])
        .arg(&png)
        .arg("--stats")
        .arg(&json)
        .args(flags)
        .args(["--turnaround", NO_REREQUEST_MS])
        .env(gridrt_loopback::LOCKSTEP_VAR, if lockstep { "1" } else { "0" })
        .output()
        .unwrap();
    assert!(out.status.success(), "gridrt {flags:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(&png).unwrap();
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // A region asked for again is rendered again: the device's cache counters would count it.
    assert_eq!(stats["link"]["regions_resent"], 0, "gridrt {flags:?}: {}", stats["link"]);
    let _ = std::fs::remove_dir_all(&dir);
    (bytes, stats)
}

#[test]
fn rtl_frame_is_byte_identical_to_the_model_with_its_kernel_and_format() {
    if !gridrt_rtl::sim::require_verilator("rtl_frame_is_byte_identical_to_the_model_with_its_kernel_and_format") {
        return;
    }
    let (rtl_png, rtl) = render("rtl", &["--coproc", "rtl"], true);
    assert_eq!(rtl["coproc"], "rtl");
    let (kernel, format) = (rtl["kernel"].as_str().unwrap(), rtl["format"].as_str().unwrap());
    assert_eq!((kernel, format), ("watertight", "fixed64-q23"));
    assert_eq!(rtl["timing"], "rtl");
    assert!(rtl["coproc_rays"].as_u64().unwrap() > 500, "the bunny must be in view: {rtl}");
    let (model_png, model) =
        render("model", &["--coproc", "model", "--kernel", kernel, "--format", format, "--timing", "rtl"], false);
    assert_eq!(model["coproc"], "model");
    assert!(rtl_png == model_png, "PNGs differ");
    for key in ["coproc_rays", "list_entries", "fsl_words", "intersection_tests", "coproc_cycles"] {
        assert_eq!(rtl[key], model[key], "{key}");
    }
}

/// `render --sim` with `flags` fails (before any output is written); its standard error.
fn refused(flags: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--sim", "--scene"])
        .arg(scene())
        .args(["--out", "/nonexistent/never.png"])
        .args(flags)
        .output()
        .unwrap();
    assert!(!out.status.success(), "{flags:?} must fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn rtl_refuses_another_kernel_or_format() {
    for flags in [
        &["--coproc", "rtl", "--format", "f32"][..],
        &["--coproc", "rtl", "--kernel", "wald"],
        &["--coproc", "rtl", "--timing", "gridrt"],
    ] {
        let err = refused(flags);
        assert!(err.contains("--coproc rtl"), "{flags:?}: {err}");
    }
}

/// PE memories beyond block RAM (rtl/README.md §4.6): bun_zipper_res3 needs more than the
/// 16 384 words per PE of block RAM; with `--pe-mem-words 1048576 --pe-cache-lines 512` the
/// RTL keeps them in its external memory behind caches and renders the frame byte-identical
/// to the model, every reply word compared (lockstep); the model's timing of those caches
/// counts the RTL's stall cycles and memory words.
#[test]
fn rtl_with_pe_caches_renders_a_scene_beyond_block_ram_like_the_model() {
    if !gridrt_rtl::sim::require_verilator("rtl_with_pe_caches_renders_a_scene_beyond_block_ram_like_the_model") {
        return;
    }
    let res3 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res3.obj");
    let words = ["--pe-mem-words", "1048576"];
    let rtl_flags = [&["--coproc", "rtl", "--pe-cache-lines", "512"][..], &words].concat();
    let (rtl_png, rtl) = render_scene(&res3, ("32", "24"), "res3-rtl", &rtl_flags, true);
    assert!(rtl["coproc_rays"].as_u64().unwrap() > 100, "the bunny must be in view: {rtl}");
    let model_flags = [
        &["--coproc", "model", "--kernel", "watertight", "--format", "fixed64-q23", "--timing", "rtl"][..],
        &["--pe-cache-lines", "512"],
        &words,
    ]
    .concat();
    let (model_png, model) = render_scene(&res3, ("32", "24"), "res3-model", &model_flags, false);
    assert!(rtl_png == model_png, "PNGs differ");
    for key in ["coproc_rays", "list_entries", "intersection_tests", "coproc_cycles"] {
        assert_eq!(rtl[key], model[key], "{key}");
    }
    // The model's timing of the caches counts what the RTL's counters count.
    for key in ["upload_stall_cycles", "frame_stall_cycles", "frame_reads", "upload_writes"] {
        assert_eq!(rtl["pe_cache"][key], model["pe_cache"][key], "{key}");
    }
}

/// `--pe-cache-lines` with `--coproc model --timing rtl`: the model's count of the cycles
/// the RTL stands still for its caches, in the upload and in the frame, and the external
/// memory's words, are the RTL's own counts (`--coproc rtl`), at two memory latencies.
#[test]
fn the_models_pe_cache_stalls_in_the_render_stats_are_the_rtls() {
    if !gridrt_rtl::sim::require_verilator("the_models_pe_cache_stalls_in_the_render_stats_are_the_rtls") {
        return;
    }
    for (lines, latency) in [("512", "8"), ("16", "1")] {
        let common = ["--pe-mem-words", "16384", "--pe-cache-lines", lines, "--pe-mem-latency", latency];
        let (_, rtl) = render_scene(
            &scene(),
            ("32", "24"),
            &format!("stall-rtl-{lines}"),
            &[&["--coproc", "rtl"][..], &common].concat(),
            false,
        );
        let model_flags = [
            &["--coproc", "model", "--kernel", "watertight", "--format", "fixed64-q23", "--timing", "rtl"][..],
            &common,
        ]
        .concat();
        let (_, model) = render_scene(&scene(), ("32", "24"), &format!("stall-model-{lines}"), &model_flags, false);
        let (r, m) = (&rtl["pe_cache"], &model["pe_cache"]);
        assert_eq!((&r["modelled"], &m["modelled"]), (&false.into(), &true.into()), "{r} {m}");
        assert!(m["frame_stall_cycles"].as_u64().unwrap() > 0, "{m}");
        for key in ["upload_stall_cycles", "frame_stall_cycles", "frame_reads", "upload_writes"] {
            assert_eq!(r[key], m[key], "{lines} lines, latency {latency}: {key}");
        }
    }
}

#[test]
fn pe_cache_lines_need_the_rtl_timeline_and_a_power_of_two() {
    for flags in [
        &["--pe-cache-lines", "512"][..],
        &["--coproc", "rtl", "--pe-cache-lines", "500"],
        &["--coproc", "rtl", "--pe-cache-lines", "4096"],
    ] {
        let err = refused(flags);
        assert!(err.contains("--pe-cache-lines"), "{flags:?}: {err}");
    }
}
