//! Point clouds, accepted: point clouds the project has never seen (sampled from analytic
//! surfaces with a seeded generator, written as ASCII and binary PLY with normals and no
//! radius) render through the real binary as splats, within 30 dB of the same points
//! ray-traced as disks; sort-last over two simulated boards gives the one-board image; bad
//! PLY files are errors, never panics.

use std::path::{Path, PathBuf};
use std::process::Command;

use gridrt_host::points::{self, synthetic, Input};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gridrt-points-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn gridrt(args: &[&str], cwd: &Path) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_gridrt")).args(args).current_dir(cwd).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.success(), text)
}

/// Writes a fresh cloud of `n` points (seed `seed`) as PLY; returns its path.
fn cloud_file(d: &Path, n: usize, seed: u64, binary: bool) -> PathBuf {
    let path = d.join(if binary { "cloud_bin.ply" } else { "cloud_ascii.ply" });
    std::fs::write(&path, synthetic::write_ply(&synthetic::torus_and_sphere(n, seed), binary)).unwrap();
    path
}

fn splat_with_reference(binary: bool, seed: u64) {
    let d = dir(if binary { "bin" } else { "ascii" });
    let ply = cloud_file(&d, 8000, seed, binary);
    let p = |s: &str| d.join(s).display().to_string();
    let (ok, log) = gridrt(
        &[
            "render",
            "--sim",
            "--scene",
            &ply.display().to_string(),
            "--out",
            &p("s.png"),
            "--stats",
            &p("s.json"),
            "--reference",
        ],
        &d,
    );
    assert!(ok, "{log}");
    eprintln!("{log}");
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    let psnr = stats["psnr_db"].as_f64().expect("psnr_db in the stats");
    let traced = stats["splat"]["psnr_vs_traced_disks_db"].as_f64().expect("PSNR against the traced disks");
    assert!(psnr >= 30.0 && traced >= 30.0, "PSNR {psnr} dB vs f64 disks, {traced} dB vs device-traced disks");
    assert_eq!(stats["splat"]["radius_from"], "density");
    assert_eq!(stats["splat"]["points"], 8000);
    assert!(stats["splat"]["codewords"].as_u64().unwrap() > 4000, "{}", stats["splat"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn unseen_ascii_cloud_without_radius_splats_within_30_db_of_the_traced_disks() {
    splat_with_reference(false, 0xC10D_0001);
}

#[test]
fn unseen_binary_cloud_without_radius_splats_within_30_db_of_the_traced_disks() {
    splat_with_reference(true, 0xC10D_0002);
}

fn render_png(d: &Path, ply: &Path, name: &str, extra: &[&str]) -> Vec<u8> {
    let out = d.join(name);
    let mut args = vec!["render", "--scene"];
    let ply_s = ply.display().to_string();
    let out_s = out.display().to_string();
    args.extend([ply_s.as_str(), "--out", out_s.as_str(), "--width", "160", "--height", "120"]);
    args.extend(extra);
    let (ok, log) = gridrt(&args, d);
    assert!(ok, "{log}");
    std::fs::read(out).unwrap()
}

#[test]
fn sort_last_on_two_simulated_boards_is_byte_identical_to_one_board() {
    let d = dir("sortlast");
    let ply = cloud_file(&d, 4000, 0xC10D_0003, true);
    for extra in [&[][..], &["--pixel-depth"][..]] {
        let one = render_png(&d, &ply, "one.png", &[&["--sim"][..], extra].concat());
        let two = render_png(&d, &ply, "two.png", &[&["--sim-devices", "2", "--split", "points"][..], extra].concat());
        let rows = render_png(&d, &ply, "rows.png", &[&["--sim-devices", "2", "--split", "rows"][..], extra].concat());
        let (a, b, c) = (image(&one), image(&two), image(&rows));
        assert_eq!(a, b, "sort-last differs from one board ({extra:?})");
        assert_eq!(a, c, "row bands differ from one board ({extra:?})");
        // Not a blank frame: the cloud is there.
        assert!(a.chunks(3).filter(|p| p != &&a[..3]).count() > 1000);
    }
    let _ = std::fs::remove_dir_all(&d);
}

fn image(png: &[u8]) -> Vec<u8> {
    image::load_from_memory(png).unwrap().to_rgb8().into_raw()
}

#[test]
fn a_mesh_renders_as_a_cloud_with_points() {
    let d = dir("mesh");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj");
    let json = d.join("m.json");
    let (ok, log) = gridrt(
        &[
            "render",
            "--sim",
            "--points",
            "--scene",
            &scene.display().to_string(),
            "--out",
            &d.join("m.png").display().to_string(),
            "--stats",
            &json.display().to_string(),
        ],
        &d,
    );
    assert!(ok, "{log}");
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // bun_zipper_res4 has 453 vertices; those of zero-area faces only have no normal.
    let n = stats["splat"]["points"].as_u64().unwrap();
    assert!((400..=453).contains(&n), "{}", stats["splat"]);
    assert!(stats["splat"]["codewords"].as_u64().unwrap() > 400, "{}", stats["splat"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn malformed_point_clouds_are_clear_errors() {
    let d = dir("bad");
    let good = synthetic::write_ply(&synthetic::torus_and_sphere(50, 1), true);
    let header_end = good.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let no_normals = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n".to_vec();
    let zero_normal = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 0\n".to_vec();
    let nan = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 0 1\n1 0 0 nan 0 1\n".to_vec();
    let bad_radius = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float radius\nend_header\n0 0 0 0 0 1 -2\n".to_vec();
    let one_point = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 0 1\n".to_vec();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("truncated", good[..header_end + 100].to_vec(), "ends inside"),
        ("no_normals", no_normals, "normals"),
        ("zero_normal", zero_normal, "normal is zero"),
        ("nan", nan, "NaN"),
        ("bad_radius", bad_radius, "not positive"),
        ("one_point", one_point, "at least 2 points"),
        ("empty", b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n".to_vec(), "no vertices"),
    ];
    for (name, bytes, want) in cases {
        let path = d.join(format!("{name}.ply"));
        std::fs::write(&path, bytes).unwrap();
        let e = points::load(&path, false).map(|i| matches!(i, Input::Cloud(_))).unwrap_err().to_string();
        assert!(e.contains(want), "{name}: {e}");
        let (ok, log) = gridrt(
            &[
                "render",
                "--sim",
                "--scene",
                &path.display().to_string(),
                "--out",
                &d.join("x.png").display().to_string(),
            ],
            &d,
        );
        assert!(!ok && log.contains(want) && !log.contains("panicked"), "{name}: {log}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
