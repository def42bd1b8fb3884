//! The bench on a small scene, and its Pareto front.

use gridrt_coproc::{KernelKind, NumberFormat};

use super::*;

#[test]
fn pareto_front_keeps_only_non_dominated_points() {
    let pts = [(1.0, 5.0), (2.0, 2.0), (3.0, 3.0), (4.0, 1.0), (2.0, 2.0), (0.5, 9.0)];
    // (3, 3) is dominated by (2, 2); the duplicate (2, 2) points do not dominate each other.
    assert_eq!(pareto_front(&pts), vec![5, 0, 1, 4, 3]);
}

/// A small end-to-end run: the cornell box (few triangles) at 32×24, two configurations.
#[test]
fn bench_runs_on_a_small_scene_and_writes_csv_and_svg() {
    let mut opts = AccuracyOptions::new();
    opts.scenes = vec![scenes_dir().join("cornell_box.obj")];
    opts.width = 32;
    opts.height = 24;
    opts.kernels = vec![KernelKind::Watertight, KernelKind::HanikaKeller];
    opts.formats = vec![NumberFormat::F32, NumberFormat::Fixed32Q16];
    opts.runs = 1;
    opts.probes = 500;
    opts.threads = 1;
    let mut events = 0;
    let rows = run(&opts, &mut |_| events += 1).unwrap();
    assert_eq!(rows.len(), 4);
    assert_eq!(events, 5);
    let wt = &rows[0];
    assert_eq!((wt.kernel, wt.format, wt.leaks, wt.overflows), ("watertight", "f32", 0, 0));
    assert!(wt.psnr_db.is_none_or(|p| p > 40.0), "{wt:?}");
    assert!(wt.probes > 0 && wt.rays > 0 && wt.native_ns_per_ray > 0.0);
    let csv = to_csv(&rows);
    assert_eq!(csv.lines().count(), 5);
    assert_eq!(csv.lines().next().unwrap().split(',').count(), csv.lines().nth(1).unwrap().split(',').count());
    let dir = std::env::temp_dir().join(format!("gridrt-accuracy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_csv(&rows, &dir.join("accuracy.csv")).unwrap();
    write_plot(&rows, &dir.join("accuracy.svg")).unwrap();
    let svg = std::fs::read_to_string(dir.join("accuracy.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("Pareto front"));
    std::fs::remove_dir_all(&dir).ok();
}
