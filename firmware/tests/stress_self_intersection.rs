//! Stress: self-intersection ("acne"). Hits on a sphere mesh and on the bunny are computed
//! with every kernel in every number format; from each hit point the firmware spawns a
//! shadow ray and a reflection ray with its own offset rule (`shade::shadow_ray`,
//! `shade::shadow_epsilon`: ε = 1e-4·|grid diagonal| + 2⁻²⁰·|p|∞ along the facing normal).
//! Neither may hit the triangle it starts on (pinned for every kernel in f32 and
//! fixed64-q23, and for Wald / Hanika–Keller in fixed32-q16; the vertex-based kernels in
//! fixed32-q16 have acne — see the assertion). The same rays spawned *without* the offset
//! are also counted, to show each kernel's own robustness; those rates are printed, not
//! pinned (`cargo test -p gridrt-firmware --test stress_self_intersection -- --nocapture`).

#[path = "../../coproc/tests/common/mod.rs"]
mod common;

use common::*;
use gridrt_coproc::{Intersector, KernelKind, NumberFormat};
use gridrt_firmware::shade;
use gridrt_shared::math::{Ray, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[derive(Debug, Default, Clone, Copy)]
struct Acne {
    hits: u32,
    shadow: u32,
    reflect: u32,
    shadow_raw: u32,
    reflect_raw: u32,
}

fn run(mesh: &Mesh, is: &Intersector, n: u32, seed: u64) -> Acne {
    let (lo, hi) = mesh.bounds();
    let (c, r) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
    let diag = (hi - lo).length();
    let tris = mesh.triangles();
    let recs: Vec<_> = tris.iter().map(|t| is.precompute(t)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut a = Acne::default();
    let own = |ray: &Ray, f: usize, t_max: f32| matches!(is.intersect(ray, &recs[f], t_max), Ok(Some(_)));
    while a.hits < n {
        let f = rng.gen_range(0..tris.len());
        let t = tris[f];
        let (b1, b2) = (rng.gen_range(0.05f32..0.45), rng.gen_range(0.05f32..0.45));
        let target = t[0] + (t[1] - t[0]) * b1 + (t[2] - t[0]) * b2;
        let ray = aim(shell_point(&mut rng, c, 1.5 * r, 4.0 * r), target);
        let Ok(Some(th)) = is.intersect(&ray, &recs[f], f32::INFINITY) else { continue };
        a.hits += 1;
        // The firmware's shading path: hit point, facing normal, offset origins.
        let p = shade::hit_point(&ray, th);
        let n_geo = (t[1] - t[0]).cross(t[2] - t[0]);
        let Some(nf) = shade::facing_normal(n_geo.to_array(), ray.dir) else { continue };
        let light = shell_point(&mut rng, c, 2.0 * r, 5.0 * r);
        // Shadow ray toward a light on the lit side (flip the light through the plane if needed).
        let light = if (light - p).dot(nf) > 0.0 { light } else { light - nf * (2.0 * (light - p).dot(nf)) };
        let sray = shade::shadow_ray(p, nf, light, diag);
        a.shadow += own(&sray, f, shade::SHADOW_T_MAX) as u32;
        let raw = Ray { origin: p, dir: light - p };
        a.shadow_raw += own(&raw, f, shade::SHADOW_T_MAX) as u32;
        // Mirror reflection with the same offset rule.
        let d = ray.dir - nf * (2.0 * ray.dir.dot(nf));
        let rray = Ray { origin: p + nf * shade::shadow_epsilon(diag, p), dir: d };
        a.reflect += own(&rray, f, f32::INFINITY) as u32;
        a.reflect_raw += own(&Ray { origin: p, dir: d }, f, f32::INFINITY) as u32;
    }
    a
}

#[test]
fn spawned_shadow_and_reflection_rays_never_rehit_their_own_triangle() {
    println!(
        "{:<7} {:<16} {:<12} {:>6} {:>7} {:>8} {:>12} {:>13}",
        "mesh", "kernel", "format", "hits", "shadow", "reflect", "shadow(raw)", "reflect(raw)"
    );
    let sphere = icosphere(4);
    let bunny = load_obj(&scene_path("bun_zipper_res4.obj"));
    // The same sphere 10^4 sizes from the origin: the 2^-20·|p| term of the offset matters.
    let far = sphere.map(|v| v + Vec3::new(1.0e4, -2.0e4, 5.0e3));
    for (name, mesh) in [("sphere", &sphere), ("bunny", &bunny), ("far", &far)] {
        let (lo, hi) = mesh.bounds();
        for is in intersectors(lo, hi) {
            let a = run(mesh, &is, 10_000, 0xAC4E);
            let pct = |x: u32| 100.0 * x as f64 / a.hits as f64;
            println!(
                "{name:<7} {:<16} {:<12} {:>6} {:>7} {:>8} {:>11.2}% {:>12.2}%",
                is.kind.name(),
                is.format.name(),
                a.hits,
                a.shadow,
                a.reflect,
                pct(a.shadow_raw),
                pct(a.reflect_raw)
            );
            // Pinned: no acne with the firmware's offset in f32 and fixed64-q23 (every kernel)
            // and for the plane-first kernels in fixed32-q16. The vertex-based kernels in
            // fixed32-q16 (watertight, Möller–Trumbore, Cramer) do show acne: their t, a
            // ratio of products rounded to 2^-16, is off by up to ~10^-3 relative, more than
            // ε — reported above, and the reason that format is not a default.
            let q16_vertex = is.format == NumberFormat::Fixed32Q16
                && matches!(is.kind, KernelKind::Watertight | KernelKind::MollerTrumbore | KernelKind::Cramer);
            if !q16_vertex {
                assert_eq!((a.shadow, a.reflect), (0, 0), "{name} {is:?}: acne with the firmware offset: {a:?}");
            }
        }
    }
}
