//! Reference renderer tests: the contract's shading and shadow rule on a hand-built scene,
//! thread-count independence.

use super::camera::CameraF64;
use super::*;
use crate::render_settings::RenderSettings;
use crate::scene::{Mesh, Scene, Triangle, DEFAULT_MATERIAL};
use std::path::Path;

#[test]
fn shadow_and_shading_follow_the_contract() {
    // Floor at y = 0, a square occluder at y = 0.5, light at (0.5, 1, 0): the shadow of the
    // occluder falls on x ∈ [-0.9, -0.1], z ∈ [-0.4, 0.4], visible from the camera above.
    let floor = [
        [[-1.0f32, 0.0, -1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0]],
        [[-1.0, 0.0, -1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]],
    ];
    let occ = [
        [[-0.2f32, 0.5, -0.2], [0.2, 0.5, 0.2], [0.2, 0.5, -0.2]],
        [[-0.2, 0.5, -0.2], [-0.2, 0.5, 0.2], [0.2, 0.5, 0.2]],
    ];
    let tris: Vec<Triangle> = floor.iter().chain(occ.iter()).map(|&v| Triangle { v, material: 0 }).collect();
    let mesh = Mesh::from_triangles(Path::new("t"), tris, vec![DEFAULT_MATERIAL]).unwrap();
    let b = mesh.bounds().unwrap();
    let scene = Scene::from_mesh(mesh);
    let reference = Reference::new(&scene, &b);
    let mut s = RenderSettings::default_for(&b).with_size(64, 64);
    s.camera.eye = [0.0, 3.0, 0.001];
    s.camera.target = [0.0, 0.0, 0.0];
    s.light.pos = [0.5, 1.0, 0.0];
    let img = render(&reference, &s, Stages::ALL, 2);
    let px = |x: usize, y: usize| {
        (
            img.prim_ids[y * 64 + x],
            [img.rgb[3 * (y * 64 + x)], img.rgb[3 * (y * 64 + x) + 1], img.rgb[3 * (y * 64 + x) + 2]],
        )
    };
    // Occluder, lit.
    let (id, occ_rgb) = px(34, 30);
    assert!(id >= 2, "{id}");
    // Floor in the occluder's shadow: ambient only, exactly.
    let (id, shadow_rgb) = px(18, 31);
    assert!(id < 2, "{id}");
    assert_eq!(shadow_rgb, to_rgb8([0.8 * 0.15; 3]));
    assert!(occ_rgb[0] > shadow_rgb[0]);
    // Without shadow rays the same pixel is lit.
    let (c, _) = reference.shade_pixel(&CameraF64::new(&s), &s.with_shadows(false), Stages::ALL, 18, 31);
    assert!(to_rgb8(c)[0] > shadow_rgb[0]);
    // Background.
    let (id, bg) = px(0, 0);
    assert_eq!((id, bg), (MISS_ID, [20, 20, 31]));
}

#[test]
fn render_threads_agree() {
    let mesh =
        crate::scene::load_mesh(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj"))
            .unwrap();
    let b = mesh.bounds().unwrap();
    let scene = Scene::from_mesh(mesh);
    let reference = Reference::new(&scene, &b);
    let s = RenderSettings::default_for(&b).with_size(40, 30);
    let a = render(&reference, &s, Stages::ALL, 1);
    let c = render(&reference, &s, Stages::ALL, 3);
    assert_eq!(a, c);
    assert!(a.prim_ids.iter().any(|&p| p != MISS_ID));
    assert!(a.prim_ids.contains(&MISS_ID));
}
