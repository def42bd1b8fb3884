//! Watertightness probes: rays aimed exactly at the shared edges and vertices of a mesh.

use std::collections::HashMap;

use gridrt_coproc::isect::Triangle as KTriangle;
use gridrt_coproc::probe::{probe, ProbeStats};
use gridrt_coproc::{Intersector, Record};
use gridrt_shared::math::{Ray, Vec3};

use crate::scene::Mesh;

/// SplitMix64: a tiny seeded generator (the host library has no `rand` dependency).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    fn f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Probe targets of a mesh (same construction as `coproc/tests/stress_watertight.rs`):
/// shared edges whose endpoints both have closed fans, and vertices with closed fans. The
/// mesh is welded by exact vertex position.
pub(super) struct ProbeSet {
    verts: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    normals: Vec<Vec3>,
    /// Star of every vertex with a closed fan (empty otherwise).
    stars: Vec<Vec<usize>>,
    edges: Vec<(u32, u32)>,
    fan_verts: Vec<u32>,
    edge_len: f32,
}

impl ProbeSet {
    pub(super) fn new(mesh: &Mesh) -> Self {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut verts = Vec::new();
        let mut faces = Vec::with_capacity(mesh.triangles.len());
        for t in &mesh.triangles {
            let f = t.v.map(|p| {
                *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                    verts.push(Vec3::from_array(p));
                    verts.len() as u32 - 1
                })
            });
            faces.push(f);
        }
        let mut edge_faces: HashMap<(u32, u32), u32> = HashMap::new();
        let mut incident: Vec<Vec<usize>> = vec![Vec::new(); verts.len()];
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *edge_faces.entry((a.min(b), a.max(b))).or_default() += 1;
                incident[f[k] as usize].push(fi);
            }
        }
        let interior = |a: u32, b: u32| edge_faces.get(&(a.min(b), a.max(b))) == Some(&2);
        let mut stars = vec![Vec::new(); verts.len()];
        let mut fan_verts = Vec::new();
        for (v, fs) in incident.iter().enumerate() {
            let v = v as u32;
            let closed = !fs.is_empty()
                && fs.iter().all(|&fi| {
                    let f = faces[fi];
                    (0..3).all(|k| {
                        let (a, b) = (f[k], f[(k + 1) % 3]);
                        (a != v && b != v) || interior(a, b)
                    })
                });
            if closed {
                stars[v as usize] = fs.clone();
                fan_verts.push(v);
            }
        }
        let mut edges: Vec<(u32, u32)> = edge_faces
            .iter()
            .filter(|(&(a, b), &n)| n == 2 && !stars[a as usize].is_empty() && !stars[b as usize].is_empty())
            .map(|(&e, _)| e)
            .collect();
        edges.sort_unstable();
        let normals = faces
            .iter()
            .map(|f| {
                let p = f.map(|i| verts[i as usize]);
                (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
            })
            .collect();
        let total: f32 = edges.iter().map(|&(a, b)| (verts[a as usize] - verts[b as usize]).length()).sum();
        let edge_len = total / edges.len().max(1) as f32;
        Self { verts, faces, normals, stars, edges, fan_verts, edge_len }
    }

    /// One probe: a ray through a random point of a shared edge (70 %) or exactly at a vertex
    /// (30 %), from 0.5–4 edge lengths off the surface on either side within 30° of the local
    /// normal, kept only if every face of its disk faces it with |cos| ≥ 0.1 (a height field
    /// along the ray: crossed exactly once). `None` when the mesh has no probe targets.
    fn ray(&self, rng: &mut Rng) -> Option<(Ray, Vec<usize>)> {
        if self.edges.is_empty() && self.fan_verts.is_empty() {
            return None;
        }
        for _ in 0..1000 {
            let (target, mut disk) = if !self.edges.is_empty() && (self.fan_verts.is_empty() || rng.f32(0.0, 1.0) < 0.7)
            {
                let (a, b) = self.edges[rng.below(self.edges.len())];
                let (pa, pb) = (self.verts[a as usize], self.verts[b as usize]);
                let mut disk = self.stars[a as usize].clone();
                disk.extend_from_slice(&self.stars[b as usize]);
                (pa + (pb - pa) * rng.f32(0.0, 1.0), disk)
            } else {
                let v = self.fan_verts[rng.below(self.fan_verts.len())];
                (self.verts[v as usize], self.stars[v as usize].clone())
            };
            disk.sort_unstable();
            disk.dedup();
            let n = disk.iter().map(|&f| self.normals[f]).sum::<Vec3>().normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            let h = rng.f32(0.5, 4.0) * self.edge_len;
            let side = if rng.f32(0.0, 1.0) < 0.5 { 1.0 } else { -1.0 };
            let any = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
            let (t1, t2) = (n.cross(any).normalize(), n.cross(n.cross(any)).normalize());
            let ang = rng.f32(0.0, std::f32::consts::TAU);
            let r = rng.f32(0.0, 0.577) * h;
            let origin = target + n * (side * h) + (t1 * ang.cos() + t2 * ang.sin()) * r;
            let ray = Ray { origin, dir: target - origin };
            let d = ray.dir.normalize_or_zero();
            let ok_pos = disk.iter().all(|&f| self.normals[f].dot(d) >= 0.1);
            let ok_neg = disk.iter().all(|&f| self.normals[f].dot(d) <= -0.1);
            if ok_pos || ok_neg {
                return Some((ray, disk));
            }
        }
        None
    }

    /// Probes `n` seeded rays with `is`.
    pub(super) fn run(&self, is: &Intersector, n: u32, seed: u64) -> ProbeStats {
        let tris: Vec<KTriangle> = self.faces.iter().map(|f| f.map(|i| self.verts[i as usize])).collect();
        let recs: Vec<Record> = tris.iter().map(|t| is.precompute(t)).collect();
        let mut rng = Rng(seed);
        let mut stats = ProbeStats::default();
        let mut fan = Vec::new();
        for _ in 0..n {
            let Some((ray, disk)) = self.ray(&mut rng) else { break };
            fan.clear();
            fan.extend(disk.iter().map(|&f| (tris[f], recs[f])));
            stats.add(probe(is, &fan, &ray));
        }
        stats
    }
}
