//! Shadow rays answer the same from the light's cells as from their walk: the firmware's
//! `dda::LightCells` list (a superset of the walked voxels, every `t_exit` 1) and its walk's
//! list (`WalkGrid::write_entries`), each traced as RAY_ANY by the co-processor model, give
//! the same hit bit. Origins on the meshes' vertices, edges and faces, offset as the firmware
//! offsets them, on both sides of each surface; the scenes' default lights, lights inside the
//! grid box and lights far from it.

use gridrt_coproc::{CoprocConfig, Coprocessor, KernelKind, RayKind, TimingProfile, LIST_CAPACITY};
use gridrt_firmware::dda::{fill_ahead, LightCells, VoxelMap, WalkGrid, MAX_LIST};
use gridrt_firmware::shade::{shadow_ray, SHADOW_T_MAX};
use gridrt_host::grid::GridParams;
use gridrt_host::native::grid_desc;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::fsl::{entry_from_words, ListEntry};
use gridrt_shared::math::{Ray, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn scene_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)
}

fn entries(words: &[u32], n: usize) -> Vec<ListEntry> {
    words[..2 * n].chunks(2).map(|c| entry_from_words(c[0], c[1])).collect()
}

#[test]
fn shadow_rays_from_the_light_cells_answer_as_their_walks() {
    for (name, seed) in [("bun_zipper_res4.obj", 1u64), ("teapot.obj", 2), ("cornell_box.obj", 3), ("suzanne.obj", 4)] {
        let scene = gridrt_host::scene::load(&scene_path(name)).unwrap();
        let settings = RenderSettings::default_for(&scene.bounds().unwrap());
        let prepared = PreparedScene::new(scene, &GridParams::default()).unwrap();
        let grid = &prepared.grid;
        let config = CoprocConfig {
            pe_count: grid.pe_count,
            pe_mem_words: grid.max_pe_words().max(1) as u32,
            max_list: LIST_CAPACITY as u16,
            timing: TimingProfile::GRIDRT,
            kernel: KernelKind::Watertight,
        };
        let mut backing = vec![0u32; config.required_backing_words()];
        let mut coproc = Coprocessor::new(config, &mut backing).unwrap();
        for (pe, words) in grid.pe_images.iter().enumerate() {
            coproc.load_pe(pe as u8, words).unwrap();
        }
        let desc = grid_desc(grid);
        let walk = WalkGrid::new(&desc);
        let mut ahead = vec![0u8; grid.owners.len()];
        assert!(fill_ahead(desc.dims, &grid.owners, &mut ahead));
        let map = VoxelMap { pe: &grid.owners, ahead: &ahead };
        let diag = desc.aabb().diagonal().length();
        let (lo, ext) = (desc.min, desc.max - desc.min);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut lights = vec![Vec3::from_array(settings.light.pos)];
        for _ in 0..3 {
            lights.push(lo + ext * Vec3::new(rng.gen(), rng.gen(), rng.gen()));
            let far = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            lights.push(lo + ext * 0.5 + far * diag * 10.0);
        }
        let mut cells = Box::new(LightCells::<48, 12>::new());
        let (mut walked, mut listed) = (vec![0u32; 2 * MAX_LIST], vec![0u32; 2 * MAX_LIST]);
        let (mut answered, mut shadowed, mut rays) = (0usize, 0usize, 0usize);
        let tris = &prepared.scene.mesh.triangles;
        for light in lights {
            cells.build(&walk, map, light);
            for _ in 0..2000 {
                let v = tris[rng.gen_range(0..tris.len())].v.map(Vec3::from_array);
                let (a, b): (f32, f32) = (rng.gen_range(0.0..1.0), rng.gen_range(0.0..1.0));
                let p = match rng.gen_range(0..3) {
                    0 => v[rng.gen_range(0..3)],
                    1 => v[0] + (v[1] - v[0]) * a,
                    _ => v[0] + (v[1] - v[0]) * (a * 0.5) + (v[2] - v[0]) * (b * 0.5),
                };
                let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                let n = if rng.gen_bool(0.5) { n } else { -n };
                let ray: Ray = shadow_ray(p, n, light, diag);
                rays += 1;
                let Some(k) = cells.write_entries(&ray, SHADOW_T_MAX, &mut listed) else { continue };
                answered += 1;
                let w = walk.write_entries(map, &ray, SHADOW_T_MAX, &mut walked);
                let hit = |list: &[ListEntry]| {
                    !list.is_empty() && coproc.trace_untimed(RayKind::Any, &ray, SHADOW_T_MAX, list).unwrap().hit
                };
                let from_walk = hit(&entries(&walked, w));
                assert_eq!(hit(&entries(&listed, k)), from_walk, "{name}: light {light:?} {ray:?}");
                shadowed += usize::from(from_walk);
            }
        }
        eprintln!("{name}: {answered} of {rays} rays from the cells, {shadowed} shadowed");
        assert!(answered > 2000, "{name}: {answered} of {rays} rays from the cells");
        assert!(shadowed * 10 > answered && shadowed * 10 < answered * 9, "{name}: {shadowed} of {answered} shadowed");
    }
}
