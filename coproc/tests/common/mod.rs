//! Meshes and probe rays shared by the stress tests (seeded, std-only).
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::Path;

use gridrt_coproc::isect::Triangle;
use gridrt_coproc::{FixedFrame, Intersector, KernelKind, NumberFormat};
use gridrt_shared::math::{Ray, Vec3};
use rand::Rng;

/// An indexed triangle mesh.
#[derive(Debug, Clone)]
pub struct Mesh {
    pub verts: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn tri(&self, f: usize) -> Triangle {
        self.faces[f].map(|i| self.verts[i as usize])
    }

    pub fn triangles(&self) -> Vec<Triangle> {
        (0..self.faces.len()).map(|f| self.tri(f)).collect()
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for v in &self.verts {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        (lo, hi)
    }

    /// Maps every vertex (shared vertices stay shared: they are transformed once).
    pub fn map(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh { verts: self.verts.iter().map(|&v| f(v)).collect(), faces: self.faces.clone() }
    }

    /// Interior edges (exactly two incident faces): (v0, v1, face a, face b).
    pub fn shared_edges(&self) -> Vec<(u32, u32, usize, usize)> {
        let mut m: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (f, t) in self.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                m.entry((a.min(b), a.max(b))).or_default().push(f);
            }
        }
        let mut v: Vec<_> =
            m.into_iter().filter(|(_, fs)| fs.len() == 2).map(|((a, b), fs)| (a, b, fs[0], fs[1])).collect();
        v.sort_unstable();
        v
    }

    /// Vertices whose fan is closed (every incident edge interior): (vertex, incident faces).
    pub fn closed_fans(&self) -> Vec<(u32, Vec<usize>)> {
        let mut edge_count: HashMap<(u32, u32), u32> = HashMap::new();
        let mut incident: HashMap<u32, Vec<usize>> = HashMap::new();
        for (f, t) in self.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edge_count.entry((a.min(b), a.max(b))).or_default() += 1;
                incident.entry(t[k]).or_default().push(f);
            }
        }
        let mut v: Vec<_> = incident
            .into_iter()
            .filter(|(vtx, fs)| {
                fs.iter().all(|&f| {
                    let t = self.faces[f];
                    (0..3).all(|k| {
                        let (a, b) = (t[k], t[(k + 1) % 3]);
                        (a != *vtx && b != *vtx) || edge_count[&(a.min(b), a.max(b))] == 2
                    })
                })
            })
            .collect();
        v.sort_unstable();
        v
    }
}

/// Icosahedron subdivided `levels` times, vertices projected onto the unit sphere (in f64,
/// then rounded once, so shared vertices are bit-identical in every triangle).
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let norm = |v: [f64; 3]| {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    };
    for v in &mut verts {
        *v = norm(*v);
    }
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        for f in &faces {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (verts[a as usize], verts[b as usize]);
                    verts.push(norm([(pa[0] + pb[0]) / 2.0, (pa[1] + pb[1]) / 2.0, (pa[2] + pb[2]) / 2.0]));
                    verts.len() as u32 - 1
                });
            }
            next.push([f[0], m[0], m[2]]);
            next.push([f[1], m[1], m[0]]);
            next.push([f[2], m[2], m[1]]);
            next.push([m[0], m[1], m[2]]);
        }
        faces = next;
    }
    Mesh { verts: verts.iter().map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)).collect(), faces }
}

/// A tiny OBJ reader: `v x y z` and triangular or polygonal `f` lines (fan-triangulated;
/// `a/b/c` index forms and negative indices supported).
pub fn load_obj(path: &Path) -> Mesh {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut verts = Vec::new();
    let mut faces = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|x| x.parse().unwrap()).collect();
                verts.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .map(|x| {
                        let i: i64 = x.split('/').next().unwrap().parse().unwrap();
                        if i < 0 {
                            (verts.len() as i64 + i) as u32
                        } else {
                            (i - 1) as u32
                        }
                    })
                    .collect();
                for k in 1..idx.len() - 1 {
                    faces.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Mesh { verts, faces }
}

/// The repository's test scenes.
pub fn scene_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)
}

/// Every (kernel, format) with the fixed-point frame of `mesh`'s bounding box.
pub fn intersectors(lo: Vec3, hi: Vec3) -> Vec<Intersector> {
    let mut v = Vec::new();
    for k in KernelKind::ALL {
        for f in NumberFormat::ALL {
            let frame = FixedFrame::for_box(lo.to_array(), hi.to_array(), f).unwrap();
            v.push(Intersector::new(k, f, frame));
        }
    }
    v
}

/// A random origin in the shell of radii `[r0, r1]` around `c`.
pub fn shell_point(rng: &mut impl Rng, c: Vec3, r0: f32, r1: f32) -> Vec3 {
    loop {
        let d = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        let l = d.length();
        if l > 1e-3 && l <= 1.0 {
            return c + d / l * rng.gen_range(r0..r1);
        }
    }
}

/// A ray from `origin` aimed at `target` (the direction rounded to f32, as a device does).
pub fn aim(origin: Vec3, target: Vec3) -> Ray {
    Ray { origin, dir: target - origin }
}

/// Watertightness probe targets of a mesh (see `gridrt_coproc::probe`): shared edges whose
/// endpoints both have closed fans, and vertices with closed fans; each probe ray crosses the
/// surface transversally at its aim point, and its disk is the star of the vertex or the
/// union of the stars of the edge's endpoints.
pub struct ProbeSet {
    pub mesh: Mesh,
    /// Star (incident faces) of every vertex with a closed fan; empty otherwise.
    stars: Vec<Vec<usize>>,
    edges: Vec<(u32, u32)>,
    verts: Vec<u32>,
    normals: Vec<Vec3>,
    edge_len: f32,
}

impl ProbeSet {
    pub fn new(mesh: Mesh) -> Self {
        let mut stars = vec![Vec::new(); mesh.verts.len()];
        let mut verts = Vec::new();
        for (v, fan) in mesh.closed_fans() {
            stars[v as usize] = fan;
            verts.push(v);
        }
        let edges: Vec<(u32, u32)> = mesh
            .shared_edges()
            .into_iter()
            .filter(|&(a, b, _, _)| !stars[a as usize].is_empty() && !stars[b as usize].is_empty())
            .map(|(a, b, _, _)| (a, b))
            .collect();
        let normals = (0..mesh.faces.len())
            .map(|f| {
                let t = mesh.tri(f);
                (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero()
            })
            .collect();
        let total: f32 = edges.iter().map(|&(a, b)| (mesh.verts[a as usize] - mesh.verts[b as usize]).length()).sum();
        let edge_len = total / edges.len().max(1) as f32;
        ProbeSet { mesh, stars, edges, verts, normals, edge_len }
    }

    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    pub fn vertex_count(&self) -> usize {
        self.verts.len()
    }

    /// One random probe: ~70 % at a random point of a shared edge, ~30 % exactly at a vertex;
    /// the origin 0.5–4 edge lengths off the surface on either side, within 30° of the local
    /// normal. Only rays for which every face of the disk faces the same way with
    /// |cos| ≥ 0.1 are returned (the disk is then a height field along the ray, crossed
    /// exactly once); others are redrawn. Returns the ray and its disk (face indices).
    pub fn ray(&self, rng: &mut impl Rng) -> (Ray, Vec<usize>) {
        loop {
            let (target, mut disk) = if rng.gen_bool(0.7) {
                let (a, b) = self.edges[rng.gen_range(0..self.edges.len())];
                let (pa, pb) = (self.mesh.verts[a as usize], self.mesh.verts[b as usize]);
                let s: f32 = rng.gen_range(0.0..1.0);
                let mut disk = self.stars[a as usize].clone();
                disk.extend_from_slice(&self.stars[b as usize]);
                (pa + (pb - pa) * s, disk)
            } else {
                let v = self.verts[rng.gen_range(0..self.verts.len())];
                (self.mesh.verts[v as usize], self.stars[v as usize].clone())
            };
            disk.sort_unstable();
            disk.dedup();
            let n = disk.iter().map(|&f| self.normals[f]).sum::<Vec3>().normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            for _ in 0..8 {
                let h = rng.gen_range(0.5..4.0) * self.edge_len;
                let side = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
                // A tangent jitter of at most tan 30° · h.
                let any = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
                let (t1, t2) = (n.cross(any).normalize(), n.cross(n.cross(any)).normalize());
                let ang: f32 = rng.gen_range(0.0..std::f32::consts::TAU);
                let r = rng.gen_range(0.0..0.577) * h;
                let origin = target + n * (side * h) + (t1 * ang.cos() + t2 * ang.sin()) * r;
                let ray = aim(origin, target);
                let d = ray.dir.normalize();
                let cos: Vec<f32> = disk.iter().map(|&f| self.normals[f].dot(d)).collect();
                if cos.iter().all(|&c| c >= 0.1) || cos.iter().all(|&c| c <= -0.1) {
                    return (ray, disk);
                }
            }
        }
    }
}
