//! An oriented point cloud (point splatting): centres, unit normals, radii from local density,
//! and a ≤ 64-colour palette as materials; from a PLY file's vertices or a mesh's.

use std::collections::HashMap;
use std::path::Path;

use gridrt_shared::scene::Material;

use crate::scene::{Bounds, Mesh, PlyVertices, SceneLoadError, DEFAULT_MATERIAL};

/// Neighbours the density radius is measured to.
pub const KNN: usize = 8;
/// Density radius over the distance to the [`KNN`]-th neighbour. A disk of that distance
/// covers about 8 neighbours' share of the surface; 0.8 of it (≈ 5) still leaves under 1 % of
/// a randomly sampled surface uncovered, and overlaps less: with one depth per splat the
/// overlaps are where splats and ray-traced disks disagree. On unseen clouds (tilted torus,
/// sharp box, bumpy sphere; host/tests/point_clouds_unseen.rs) 0.8 lifts the PSNR against
/// the traced disks by 0.6–1.2 dB over 1.0 (box, x y z only: 30.17 → 31.33 dB); 0.65 and
/// 1.25 are worse.
pub const RADIUS_SCALE: f32 = 0.8;
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
    /// [`RADIUS_SCALE`] times the distance to the [`KNN`]-th nearest neighbour.
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
    /// A PLY file's vertices as a cloud: normals from the file or estimated from the
    /// neighbourhoods (`normals`); radius from the file or from density; colours become a
    /// palette of at most 64 materials.
    pub fn from_ply(path: &Path, v: PlyVertices) -> Result<Self, SceneLoadError> {
        let malformed = |reason: String| SceneLoadError::Malformed {
            path: path.to_path_buf(),
            at: crate::scene::Location::File,
            reason,
        };
        if v.pos.is_empty() {
            return Err(malformed("the point cloud has no vertices".into()));
        }
        let normals = match v.normal {
            Some(n) => n,
            None => super::normals::estimate(&v.pos).map_err(malformed)?,
        };
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

/// Sets every radius to [`RADIUS_SCALE`] times the distance to its [`KNN`]-th nearest
/// neighbour (point splatting: the denser the neighbourhood, the smaller the disk), at most
/// [`RADIUS_CAP`] times the median of its neighbours' radii.
pub fn density_radii(points: &mut [CloudPoint]) -> Result<(), String> {
    let pos: Vec<[f32; 3]> = points.iter().map(|p| p.pos).collect();
    let nb = super::knn::nearest(&pos, KNN)?;
    let raw: Vec<f32> = (0..points.len())
        .map(|i| {
            let r = RADIUS_SCALE * nb.of(i).last().map_or(0.0, |(_, d2)| d2.sqrt()) as f32;
            // Coincident points would get radius 0: give them the cell size instead.
            if r > 0.0 {
                r
            } else {
                nb.cell as f32
            }
        })
        .collect();
    let mut around = Vec::with_capacity(KNN);
    for (i, p) in points.iter_mut().enumerate() {
        around.clear();
        around.extend(nb.of(i).map(|(j, _)| raw[j]));
        around.sort_by(f32::total_cmp);
        let cap = around.get(around.len() / 2).map_or(f32::INFINITY, |m| RADIUS_CAP * m);
        p.radius = raw[i].min(cap);
    }
    Ok(())
}

/// Largest density radius over the median of its neighbours' radii. A point at the edge of a
/// sparse patch measures its radius to far-away points and would cover its dense neighbours
/// with one oversized disk (clipped to the device's largest splat shape); twice the local
/// median still closes the gaps between neighbours of a smoothly varying density.
pub const RADIUS_CAP: f32 = 2.0;

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

#[cfg(test)]
mod tests {
    use super::*;

    fn point(x: f32, z: f32) -> CloudPoint {
        CloudPoint { pos: [x, 0.0, z], normal: [0.0, 1.0, 0.0], radius: 0.0, material: 0 }
    }

    /// A 20×20 patch at spacing 0.01 and one stray point 0.5 away: the stray point's raw
    /// density radius (≈ 0.4) would cover the whole patch; capped, it is at most twice its
    /// neighbours' median, while the patch's own radii stay uncapped.
    #[test]
    fn a_sparse_point_beside_a_dense_patch_gets_no_oversized_disk() {
        let mut pts: Vec<CloudPoint> =
            (0..400).map(|i| point((i % 20) as f32 * 0.01, (i / 20) as f32 * 0.01)).collect();
        pts.push(point(0.69, 0.095));
        density_radii(&mut pts).unwrap();
        let patch_max = pts[..400].iter().map(|p| p.radius).fold(0.0, f32::max);
        let stray = pts[400].radius;
        assert!(stray <= 2.0 * patch_max + 1e-6 && stray < 0.05, "stray {stray}, patch up to {patch_max}");
        // Interior patch points: 0.8 × the 8th neighbour's distance (√2 · 0.01), not capped.
        let interior = pts[10 * 20 + 10].radius;
        assert!((interior - RADIUS_SCALE * 0.01 * 2f32.sqrt()).abs() < 1e-4, "{interior}");
    }
}
