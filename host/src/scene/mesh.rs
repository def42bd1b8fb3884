//! A triangle mesh as the loaders produce it: triangles whose index is the global primitive
//! id, plus a material table whose entry 0 is always the default grey ([`DEFAULT_MATERIAL`]).
//!
//! Policy for bad geometry:
//! - NaN or infinite vertex coordinates are an error (the device must never see them).
//! - A face index outside the vertex list is an error.
//! - Zero-area triangles (exactly zero cross product in f64, e.g. repeated vertices) are
//!   dropped and counted in [`LoadStats::dropped_degenerate`]; they can never be hit.
//! - A mesh without any remaining triangle is an error.

use std::path::Path;

use gridrt_shared::scene::Material;

use super::error::{Location, SceneLoadError};
pub use crate::bounds::Bounds;

/// Material 0: what faces without a material (or with an unknown one) use.
pub const DEFAULT_MATERIAL: Material = Material { diffuse: [0.8, 0.8, 0.8], reflect: 0.0 };

/// One triangle of a loaded mesh. Its index in [`Mesh::triangles`] is its primitive id.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// Vertices a, b, c (counter-clockwise as in the file).
    pub v: [[f32; 3]; 3],
    /// Index into [`Mesh::materials`].
    pub material: u32,
}

/// Counters of one load, for the statistics report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadStats {
    /// Triangles read from the file (after triangulating polygons), before dropping.
    pub triangles_read: u64,
    /// Zero-area triangles that were dropped.
    pub dropped_degenerate: u64,
    /// Non-fatal findings (e.g. a referenced MTL file that could not be opened).
    pub warnings: Vec<String>,
}

/// A triangle mesh ready for grid building.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Triangles; the index is the primitive id.
    pub triangles: Vec<Triangle>,
    /// Material table; entry 0 is [`DEFAULT_MATERIAL`].
    pub materials: Vec<Material>,
    /// What happened during loading.
    pub stats: LoadStats,
}

impl Mesh {
    /// Bounding box of all triangle vertices. `None` for an empty mesh.
    pub fn bounds(&self) -> Option<Bounds> {
        let mut it = self.triangles.iter().flat_map(|t| t.v.iter());
        let first = *it.next()?;
        let mut b = Bounds { min: first, max: first };
        for p in it {
            for (i, &c) in p.iter().enumerate() {
                b.min[i] = b.min[i].min(c);
                b.max[i] = b.max[i].max(c);
            }
        }
        Some(b)
    }

    /// Builds a mesh from triangles, dropping zero-area ones. Fails on non-finite
    /// coordinates, a material index outside `materials`, or an empty result.
    /// `materials` must start with the default material.
    pub fn from_triangles(
        name: &Path,
        triangles: impl IntoIterator<Item = Triangle>,
        materials: Vec<Material>,
    ) -> Result<Self, SceneLoadError> {
        let mut stats = LoadStats::default();
        let mut out = Vec::new();
        for (i, t) in triangles.into_iter().enumerate() {
            stats.triangles_read += 1;
            if t.v.iter().flatten().any(|c| !c.is_finite()) {
                return Err(SceneLoadError::NonFinite {
                    path: name.to_path_buf(),
                    at: Location::Element("triangle", i as u64),
                });
            }
            if t.material as usize >= materials.len() {
                return Err(SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::Element("triangle", i as u64),
                    reason: format!("material {} does not exist ({} materials)", t.material, materials.len()),
                });
            }
            if is_degenerate(&t.v) {
                stats.dropped_degenerate += 1;
            } else {
                out.push(t);
            }
        }
        if out.is_empty() {
            return Err(SceneLoadError::EmptyMesh { path: name.to_path_buf(), dropped: stats.dropped_degenerate });
        }
        Ok(Self { triangles: out, materials, stats })
    }
}

/// True when the triangle has exactly zero area (cross product computed in f64, which is
/// exact for the products of f32 differences up to rounding of the sum; a triangle this
/// test keeps has a non-zero f64 normal).
pub fn is_degenerate(v: &[[f32; 3]; 3]) -> bool {
    let d = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|i| b[i] as f64 - a[i] as f64);
    let (e1, e2) = (d(v[0], v[1]), d(v[0], v[2]));
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0
}
