//! Mesh files by extension: `.obj` (with `.mtl` materials) or `.ply`.

use std::path::Path;

use super::error::SceneLoadError;
use super::mesh::Mesh;
use super::obj::load_obj;
use super::ply::load_ply;

/// Loads a mesh file by extension (`.obj` or `.ply`, case-insensitive).
pub fn load_mesh(path: &Path) -> Result<Mesh, SceneLoadError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("ply") => load_ply(path),
        _ => Err(SceneLoadError::UnsupportedFormat { path: path.to_path_buf() }),
    }
}
