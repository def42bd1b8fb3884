//! An oriented point cloud (point splatting): centres, unit normals, radii from local density,
//! and a ≤ 64-colour palette as materials; from a PLY file's vertices or a mesh's.

use std::collections::HashMap;
use std::path::Path;

use gridrt_shared::scene::Material;

use crate::scene::{Bounds, Mesh, PlyVertices, SceneLoadError, DEFAULT_MATERIAL};

/// Neighbours the density radius is measured to.
pub const KNN: usize = 8;
/// Largest palette: the device's material table (`MAX_MATERIALS`).
pub const MAX_PALETTE: usize = 64;

/// One oriented point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudPoint {
    /// Centre.
    pub pos: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Disk radius.
    pub radius: f32,
    /// Index into [`PointCloud::materials`].
    pub material: u16,
}

/// Where the radii came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadiusSource {
    /// The file's `radius` property.
    File,
    /// The distance to the [`KNN`]-th nearest neighbour.
    Density,
}

/// A point cloud with its palette.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud {
    /// The points.
    pub points: Vec<CloudPoint>,
    /// Colours (index = material id); entry 0 is the default grey when the file has none.
    pub materials: Vec<Material>,
    /// Where the radii came from.
    pub radius: RadiusSource,
}

impl PointCloud {
    /// A PLY file's vertices as a cloud: needs normals; radius from the file or from density;
    /// colours become a palette of at most 64 materials.
    pub fn from_ply(path: &Path, v: PlyVertices) -> Result<Self, SceneLoadError> {
        let malformed = |reason: String| SceneLoadError::Malformed {
            path: path.to_path_buf(),
            at: crate::scene::Location::File,
            reason,
        };
        let Some(normals) = v.normal else {
            return Err(malformed("a point cloud needs per-vertex normals (nx ny nz)".into()));
        };
        if v.pos.is_empty() {
            return Err(malformed("the point cloud has no vertices".into()));
        }
        let mut points = Vec::with_capacity(v.pos.len());
        for (i, (p, n)) in v.pos.iter().zip(&normals).enumerate() {
            let Some(n) = unit(*n) else {
                return Err(SceneLoadError::Malformed {
                    path: path.to_path_buf(),
                    at: crate::scene::Location::Element("vertex", i as u64),
                    reason: "normal is zero".into(),
                });
            };
            let radius = v.radius.as_ref().map_or(0.0, |r| r[i]);
            if v.radius.is_some() && radius <= 0.0 {
                return Err(SceneLoadError::Malformed {
                    path: path.to_path_buf(),
                    at: crate::scene::Location::Element("vertex", i as u64),
                    reason: format!("radius {radius} is not positive"),
                });
            }
            points.push(CloudPoint { pos: *p, normal: n, radius, material: 0 });
        }
        let source = if v.radius.is_some() { RadiusSource::File } else { RadiusSource::Density };
        if source == RadiusSource::Density {
            density_radii(&mut points).map_err(malformed)?;
        }
        let materials = match &v.colour {
            Some(c) => palette(&mut points, c),
            None => vec![DEFAULT_MATERIAL],
        };
        Ok(Self { points, materials, radius: source })
    }

    /// A mesh's vertices as a cloud (`--points`): each distinct vertex once, its normal the
    /// area-weighted average of the faces around it (two-sided, so its sign does not matter),
    /// its colour the material of its first face, its radius from density.
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, String> {
        let mut index: HashMap<[u32; 3], usize> = HashMap::new();
        let mut sums: Vec<([f32; 3], [f64; 3], u32)> = Vec::new();
        for t in &mesh.triangles {
            let [a, b, c] = t.v.map(|p| p.map(f64::from));
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            for p in t.v {
                let key = p.map(f32::to_bits);
                let i = *index.entry(key).or_insert_with(|| {
                    sums.push((p, [0.0; 3], t.material));
                    sums.len() - 1
                });
                for (s, v) in sums[i].1.iter_mut().zip(n) {
                    *s += v;
                }
            }
        }
        let mut points: Vec<CloudPoint> = sums
            .iter()
            .filter_map(|(p, n, m)| {
                let n = unit(n.map(|v| v as f32))?;
                Some(CloudPoint { pos: *p, normal: n, radius: 0.0, material: *m as u16 })
            })
            .collect();
        if points.is_empty() {
            return Err("the mesh has no vertex with a defined normal".into());
        }
        density_radii(&mut points)?;
        let colours: Vec<[f32; 3]> = points
            .iter()
            .map(|p| mesh.materials.get(p.material as usize).copied().unwrap_or(DEFAULT_MATERIAL).diffuse)
            .collect();
        let materials = palette(&mut points, &colours);
        Ok(Self { points, materials, radius: RadiusSource::Density })
    }

    /// Box of the centres grown by each disk's radius.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3] };
        for p in &self.points {
            for i in 0..3 {
                b.min[i] = b.min[i].min(p.pos[i] - p.radius);
                b.max[i] = b.max[i].max(p.pos[i] + p.radius);
            }
        }
        b
    }

    /// A random subset per board (point splatting): point i goes to board `rng() mod n`, the
    /// generator seeded so every run splits alike. Every subset keeps the whole palette.
    pub fn split(&self, n: usize, seed: u64) -> Vec<PointCloud> {
        let n = n.max(1);
        let mut out: Vec<PointCloud> = (0..n)
            .map(|_| PointCloud { points: Vec::new(), materials: self.materials.clone(), radius: self.radius })
            .collect();
        let mut state = seed ^ 0x9E37_79B9_7F4A_7C15;
        for p in &self.points {
            // SplitMix64.
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            out[(z % n as u64) as usize].points.push(*p);
        }
        out
    }
}

fn unit(n: [f32; 3]) -> Option<[f32; 3]> {
    let l = (n[0] as f64).hypot(n[1] as f64).hypot(n[2] as f64);
    (l > 0.0 && l.is_finite()).then(|| n.map(|c| (c as f64 / l) as f32))
}

/// Sets every radius to the distance to its [`KNN`]-th nearest neighbour (point splatting: the
/// denser the neighbourhood, the smaller the disk), found with a uniform grid.
pub fn density_radii(points: &mut [CloudPoint]) -> Result<(), String> {
    let n = points.len();
    if n < 2 {
        return Err(format!("a radius from density needs at least 2 points, the cloud has {n}"));
    }
    let k = KNN.min(n - 1);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points.iter() {
        for i in 0..3 {
            lo[i] = lo[i].min(p.pos[i] as f64);
            hi[i] = hi[i].max(p.pos[i] as f64);
        }
    }
    let diag = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt();
    if diag.is_nan() || diag <= 0.0 {
        return Err("all points coincide: no density to derive radii from".into());
    }
    // About 4 points per cell on a surface spanning the box.
    let h = (diag * 2.0 / (n as f64).sqrt()).max(diag * 1e-6);
    let cell = |p: [f32; 3]| -> [i64; 3] { [0, 1, 2].map(|i| ((p[i] as f64 - lo[i]) / h).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        grid.entry(cell(p.pos)).or_default().push(i as u32);
    }
    // Rings of cells around the point's cell; an isolated point (nothing within 16 cells)
    // falls back to a scan of the whole cloud, so outliers cost O(n), not O(rings³).
    let max_ring = ((diag / h).ceil() as i64 + 1).min(16);
    let consider = |best: &mut Vec<f64>, p: [f32; 3], q: [f32; 3]| {
        let d2: f64 = (0..3).map(|a| (q[a] as f64 - p[a] as f64).powi(2)).sum();
        if best.len() < k || d2 < best[k - 1] {
            let at = best.partition_point(|&b| b <= d2);
            best.insert(at, d2);
            best.truncate(k);
        }
    };
    let radii: Vec<f32> = (0..n)
        .map(|i| {
            let p = points[i].pos;
            let c = cell(p);
            let mut best: Vec<f64> = Vec::with_capacity(k + 1);
            let mut done = false;
            for r in 0..=max_ring {
                for dx in -r..=r {
                    for dy in -r..=r {
                        for dz in -r..=r {
                            if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                                continue;
                            }
                            let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                            for &j in list.iter().filter(|&&j| j as usize != i) {
                                consider(&mut best, p, points[j as usize].pos);
                            }
                        }
                    }
                }
                // Every point of ring r + 1 is at least r·h away.
                if best.len() == k && best[k - 1] <= (r as f64 * h).powi(2) {
                    done = true;
                    break;
                }
            }
            if !done {
                best.clear();
                for (_, q) in points.iter().enumerate().filter(|&(j, _)| j != i) {
                    consider(&mut best, p, q.pos);
                }
            }
            best.last().map_or(h, |d2| d2.sqrt()) as f32
        })
        .collect();
    for (p, r) in points.iter_mut().zip(radii) {
        // Coincident points would get radius 0: give them the cell size instead.
        p.radius = if r > 0.0 { r } else { h as f32 };
    }
    Ok(())
}

/// Quantises colours to a palette of at most 64 (4 levels per channel; each entry the mean
/// of its points) and sets every point's material; returns the palette.
fn palette(points: &mut [CloudPoint], colours: &[[f32; 3]]) -> Vec<Material> {
    let mut bins: HashMap<u32, (usize, [f64; 3], u32)> = HashMap::new();
    let mut order = Vec::new();
    for (p, c) in points.iter_mut().zip(colours) {
        let q = c.map(|v| ((v.clamp(0.0, 1.0) * 3.999) as u32).min(3));
        let key = q[0] << 4 | q[1] << 2 | q[2];
        let next = bins.len();
        let e = bins.entry(key).or_insert_with(|| {
            order.push(key);
            (next, [0.0; 3], 0)
        });
        for (s, v) in e.1.iter_mut().zip(c) {
            *s += *v as f64;
        }
        e.2 += 1;
        p.material = e.0 as u16;
    }
    debug_assert!(order.len() <= MAX_PALETTE);
    order
        .iter()
        .map(|k| {
            let (_, s, n) = bins[k];
            Material { diffuse: s.map(|v| (v / n as f64) as f32), reflect: 0.0 }
        })
        .collect()
}
