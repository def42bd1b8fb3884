//! SPEC.md §5.11 ("Building an image: the host's duties") against the reference host's images:
//! the rules a device cannot check, which would otherwise render wrong pixels silently.

use std::collections::BTreeSet;
use std::path::Path;

use gridrt_host::grid::GridParams;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::scene::{PeImage, EMPTY_VOXEL, PE_IMAGE_TAG};

fn prepared(name: &str, pe_count: u16, m: f64) -> PreparedScene {
    let scene =
        gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)).unwrap();
    PreparedScene::new(scene, &GridParams { pe_count, pe_mem_words: 1 << 20, m, ..Default::default() }).unwrap()
}

/// Rules 3, 4, 6, 7 and 8 on one prepared scene.
fn check_duties(p: &PreparedScene, what: &str) {
    let g = &p.grid;
    // Rule 4: a positive extent on every axis.
    for a in 0..3 {
        assert!(g.bounds.min[a] < g.bounds.max[a], "{what}: axis {a} is flat: {:?}", g.bounds);
    }
    // Rule 3: every vertex inside the closed box the header carries.
    for (id, t) in p.scene.mesh.triangles.iter().enumerate() {
        for v in &t.v {
            for a in 0..3 {
                assert!(
                    g.bounds.min[a] <= v[a] && v[a] <= g.bounds.max[a],
                    "{what}: triangle {id} has a vertex outside the box: {v:?} vs {:?}",
                    g.bounds
                );
            }
        }
    }
    let mut owned_by_pe = vec![BTreeSet::new(); g.pe_count as usize];
    for (voxel, &owner) in g.owners.iter().enumerate() {
        let listed = g.voxels.binary_search(&(voxel as u32)).is_ok();
        // Rule 6: owned iff something is listed in it.
        assert_eq!(owner != EMPTY_VOXEL, listed, "{what}: voxel {voxel}, owner {owner}");
        if listed {
            owned_by_pe[owner as usize].insert(voxel as u32);
        }
    }
    for (pe, words) in g.pe_images.iter().enumerate() {
        let img = PeImage::parse(words).unwrap();
        let table: BTreeSet<u32> = (0..img.voxel_count()).map(|i| img.voxel_entry(i).unwrap().0).collect();
        // Rule 6: exactly the PE's own voxels in its table.
        assert_eq!(table, owned_by_pe[pe], "{what}: PE {pe}'s voxel table against the voxel map");
        // Rule 7: each triangle stored once per PE.
        let ids: Vec<u32> = (0..img.triangle_count()).map(|i| img.triangle(i).unwrap().prim).collect();
        let unique: BTreeSet<u32> = ids.iter().copied().collect();
        assert_eq!(unique.len(), ids.len(), "{what}: PE {pe} stores a triangle twice");
        // Rule 8: an empty PE is the five-word tagged image.
        if table.is_empty() {
            assert_eq!(words.as_slice(), &[PE_IMAGE_TAG, 0, 0, 0, 0], "{what}: PE {pe} is empty");
        }
    }
}

#[test]
fn the_reference_hosts_images_follow_the_hosts_duties_of_spec_5_11() {
    check_duties(&prepared("bun_zipper_res4.obj", 4, 1.0), "res4");
    // The Cornell box: walls lie on the geometry's box, so the padding of rule 3 matters.
    check_duties(&prepared("cornell_box.obj", 3, 1.0), "cornell box");
    // A coarse grid with fewer occupied voxels than PEs: some PEs are empty (rule 8).
    let sparse = prepared("bun_zipper_res4.obj", 64, 0.3);
    assert!(sparse.grid.voxels.len() < 64, "{} voxels", sparse.grid.voxels.len());
    check_duties(&sparse, "res4, coarse grid, 64 PEs");
}
