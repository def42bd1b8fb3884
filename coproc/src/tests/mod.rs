//! Crate tests: scene builders shared by the protocol, arbitration, timing and property tests.

mod arbitration;
mod frame;
mod observe;
mod property;
mod protocol;
mod timing;

use crate::*;
use gridrt_shared::fsl::{entry_words, load_header, ray_request_head};
use gridrt_shared::math::{Aabb, Vec3};
use gridrt_shared::scene::{TriangleRecord, PE_IMAGE_TAG};

pub(crate) fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

pub(crate) fn tri(a: Vec3, b: Vec3, c: Vec3, prim: u32, material: u32) -> TriangleRecord {
    TriangleRecord { vertices: [a.to_array(), b.to_array(), c.to_array()], prim, material }
}

/// A PE image: `voxels` = (voxel id, local triangle indices), in the given order.
pub(crate) fn image(voxels: &[(u32, Vec<u32>)], tris: &[TriangleRecord]) -> Vec<u32> {
    let refs: usize = voxels.iter().map(|(_, r)| r.len()).sum();
    let mut w = vec![PE_IMAGE_TAG, tris.len() as u32, voxels.len() as u32, refs as u32, 0];
    let mut first = 0u32;
    for (id, r) in voxels {
        w.extend([*id, first, r.len() as u32]);
        first += r.len() as u32;
    }
    for (_, r) in voxels {
        w.extend(r.iter().copied());
    }
    for t in tris {
        w.extend(t.to_words());
    }
    w
}

/// A triangle in the plane z = `z` that covers (x, y) ∈ [0.25, 0.75]² (hit by `probe_ray`).
pub(crate) fn hit_tri(z: f32, prim: u32) -> TriangleRecord {
    tri(v(0.0, 0.0, z), v(2.0, 0.0, z), v(0.0, 2.0, z), prim, prim % 7)
}

/// A triangle at z = `z` far from the probe ray.
pub(crate) fn miss_tri(z: f32, prim: u32) -> TriangleRecord {
    tri(v(5.0, 5.0, z), v(6.0, 5.0, z), v(5.0, 6.0, z), prim, 0)
}

/// The ray (0.5, 0.5, −1) + t·(0, 0, 1): hits `hit_tri(z)` at t = z + 1.
pub(crate) fn probe_ray() -> Ray {
    Ray { origin: v(0.5, 0.5, -1.0), dir: v(0.0, 0.0, 1.0) }
}

pub(crate) fn entry(voxel: u32, pe: u8, t_exit: f32) -> ListEntry {
    ListEntry { voxel, pe, t_exit }
}

/// The request packet for a ray, control bit on its last word.
pub(crate) fn ray_packet(kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Vec<FslWord> {
    let mut w: Vec<u32> =
        ray_request_head(kind, ray.origin.to_array(), ray.dir.to_array(), t_max, list.len() as u16).to_vec();
    for e in list {
        w.extend(entry_words(*e));
    }
    framed(&w)
}

/// The LOAD_PE packet for an image.
pub(crate) fn load_packet(pe: u8, img: &[u32]) -> Vec<FslWord> {
    let mut w = vec![load_header(pe), img.len() as u32];
    w.extend_from_slice(img);
    framed(&w)
}

/// Data words with the control bit on the last.
pub(crate) fn framed(words: &[u32]) -> Vec<FslWord> {
    let n = words.len();
    words.iter().enumerate().map(|(i, &d)| FslWord { data: d, control: i + 1 == n }).collect()
}

pub(crate) fn push_all(cp: &mut Coprocessor<'_>, words: &[FslWord]) {
    for &w in words {
        cp.push(w);
    }
}

pub(crate) fn drain(cp: &mut Coprocessor<'_>) -> Vec<FslWord> {
    core::iter::from_fn(|| cp.pop()).collect()
}

pub(crate) fn config(pe_count: u16, pe_mem_words: u32) -> CoprocConfig {
    CoprocConfig { pe_count, pe_mem_words, max_list: 64, timing: TimingProfile::GRIDRT, kernel: KernelKind::default() }
}

// ------------------------------------------------------------ the random 2×2×2 scene

/// Unit voxels of the 2×2×2 grid over [0, 2]³; id = ix + 2·iy + 4·iz.
pub(crate) fn voxel_box(id: u32) -> Aabb {
    let min = v((id & 1) as f32, ((id >> 1) & 1) as f32, ((id >> 2) & 1) as f32);
    Aabb { min, max: min + Vec3::ONE }
}

/// Random triangles inside [0, 2]³ (seeded), binned by bounding-box overlap with the voxel
/// boxes padded by 10⁻³ (conservative binning, as a grid builder must do).
pub(crate) struct GridScene {
    pub tris: Vec<TriangleRecord>,
    /// Global triangle ids per voxel.
    pub cells: [Vec<u32>; 8],
}

impl GridScene {
    pub fn random(seed: u64, n: usize) -> Self {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut tris = Vec::new();
        for prim in 0..n as u32 {
            let c = v(rng.gen_range(0.1..1.9), rng.gen_range(0.1..1.9), rng.gen_range(0.1..1.9));
            let size = if prim % 5 == 0 { 1.2 } else { 0.4 };
            let mut p = || {
                let o = v(rng.gen_range(-size..size), rng.gen_range(-size..size), rng.gen_range(-size..size));
                (c + o).clamp(Vec3::ZERO, Vec3::splat(2.0))
            };
            tris.push(tri(p(), p(), p(), 1000 + prim, prim % 5));
        }
        let mut cells: [Vec<u32>; 8] = Default::default();
        for (i, t) in tris.iter().enumerate() {
            let vs = t.vertices.map(Vec3::from_array);
            let (lo, hi) = (vs[0].min(vs[1]).min(vs[2]), vs[0].max(vs[1]).max(vs[2]));
            for (id, cell) in cells.iter_mut().enumerate() {
                let b = voxel_box(id as u32);
                let pad = Vec3::splat(1e-3);
                if (lo.cmple(b.max + pad) & hi.cmpge(b.min - pad)).all() {
                    cell.push(i as u32);
                }
            }
        }
        Self { tris, cells }
    }

    /// PE images when voxel `id` lives on PE `map(id)`; returns one image per PE.
    pub fn images(&self, pe_count: u8, map: impl Fn(u32) -> u8) -> Vec<Vec<u32>> {
        (0..pe_count)
            .map(|pe| {
                let mut local: Vec<u32> = Vec::new(); // global ids of this PE's triangles
                let mut voxels = Vec::new();
                for id in 0..8u32 {
                    if map(id) != pe || self.cells[id as usize].is_empty() {
                        continue;
                    }
                    let refs = self.cells[id as usize]
                        .iter()
                        .map(|&g| match local.iter().position(|&x| x == g) {
                            Some(i) => i as u32,
                            None => {
                                local.push(g);
                                local.len() as u32 - 1
                            }
                        })
                        .collect();
                    voxels.push((id, refs));
                }
                let tris: Vec<_> = local.iter().map(|&g| self.tris[g as usize]).collect();
                image(&voxels, &tris)
            })
            .collect()
    }

    /// Traversal list: non-empty voxels the ray crosses for t ≥ 0, by entry distance, each
    /// with its exit distance (a brute-force stand-in for the firmware's 3D-DDA).
    pub fn list(&self, ray: &Ray, map: impl Fn(u32) -> u8) -> Vec<ListEntry> {
        let mut l: Vec<(f32, ListEntry)> = (0..8u32)
            .filter(|&id| !self.cells[id as usize].is_empty())
            .filter_map(|id| voxel_box(id).clip(ray, 0.0, f32::INFINITY).map(|(t0, t1)| (t0, entry(id, map(id), t1))))
            .collect();
        l.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.voxel.cmp(&b.1.voxel)));
        l.into_iter().map(|(_, e)| e).collect()
    }

    /// Brute-force nearest hit over all triangles with the same kernel and number format
    /// (fixed-point overflows count as misses, as in the co-processor): (t, prim).
    pub fn brute_force_with(&self, is: &Intersector, ray: &Ray, t_max: f32) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        for t in &self.tris {
            let verts = t.vertices.map(Vec3::from_array);
            if let Ok(Some(h)) = is.intersect_tri(ray, &verts, f32::INFINITY) {
                if h > 0.0 && h < t_max && best.is_none_or(|(bt, bp)| h < bt || (h == bt && t.prim < bp)) {
                    best = Some((h, t.prim));
                }
            }
        }
        best
    }

    /// Brute-force nearest hit over all triangles with the same kernel: (t, prim).
    pub fn brute_force(&self, kernel: KernelKind, ray: &Ray, t_max: f32) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        for t in &self.tris {
            let verts = t.vertices.map(Vec3::from_array);
            if let Some(h) = kernel.intersect_once(ray, &verts, f32::INFINITY) {
                if h > 0.0 && h < t_max && best.is_none_or(|(bt, bp)| h < bt || (h == bt && t.prim < bp)) {
                    best = Some((h, t.prim));
                }
            }
        }
        best
    }
}

/// Random rays for the 2×2×2 scene: origins in [−1, 3]³, half aimed at points in the grid.
pub(crate) fn random_ray(rng: &mut impl rand::Rng) -> (Ray, f32) {
    let origin = v(rng.gen_range(-1.0..3.0), rng.gen_range(-1.0..3.0), rng.gen_range(-1.0..3.0));
    let dir = if rng.gen_bool(0.5) {
        v(rng.gen_range(0.0..2.0), rng.gen_range(0.0..2.0), rng.gen_range(0.0..2.0)) - origin
    } else {
        v(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
    };
    let dir = if dir == Vec3::ZERO { Vec3::X } else { dir };
    let t_max = if rng.gen_bool(0.2) { rng.gen_range(0.0..3.0) } else { f32::INFINITY };
    (Ray { origin, dir }, t_max)
}

/// A co-processor over `backing` with `images` loaded via `load_pe`.
pub(crate) fn loaded<'m>(cfg: CoprocConfig, backing: &'m mut Vec<u32>, images: &[Vec<u32>]) -> Coprocessor<'m> {
    backing.clear();
    backing.resize(cfg.required_backing_words(), 0);
    let mut cp = Coprocessor::new(cfg, backing).unwrap();
    for (pe, img) in images.iter().enumerate() {
        cp.load_pe(pe as u8, img).unwrap();
    }
    cp
}

/// The model lives in firmware RAM on the emulated board: keep its footprint known.
#[test]
fn coprocessor_footprint_stays_below_24_kib() {
    let size = core::mem::size_of::<Coprocessor<'static>>();
    assert!(size < 24 * 1024, "{size} bytes");
}
