//! Embree 3 beside the native path (`gridrt bench rays --vs-embree`, cargo feature `embree`).
//!
//! Binding: the `embree` crate 0.3 (Will Usher's embree-rs, the Embree 3 API; links
//! `libembree3`, Debian's `libembree-dev` 3.13). Its own BVH build, default build quality,
//! one `rtcIntersect1` per camera ray on the calling thread with a coherent context — the
//! single-ray path a renderer without ray packets would use. The scene is the triangles the
//! PE images hold (each primitive once, Embree primitive index = prim id order), the rays are
//! the firmware camera's.
//!
//! The crate's `Device::new` would set flush-to-zero on x86_64, but its `cfg` never matches;
//! nothing here touches MXCSR either, so the native path's f32 results in the same process
//! are unaffected (the bench still checks them against the model word for word).

use std::collections::BTreeMap;

use cgmath::{Vector3, Vector4};
use embree::{Device, Geometry, IntersectContext, Ray, RayHit, Scene, TriangleMesh};
use gridrt_firmware::camera::Camera;

use super::scene::NativeScene;

/// Why the Embree scene could not be built.
#[derive(Debug, thiserror::Error)]
pub enum EmbreeError {
    /// The scene has no triangles.
    #[error("no triangles to give Embree")]
    Empty,
}

impl NativeScene {
    /// Every triangle of the PE images once, by prim id: `(prim, 9 vertex coordinates)`.
    pub fn triangles(&self) -> Vec<(u32, [f32; 9])> {
        let mut by_prim = BTreeMap::new();
        for s in &self.slots {
            by_prim.entry(s.prim).or_insert(s.words.map(f32::from_bits));
        }
        by_prim.into_iter().collect()
    }
}

/// A committed Embree scene of triangles.
pub struct EmbreeScene<'a> {
    scene: embree::CommittedScene<'a>,
    /// Embree primitive index → prim id.
    prims: Vec<u32>,
}

/// Builds the BVH of `tris` (`NativeScene::triangles`) and runs `f` on it (the crate's
/// committed scene borrows its scene and device, so they live on this stack frame).
pub fn with_scene<R>(tris: &[(u32, [f32; 9])], f: impl FnOnce(&EmbreeScene<'_>) -> R) -> Result<R, EmbreeError> {
    if tris.is_empty() {
        return Err(EmbreeError::Empty);
    }
    let device = Device::new();
    let mut mesh = TriangleMesh::unanimated(&device, tris.len(), 3 * tris.len());
    {
        let mut verts = mesh.vertex_buffer.map();
        let mut idx = mesh.index_buffer.map();
        for (i, (_, v)) in tris.iter().enumerate() {
            for j in 0..3 {
                verts[3 * i + j] = Vector4::new(v[3 * j], v[3 * j + 1], v[3 * j + 2], 0.0);
            }
            let b = 3 * i as u32;
            idx[i] = Vector3::new(b, b + 1, b + 2);
        }
    }
    let mut geometry = Geometry::Triangle(mesh);
    geometry.commit();
    let mut scene = Scene::new(&device);
    scene.attach_geometry(geometry);
    let committed = EmbreeScene { scene: scene.commit(), prims: tris.iter().map(|t| t.0).collect() };
    Ok(f(&committed))
}

impl EmbreeScene<'_> {
    /// Embree's version (`rtcGetDeviceProperty(VERSION)`), e.g. `3.13.5`.
    pub fn version(&self) -> String {
        // SAFETY: a device created and released here; the property query has no other effect.
        let v = unsafe {
            let d = embree::sys::rtcNewDevice(std::ptr::null());
            let v = embree::sys::rtcGetDeviceProperty(d, embree::DeviceProperty::VERSION);
            embree::sys::rtcReleaseDevice(d);
            v
        };
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    #[inline]
    fn hit(&self, ctx: &mut IntersectContext, camera: &Camera, x: u32, y: u32) -> Option<u32> {
        let r = camera.primary_ray(x, y);
        let mut rh = RayHit::new(Ray::new(
            Vector3::new(r.origin.x, r.origin.y, r.origin.z),
            Vector3::new(r.dir.x, r.dir.y, r.dir.z),
        ));
        self.scene.intersect(ctx, &mut rh);
        rh.hit.hit().then(|| self.prims.get(rh.hit.primID as usize).copied().unwrap_or(u32::MAX))
    }

    /// Hits of a frame of primary rays (single thread).
    pub fn count_frame(&self, camera: &Camera, width: u32, height: u32) -> u64 {
        let mut ctx = IntersectContext::coherent();
        let mut hits = 0;
        for y in 0..height {
            for x in 0..width {
                hits += self.hit(&mut ctx, camera, x, y).is_some() as u64;
            }
        }
        hits
    }

    /// The prim id hit by every pixel's primary ray, row by row.
    pub fn trace_frame(&self, camera: &Camera, width: u32, height: u32) -> Vec<Option<u32>> {
        let mut ctx = IntersectContext::coherent();
        (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| self.hit(&mut ctx, camera, x, y))
            .collect()
    }
}
