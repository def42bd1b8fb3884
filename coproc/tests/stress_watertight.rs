//! Stress: watertightness. Rays aimed exactly at the shared edges and vertices of closed
//! meshes (a subdivided icosphere and the bunny's closed regions), crossing the surface
//! there from either side, per kernel and number format; each probe is tested against the
//! disk of triangles around its aim point and settled by the exact reference
//! (`gridrt_coproc::probe`).
//!
//! The watertight kernel in f32 must have 0 leaks over ≥ 10⁶ rays. Every other
//! (kernel, format) pair's leak count is printed (run with `--nocapture`); the accuracy
//! bench writes the same counts to `accuracy.csv`.

mod common;

use common::*;
use gridrt_coproc::probe::{probe, ProbeStats};
use gridrt_coproc::{Intersector, KernelKind, NumberFormat, Record};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Probes `n` seeded rays with `is`; records are precomputed once per face.
fn run(t: &ProbeSet, is: &Intersector, n: u64, seed: u64) -> ProbeStats {
    let tris = t.mesh.triangles();
    let recs: Vec<Record> = tris.iter().map(|tri| is.precompute(tri)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut stats = ProbeStats::default();
    let mut fan = Vec::with_capacity(16);
    for _ in 0..n {
        let (ray, faces) = t.ray(&mut rng);
        fan.clear();
        fan.extend(faces.iter().map(|&f| (tris[f], recs[f])));
        stats.add(probe(is, &fan, &ray));
    }
    stats
}

fn sphere() -> ProbeSet {
    ProbeSet::new(icosphere(4))
}

fn bunny() -> ProbeSet {
    ProbeSet::new(load_obj(&scene_path("bun_zipper_res4.obj")))
}

#[test]
fn watertight_f32_has_no_leaks_over_a_million_rays_on_sphere_and_bunny() {
    let mut total = ProbeStats::default();
    for (name, t, n) in [("sphere", sphere(), 600_000u64), ("bunny", bunny(), 400_000)] {
        assert!(
            t.edge_count() > 500 && t.vertex_count() > 300,
            "{name}: {} edges, {} fans",
            t.edge_count(),
            t.vertex_count()
        );
        let (lo, hi) = t.mesh.bounds();
        let is = Intersector::new(
            KernelKind::Watertight,
            NumberFormat::F32,
            gridrt_coproc::FixedFrame::for_box(lo.to_array(), hi.to_array(), NumberFormat::F32).unwrap(),
        );
        let s = run(&t, &is, n, 0x3A7E_0001);
        println!("{name}: watertight f32: {s:?}");
        assert_eq!(s.leaks, 0, "{name}: watertight f32 leaked: {s:?}");
        assert_eq!(s.overflows, 0);
        total.rays += s.rays;
        total.outside += s.outside;
    }
    assert!(total.rays >= 1_000_000);
    // The probes are meaningful: every ray crosses its disk exactly.
    assert_eq!(total.outside, 0, "{total:?}");
}

/// Every kernel in every format on both meshes: leaks are reported (printed), and the
/// watertight kernel stays crack-free in fixed point too (a shared edge's fixed-point edge
/// function is exactly negated in its neighbour, see `isect::watertight`).
#[test]
fn leaks_of_every_kernel_and_format_are_reported() {
    println!(
        "{:<8} {:<16} {:<12} {:>8} {:>7} {:>9} {:>10}",
        "mesh", "kernel", "format", "rays", "leaks", "overflows", "leak rate"
    );
    for (name, t) in [("sphere", sphere()), ("bunny", bunny())] {
        let (lo, hi) = t.mesh.bounds();
        for is in intersectors(lo, hi) {
            let s = run(&t, &is, 100_000, 0x3A7E_0002);
            println!(
                "{name:<8} {:<16} {:<12} {:>8} {:>7} {:>9} {:>10.2e}",
                is.kind.name(),
                is.format.name(),
                s.rays,
                s.leaks,
                s.overflows,
                s.leak_rate()
            );
            assert_eq!(s.overflows, 0, "{name} {is:?}: the mesh's own frame never overflows");
            if is.kind == KernelKind::Watertight {
                assert_eq!(s.leaks, 0, "{name} {is:?}");
            }
        }
    }
}
