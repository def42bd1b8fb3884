//! The host's one scene model ([`Scene`]: meshes, analytic primitives, materials, textures,
//! lights, camera) and its loaders. A mesh file (OBJ via `tobj`, PLY) is simply a scene with
//! defaults; a TOML scene file (docs/SCENE-FILE.md) sets everything.
//!
//! | file | what |
//! |---|---|
//! | `model` | [`Scene`] |
//! | `mesh` | [`Mesh`], [`Triangle`], [`Bounds`]: the triangles of a scene |
//! | `analytic` | [`AnalyticPrim`]: ViRAY's sphere, cylinder, cone, disk, square |
//! | `transform` | f64 affine maps and their f32 wire form |
//! | `file` | the TOML scene file (`schema`, `materials`, `objects`, `lighting`) |
//! | `mesh_file`, `obj`, `ply` | mesh files |
//! | `error` | [`SceneLoadError`] with file and line |
//!
//! Malformed input never panics; it becomes an error naming the file and the line (text
//! formats) or the element index (binary PLY).

mod analytic;
mod error;
mod file;
mod mesh;
mod mesh_file;
mod model;
mod obj;
mod ply;
pub mod transform;

use std::path::Path;

pub use analytic::AnalyticPrim;
pub use error::{Location, SceneLoadError};
pub use file::{parse as parse_scene_file, SceneFileError};
pub use mesh::{is_degenerate, Bounds, LoadStats, Mesh, Triangle, DEFAULT_MATERIAL};
pub use mesh_file::load_mesh;
pub use model::Scene;
pub use obj::{load_obj, load_obj_bytes};
pub use ply::{load_ply, load_ply_bytes, load_ply_vertices, load_ply_vertices_bytes, PlyVertices};

/// Why a scene could not be loaded: a mesh file's error or a scene file's.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// An OBJ or PLY file.
    #[error(transparent)]
    Mesh(#[from] SceneLoadError),
    /// A TOML scene file.
    #[error(transparent)]
    SceneFile(#[from] SceneFileError),
}

/// Loads a scene: `.toml` as a scene file, `.obj` / `.ply` as a mesh with defaults.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    let is_toml = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        Ok(file::load(path)?)
    } else {
        Ok(Scene::from_mesh(load_mesh(path)?))
    }
}

#[cfg(test)]
mod tests;
