//! Issue-2 property: the grid + co-processor path finds the brute-force nearest triangle.
//!
//! The host builds the grid and PE images of a real mesh, the firmware's 3D-DDA makes each
//! ray's traversal list, and the co-processor model answers it; brute force runs the same
//! intersection kernel over every triangle. They must agree on the nearest triangle except for
//! exact ties (two triangles hit at the same t, e.g. on a shared edge).

use std::path::Path;

use gridrt_coproc::{CoprocConfig, Coprocessor, KernelKind};
use gridrt_firmware::dda::{build_list, GridDesc, TraversalList};
use gridrt_host::grid::GridParams;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::fsl::RayKind;
use gridrt_shared::math::{Ray, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn prepared(scene: &str, pe_count: u16) -> PreparedScene {
    let mesh = gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(scene)).unwrap();
    PreparedScene::new(mesh, &GridParams { pe_count, m: 2.0, ..Default::default() }).unwrap()
}

fn coprocessor<'m>(p: &PreparedScene, backing: &'m mut Vec<u32>) -> Coprocessor<'m> {
    let config = CoprocConfig {
        pe_count: p.grid.pe_count,
        pe_mem_words: p.grid.pe_mem_words,
        max_list: 1024,
        ..CoprocConfig::GRIDRT
    };
    let config = CoprocConfig { kernel: KernelKind::default(), ..config };
    backing.resize(config.required_backing_words(), 0);
    let mut c = Coprocessor::new(config, backing).unwrap();
    for (pe, words) in p.grid.pe_images.iter().enumerate() {
        c.load_pe(pe as u8, words).unwrap();
    }
    c
}

fn grid_desc(p: &PreparedScene) -> GridDesc {
    let b = p.grid.bounds;
    GridDesc { min: Vec3::from(b.min), max: Vec3::from(b.max), dims: p.grid.dims.map(u32::from) }
}

/// Random rays of four kinds: general, axis-aligned, grazing (nearly parallel to a random
/// triangle's plane, aimed at it), and origins inside the grid.
fn random_ray(rng: &mut ChaCha8Rng, p: &PreparedScene) -> Ray {
    let b = p.grid.mesh_bounds;
    let lo = Vec3::from(b.min);
    let hi = Vec3::from(b.max);
    let size = hi - lo;
    let inside = |rng: &mut ChaCha8Rng| lo + size * Vec3::new(rng.gen(), rng.gen(), rng.gen());
    let outside = |rng: &mut ChaCha8Rng| {
        (lo + hi) * 0.5 + size * 1.5 * (Vec3::new(rng.gen(), rng.gen(), rng.gen()) - 0.5).normalize_or_zero() * 1.2
    };
    match rng.gen_range(0..4) {
        0 => {
            let o = outside(rng);
            Ray { origin: o, dir: inside(rng) - o }
        }
        1 => {
            let o = inside(rng);
            let mut d = Vec3::ZERO;
            d[rng.gen_range(0..3)] = if rng.gen() { 1.0 } else { -1.0 };
            Ray { origin: o - d * size.max_element() * 2.0, dir: d }
        }
        2 => {
            let t = &p.scene.mesh.triangles[rng.gen_range(0..p.scene.mesh.triangles.len())];
            let v = t.v.map(Vec3::from);
            let (u, w): (f32, f32) = (rng.gen(), rng.gen());
            let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
            let target = v[0] + (v[1] - v[0]) * u + (v[2] - v[0]) * w;
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            let along = (v[1] - v[0]).normalize_or_zero();
            let dir = along + n * rng.gen_range(-1e-3..1e-3);
            Ray { origin: target - dir * size.max_element(), dir }
        }
        _ => Ray {
            origin: inside(rng),
            dir: Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)),
        },
    }
}

#[test]
fn grid_and_coprocessor_find_the_brute_force_nearest_triangle_for_1e5_random_rays() {
    let p = prepared("bun_zipper_res4.obj", 4);
    let mut backing = Vec::new();
    let c = coprocessor(&p, &mut backing);
    let grid = grid_desc(&p);
    let tris: Vec<[Vec3; 3]> = p.scene.mesh.triangles.iter().map(|t| t.v.map(Vec3::from)).collect();
    let kernel = KernelKind::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6d1d_2010);
    let mut list = TraversalList::new();
    let (mut hits, mut ties, mut mismatches) = (0u32, 0u32, Vec::new());
    for _ in 0..100_000 {
        let ray = random_ray(&mut rng, &p);
        if !ray.is_valid() {
            continue;
        }
        build_list(&grid, &p.grid.owners, &ray, 0.0, f32::INFINITY, &mut list);
        let r = c.trace_untimed(RayKind::Closest, &ray, f32::INFINITY, &list).unwrap();
        let got = r.hit.then_some((r.prim, r.t));
        let mut best: Option<(u32, f32)> = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some(th) = kernel.intersect_once(&ray, t, best.map_or(f32::INFINITY, |b| b.1)) {
                if best.is_none_or(|b| th < b.1) {
                    best = Some((i as u32, th));
                }
            }
        }
        match (got, best) {
            (None, None) => {}
            (Some(g), Some(b)) if g.0 == b.0 => hits += 1,
            // Exact tie: another triangle hit at the same distance.
            (Some(g), Some(b)) if g.1 == b.1 => ties += 1,
            other => mismatches.push((ray, other)),
        }
    }
    assert!(hits > 10_000, "enough rays hit the bunny: {hits}");
    assert!(mismatches.is_empty(), "{} mismatches ({ties} ties), first: {:?}", mismatches.len(), mismatches.first());
}

#[test]
fn answers_do_not_depend_on_the_pe_count_for_a_scene_that_fits_one_pe() {
    let one = prepared("bun_zipper_res4.obj", 1);
    let mut backing1 = Vec::new();
    let c1 = coprocessor(&one, &mut backing1);
    let grid = grid_desc(&one);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let rays: Vec<Ray> = (0..20_000).map(|_| random_ray(&mut rng, &one)).filter(Ray::is_valid).collect();
    let answers = |p: &PreparedScene, c: &Coprocessor| -> Vec<(bool, u32, u32)> {
        let mut list = TraversalList::new();
        rays.iter()
            .map(|ray| {
                build_list(&grid, &p.grid.owners, ray, 0.0, f32::INFINITY, &mut list);
                let r = c.trace_untimed(RayKind::Closest, ray, f32::INFINITY, &list).unwrap();
                (r.hit, r.prim, r.t.to_bits())
            })
            .collect()
    };
    let base = answers(&one, &c1);
    assert!(base.iter().filter(|a| a.0).count() > 1000);
    for pes in [2u16, 3, 4, 8] {
        let p = prepared("bun_zipper_res4.obj", pes);
        assert_eq!(
            p.grid.owners.iter().filter(|&&o| o != 0xFF).count(),
            one.grid.owners.iter().filter(|&&o| o != 0xFF).count()
        );
        let mut backing = Vec::new();
        let c = coprocessor(&p, &mut backing);
        assert_eq!(answers(&p, &c), base, "{pes} PEs");
    }
}
