//! The fast native path (`gridrt_host::native`) answers every ray with the same result words
//! as the firmware's list builder plus the co-processor model's `trace_untimed` (the fast native path):
//! whole frames of primary rays on several scenes, and seeded random rays aimed at vertices
//! and edges, axis-aligned and with tiny direction components, Closest and Any, bounded and
//! unbounded, with the AVX2 filter and with the portable one.

use gridrt_coproc::{CoprocConfig, Coprocessor, KernelKind, RayKind, TimingProfile, LIST_CAPACITY};
use gridrt_firmware::camera::Camera;
use gridrt_firmware::dda::{build_list, GridDesc, TraversalList};
use gridrt_host::grid::{GridParams, PeMapping};
use gridrt_host::native::{grid_desc, NativeScene, Trace};
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::math::{Ray, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn scene_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)
}

/// A scene with its grid, the co-processor model loaded with its PE images, and the fast
/// path's layout of the same data.
struct Fixture {
    prepared: PreparedScene,
    desc: GridDesc,
    backing: Vec<u32>,
    config: CoprocConfig,
}

impl Fixture {
    fn new(name: &str, params: &GridParams) -> Self {
        let scene = gridrt_host::scene::load(&scene_path(name)).unwrap();
        let prepared = PreparedScene::new(scene, params).unwrap();
        let grid = &prepared.grid;
        let config = CoprocConfig {
            pe_count: grid.pe_count,
            pe_mem_words: grid.max_pe_words().max(1) as u32,
            max_list: LIST_CAPACITY as u16,
            timing: TimingProfile::GRIDRT,
            kernel: KernelKind::Watertight,
        };
        let backing = vec![0u32; config.required_backing_words()];
        let desc = grid_desc(grid);
        Self { prepared, desc, backing, config }
    }

    /// Runs `f` with the loaded model and the native scene (AVX2 where available, then
    /// portable).
    fn with(&mut self, mut f: impl FnMut(&Coprocessor<'_>, &NativeScene, &GridDesc, &[u8])) {
        let grid = &self.prepared.grid;
        let mut coproc = Coprocessor::new(self.config, &mut self.backing).unwrap();
        for (pe, words) in grid.pe_images.iter().enumerate() {
            coproc.load_pe(pe as u8, words).unwrap();
        }
        let mut native = NativeScene::from_grid(grid).unwrap();
        for portable in [false, true] {
            native.set_portable(portable);
            f(&coproc, &native, &self.desc, &grid.owners);
        }
    }
}

/// The model's answer: the firmware's list over `[0, t_max]`, then `trace_untimed`.
fn model(coproc: &Coprocessor<'_>, desc: &GridDesc, owners: &[u8], kind: RayKind, ray: &Ray, t_max: f32) -> Trace {
    let mut list = TraversalList::new();
    build_list(desc, owners, ray, 0.0, t_max, &mut list);
    if list.is_empty() {
        return Trace::Culled;
    }
    Trace::Result(coproc.trace_untimed(kind, ray, t_max, &list).unwrap())
}

fn words(t: &Trace) -> Option<[u32; 8]> {
    match t {
        Trace::Culled => None,
        Trace::Result(r) => Some(r.to_words()),
    }
}

/// Every pixel of a frame of the scene's default camera; returns (hits, culled).
fn check_frame(name: &str, params: &GridParams, w: u32, h: u32) -> (u64, u64) {
    check_frame_from(name, params, w, h, None)
}

/// Every pixel of a frame, from the scene's camera or from `eye` looking at the scene's
/// target; returns (hits, culled). Also checks that the frame's footprint traced every pixel
/// the model sends a ray for.
fn check_frame_from(name: &str, params: &GridParams, w: u32, h: u32, eye: Option<Vec3>) -> (u64, u64) {
    let mut fx = Fixture::new(name, params);
    let mut totals = (0, 0);
    // The scene's own camera (the default one for a mesh file).
    let settings = fx.prepared.scene.settings.with_size(w as u16, h as u16);
    let c = settings.camera;
    let camera = Camera::new(
        eye.unwrap_or(Vec3::from_array(c.eye)),
        Vec3::from_array(c.target),
        Vec3::from_array(c.up),
        c.fov_y_deg,
        w,
        h,
    )
    .unwrap();
    fx.with(|coproc, native, desc, owners| {
        let mut row = Vec::new();
        totals = (0, 0);
        let frame = native.frame(&camera, w, h);
        for y in 0..h {
            row.clear();
            native.trace_row(&frame, y, &mut row);
            for (x, got) in row.iter().enumerate() {
                let ray = camera.primary_ray(x as u32, y);
                let want = model(coproc, desc, owners, RayKind::Closest, &ray, f32::INFINITY);
                assert_eq!(words(got), words(&want), "{name}: pixel ({x}, {y}), avx2 {}", native.uses_avx2());
                match want {
                    Trace::Culled => totals.1 += 1,
                    Trace::Result(r) => totals.0 += r.hit as u64,
                }
            }
        }
        assert!(frame.traced_pixels() >= w as u64 * h as u64 - totals.1);
    });
    totals
}

/// The frame footprint skips most of a bunny frame's empty pixels, and a camera inside the
/// grid box gets no footprint (every pixel traced) and the same answers.
#[test]
fn frame_footprint_skips_empty_pixels_and_is_off_inside_the_box() {
    let fx = Fixture::new("bun_zipper_res2.obj", &GridParams::default());
    let native = NativeScene::from_grid(&fx.prepared.grid).unwrap();
    let c = fx.prepared.scene.settings.with_size(160, 120).camera;
    let camera =
        Camera::new(Vec3::from_array(c.eye), Vec3::from_array(c.target), Vec3::from_array(c.up), c.fov_y_deg, 160, 120)
            .unwrap();
    let traced = native.frame(&camera, 160, 120).traced_pixels();
    assert!(traced < 160 * 120 / 2, "{traced} pixels traced");
    let b = fx.prepared.grid.bounds;
    let inside = (Vec3::from_array(b.min) + Vec3::from_array(b.max)) * 0.5 + Vec3::new(0.0, 0.0, 1e-3);
    let inside_cam = Camera::new(inside, Vec3::from_array(c.target), Vec3::from_array(c.up), 60.0, 160, 120).unwrap();
    assert_eq!(native.frame(&inside_cam, 160, 120).traced_pixels(), 160 * 120);
    let (hits, _) = check_frame_from("bun_zipper_res2.obj", &GridParams::default(), 96, 64, Some(inside));
    assert!(hits > 1000, "{hits}");
}

#[test]
fn native_path_equals_model_on_every_pixel_of_bunny_teapot_suzanne_cornell() {
    let params = GridParams::default();
    for name in ["bun_zipper_res2.obj", "teapot.obj", "suzanne.obj", "cornell_box.obj"] {
        let (hits, culled) = check_frame(name, &params, 160, 120);
        assert!(hits > 1000, "{name}: {hits} hits");
        assert!(culled > 0 || name == "cornell_box.obj", "{name}");
    }
}

#[test]
fn native_path_equals_model_with_finer_grid_and_slab_mapping() {
    let params = GridParams { m: 2.5, pe_count: 3, mapping: PeMapping::Slabs, ..GridParams::default() };
    let (hits, _) = check_frame("bun_zipper_res2.obj", &params, 128, 96);
    assert!(hits > 1000);
}

/// Scene image v2: voxels holding analytic primitives take the ordered path.
#[test]
fn native_path_equals_model_on_analytic_primitives() {
    let (hits, _) = check_frame("viray_demo.toml", &GridParams::default(), 160, 120);
    assert!(hits > 5000, "{hits}");
}

/// Points on the scene's triangles that make rays graze: vertices, edge points (some exactly
/// at edge midpoints), interior points.
fn targets(fx: &Fixture, rng: &mut ChaCha8Rng, n: usize) -> Vec<Vec3> {
    let tris = &fx.prepared.scene.mesh.triangles;
    (0..n)
        .map(|_| {
            let t = &tris[rng.gen_range(0..tris.len())];
            let v = t.v.map(Vec3::from_array);
            match rng.gen_range(0..4) {
                0 => v[rng.gen_range(0..3)],
                1 => (v[0] + v[1]) * 0.5,
                2 => {
                    let s: f32 = rng.gen_range(0.0..1.0);
                    v[1] + (v[2] - v[1]) * s
                }
                _ => {
                    let (a, b): (f32, f32) = (rng.gen_range(0.0..0.5), rng.gen_range(0.0..0.5));
                    v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b
                }
            }
        })
        .collect()
}

#[test]
fn native_path_equals_model_on_seeded_rays_at_vertices_and_edges() {
    for (name, seed) in [("bun_zipper_res2.obj", 0x5EED_0001u64), ("teapot.obj", 0x5EED_0002), ("suzanne.obj", 3)] {
        let mut fx = Fixture::new(name, &GridParams::default());
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let aims = targets(&fx, &mut rng, 6000);
        let b = fx.prepared.grid.bounds;
        let (lo, hi) = (Vec3::from_array(b.min), Vec3::from_array(b.max));
        let ext = hi - lo;
        let mut cases = Vec::new();
        for target in aims {
            // Origins outside the box, inside it, and on the target's axis lines.
            let origin = match rng.gen_range(0..4) {
                0 => lo - ext * 0.5 + ext * 2.0 * Vec3::new(rng.gen(), rng.gen(), rng.gen()),
                1 => lo + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen()),
                2 => {
                    // Axis-aligned ray (two zero direction components).
                    let mut o = target;
                    let a = rng.gen_range(0..3);
                    o[a] = if rng.gen() { lo[a] - ext[a] } else { hi[a] + ext[a] };
                    o
                }
                _ => {
                    // One zero and one tiny (subnormal-reciprocal-prone) component.
                    let mut o = lo - ext * 0.5 + ext * 2.0 * Vec3::new(rng.gen(), rng.gen(), rng.gen());
                    let a = rng.gen_range(0..3);
                    o[a] = target[a];
                    let b2 = (a + 1) % 3;
                    o[b2] = target[b2] - f32::from_bits(rng.gen_range(1..1000)) * if rng.gen() { 1.0 } else { -1.0 };
                    o
                }
            };
            let dir = target - origin;
            if dir == Vec3::ZERO {
                continue;
            }
            let kind = if rng.gen_bool(0.3) { RayKind::Any } else { RayKind::Closest };
            let t_max = if rng.gen_bool(0.3) { rng.gen_range(0.2f32..1.2) } else { f32::INFINITY };
            cases.push((Ray { origin, dir }, kind, t_max));
        }
        let mut hits = 0;
        fx.with(|coproc, native, desc, owners| {
            hits = 0;
            for (i, (ray, kind, t_max)) in cases.iter().enumerate() {
                let want = model(coproc, desc, owners, *kind, ray, *t_max);
                let got = native.trace(*kind, ray, *t_max);
                assert_eq!(words(&got), words(&want), "{name}: case {i}: {ray:?} {kind:?} t_max {t_max}");
                hits += matches!(want, Trace::Result(r) if r.hit) as u32;
            }
        });
        assert!(hits > 2000, "{name}: {hits} of {} rays hit", cases.len());
    }
}

/// Malformed inputs are refused when the scene is laid out, not met ray by ray.
#[test]
fn native_scene_refuses_a_map_naming_a_pe_without_the_voxel() {
    let fx = Fixture::new("bun_zipper_res2.obj", &GridParams::default());
    let grid = &fx.prepared.grid;
    let mut owners = grid.owners.clone();
    let v = owners.iter().position(|&p| p != gridrt_shared::scene::EMPTY_VOXEL).unwrap();
    owners[v] = (owners[v] + 1) % grid.pe_count as u8;
    let err = NativeScene::new(&fx.desc, &owners, &grid.pe_images).unwrap_err();
    assert!(matches!(err, gridrt_host::native::NativeError::NotHeld { .. }), "{err}");
    assert!(NativeScene::new(&fx.desc, &owners[1..], &grid.pe_images).is_err());
}
