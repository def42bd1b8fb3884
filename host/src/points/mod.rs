//! Point clouds and the point-splatting renderer on the host side: loading (PLY point clouds,
//! meshes as clouds), density radii and palettes (`cloud`), the cloud as a scene of disks
//! plus the scene image's point section (`image`), and splat frames on one or several boards
//! with sort-last compositing (`render`).
//!
//! | file | what |
//! |---|---|
//! | `cloud` | [`PointCloud`]: from PLY vertices or a mesh, k-NN radii, palette, random split |
//! | `knn` | the k nearest neighbours of every point (a uniform grid) |
//! | `normals` | normals of an `x y z`-only cloud: k-NN PCA, oriented along a spanning tree |
//! | `image` | disks for the ray tracer and the reference, the point section, [`prepare`] |
//! | `render` | the splat request, [`composite`], [`render_sort_last`], [`SplatReport`] |
//! | `synthetic` | seeded clouds on analytic surfaces, a PLY writer |
//!
//! `gridrt bench splat` (native splats/s and image error per cloud size and table) is
//! [`crate::bench::splat`].

mod cloud;
mod image;
mod knn;
mod normals;
mod render;
pub mod synthetic;

use std::path::Path;

pub use cloud::{density_radii, CloudPoint, PointCloud, RadiusSource, KNN, MAX_PALETTE, RADIUS_SCALE};
pub use image::{cloud_scene, disk, point_section, prepare, with_points};
pub use normals::{estimate as estimate_normals, NORMAL_KNN};
pub use render::{composite, render_sort_last, splat_request, SplatReport, MAX_SPLAT_WIDTH};

use crate::scene::{self, LoadError, Scene, SceneLoadError};

/// What a scene file turned out to be.
#[derive(Debug, Clone)]
pub enum Input {
    /// Triangles and analytic primitives: ray traced.
    Scene(Box<Scene>),
    /// A point cloud (normals from the file or estimated): splatted.
    Cloud(PointCloud),
}

/// Loads `path`: a PLY with vertices and no faces is a point cloud; with `as_points` any mesh
/// becomes one (its vertices with averaged normals); everything else is a scene.
pub fn load(path: &Path, as_points: bool) -> Result<Input, LoadError> {
    let is_ply = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("ply"));
    if is_ply {
        let v = scene::load_ply_vertices(path)?;
        if v.faces == 0 {
            return Ok(Input::Cloud(PointCloud::from_ply(path, v)?));
        }
    }
    let s = scene::load(path)?;
    if !as_points {
        return Ok(Input::Scene(Box::new(s)));
    }
    PointCloud::from_mesh(&s.mesh).map(Input::Cloud).map_err(|reason| {
        LoadError::Mesh(SceneLoadError::Malformed { path: path.to_path_buf(), at: scene::Location::File, reason })
    })
}
