//! PLY reader: arbitrary bytes as a mesh (`load_ply_bytes`) and as a point cloud's vertices
//! (`load_ply_vertices_bytes`, then `PointCloud::from_ply`: normals, radii from density,
//! palette). Errors are fine; panics and unbounded time are not.
//!
//! Seeds (`fuzz/corpus/ply/`): `cloud_ascii` and `cloud_bin`, 20-point synthetic clouds with
//! normals (ASCII and binary little endian), and `cloud_rgb_radius`, one with colours and
//! radii.
#![no_main]

use std::path::Path;

use gridrt_host::points::PointCloud;
use gridrt_host::scene::{load_ply_bytes, load_ply_vertices_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = Path::new("fuzz.ply");
    let _ = load_ply_bytes(name, data);
    if let Ok(v) = load_ply_vertices_bytes(name, data) {
        // Bounded: the radius search is O(n²) at worst, and inputs are small.
        if v.pos.len() <= 4096 {
            let _ = PointCloud::from_ply(name, v);
        }
    }
});
