//! Issue-2 acceptance: `gridrt render --sim --reference` through the real binary.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
}

fn render_sim(scene: &str, extra: &[&str]) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("gridrt-cli-{}-{}", std::process::id(), scene.replace('.', "_")));
    // Output folders that do not exist yet: the CLI creates them before rendering.
    let png = dir.join("images/out.png");
    let json = dir.join("stats/stats.json");
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--sim", "--scene"])
        .arg(scenes().join(scene))
        .arg("--out")
        .arg(&png)
        .arg("--stats")
        .arg(&json)
        .arg("--reference")
        .args(extra)
        .output()
        .unwrap();
    assert!(out.status.success(), "gridrt failed: {}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::metadata(&png).unwrap().len() > 0, "PNG written");
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    stats
}

/// PSNR ≥ 50 dB (or identical) and hit mismatches ≤ 0.1 % of primary rays.
fn assert_matches_reference(stats: &serde_json::Value) {
    let primary = stats["primary_rays"].as_u64().unwrap();
    assert_eq!(primary, 320 * 240, "default size is 320×240");
    let identical = stats["identical"].as_bool().unwrap();
    let psnr = stats["psnr_db"].as_f64();
    assert!(identical || psnr.is_some_and(|p| p >= 50.0), "psnr {psnr:?}");
    let mismatches = stats["hit_mismatches"].as_u64().unwrap();
    assert!(mismatches * 1000 <= primary, "{mismatches} hit mismatches of {primary} primary rays");
    for key in [
        "rays",
        "fsl_words",
        "intersection_tests",
        "coproc_cycles",
        "uart_bytes",
        "wall_ms",
        "max_abs_diff",
        "differing_pixels",
    ] {
        assert!(!stats[key].is_null(), "stats has {key}");
    }
    assert!(stats["intersection_tests"].as_u64().unwrap() > 0);
    assert!(stats["coproc_cycles"].as_u64().unwrap() > 0);
}

#[test]
fn render_sim_of_bunny_res4_matches_the_f64_reference() {
    assert_matches_reference(&render_sim("bun_zipper_res4.obj", &[]));
}

#[test]
fn render_sim_of_the_69k_triangle_bunny_matches_the_f64_reference() {
    let stats = render_sim("stanford-bunny.obj", &[]);
    assert_eq!(stats["grid"], serde_json::json!([45, 45, 35]), "Eq. 6.1 at m = 1");
    assert_matches_reference(&stats);
    let capped = render_sim("stanford-bunny.obj", &["--width", "16", "--height", "12", "--grid-max-voxels", "2048"]);
    assert_eq!(capped["grid"], serde_json::json!([14, 13, 11]), "Eq. 6.1 within 2048 voxels");
}

#[test]
fn render_sim_without_shadows_sends_no_shadow_rays() {
    let stats = render_sim("bun_zipper_res4.obj", &["--no-shadows"]);
    assert_eq!(stats["shadow_rays"].as_u64(), Some(0));
    assert_eq!(stats["rays"], stats["primary_rays"]);
}

#[test]
fn malformed_scene_is_a_clear_error_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("gridrt-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt"))
        .args(["render", "--sim", "--scene"])
        .arg(&bad)
        .arg("--out")
        .arg(dir.join("x.png"))
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2"), "error names the line: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Accuracy: the default configuration (watertight f32) reaches ≥ 50 dB on every bundled scene.
#[test]
fn default_configuration_matches_the_reference_on_every_bundled_scene() {
    for scene in [
        "bun_zipper_res3.obj",
        "bun_zipper_res2.obj",
        "teapot.obj",
        "suzanne.obj",
        "cornell_box.obj",
        "bun_zipper_res4.ply",
    ] {
        let stats = render_sim(scene, &[]);
        let identical = stats["identical"].as_bool().unwrap();
        let psnr = stats["psnr_db"].as_f64();
        assert!(identical || psnr.is_some_and(|p| p >= 50.0), "{scene}: psnr {psnr:?}");
    }
}
