//! The TOML scene file (docs/SCENE-FILE.md): camera, light, materials, textures and objects
//! (OBJ meshes with MTL, or ViRAY's analytic primitives with transforms) → [`Scene`].
//!
//! Errors name the file, the line and the field: syntax and type errors come from `toml`
//! (line, column and the offending text); semantic errors (unknown material, zero scale, …)
//! carry the line of the table they occur in, from `toml::Spanned`.

use std::path::Path;

use super::error::SceneLoadError;
use super::mesh::{Bounds, Mesh};
use super::mesh_file::load_mesh;
use super::model::Scene;
use crate::render_settings::{Camera, RenderSettings, DEFAULT_HEIGHT, DEFAULT_WIDTH};

mod error;
mod lighting;
mod materials;
mod objects;
mod schema;
#[cfg(test)]
mod tests;

pub use error::SceneFileError;

use error::Ctx;
use schema::{f3, finite3, FileDef};

/// Loads a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneFileError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| SceneFileError::Io { path: path.to_path_buf(), source })?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse(path, &text, &|p| load_mesh(&dir.join(p)))
}

/// Parses scene-file text; `load_mesh` loads a mesh file named by an object (path relative
/// to the scene file).
pub fn parse(
    path: &Path,
    text: &str,
    load_mesh: &dyn Fn(&Path) -> Result<Mesh, SceneLoadError>,
) -> Result<Scene, SceneFileError> {
    let def: FileDef = toml::from_str(text).map_err(|e| SceneFileError::Syntax {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let cx = Ctx { path, text };

    let mut table = materials::materials(&cx, &def)?;
    let geometry = objects::objects(&cx, &def.objects, &mut table, load_mesh)?;
    let (lighting, ambient) = lighting::render(&cx, def.render.as_ref())?;

    let mut world = Scene {
        mesh: Mesh { triangles: geometry.triangles, materials: table.materials, stats: Default::default() },
        material_model: table.models,
        prims: geometry.prims,
        objects: geometry.objects,
        lighting,
        settings: RenderSettings::default_for(&Bounds { min: [-1.0; 3], max: [1.0; 3] }),
        material_names: table.names,
        camera_path: Vec::new(),
    };
    let bounds = world.bounds().unwrap_or(Bounds { min: [-1.0; 3], max: [1.0; 3] });
    let mut settings = RenderSettings::default_for(&bounds);
    settings.ambient = ambient as f32;
    lighting::light(&cx, def.light.as_ref(), &mut world.lighting, &mut settings)?;
    if let Some(c) = &def.camera {
        let span = c.span();
        let c = c.get_ref();
        if !finite3(c.eye) || !finite3(c.target) || !finite3(c.up) {
            return Err(cx.field(span, "camera", "eye", "eye, target and up must be finite"));
        }
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return Err(cx.field(span, "camera", "fov", "must be in (0, 180) degrees"));
        }
        if c.eye == c.target {
            return Err(cx.field(span, "camera", "target", "must differ from eye"));
        }
        settings.camera = Camera { eye: f3(c.eye), target: f3(c.target), up: f3(c.up), fov_y_deg: c.fov as f32 };
        settings.width = c.width.unwrap_or(DEFAULT_WIDTH);
        settings.height = c.height.unwrap_or(DEFAULT_HEIGHT);
        if settings.width == 0 || settings.height == 0 {
            return Err(cx.field(span, "camera", "width", "width and height must be ≥ 1"));
        }
    }
    world.settings = settings;
    for k in &def.camera_path {
        let span = k.span();
        let k = k.get_ref();
        let base = world.settings.camera;
        let up = k.up.map_or(base.up, f3);
        let fov = k.fov.unwrap_or(f64::from(base.fov_y_deg));
        if !finite3(k.eye) || !finite3(k.target) || !up.iter().all(|c| c.is_finite()) {
            return Err(cx.field(span, "camera_path", "eye", "eye, target and up must be finite"));
        }
        if !(fov > 0.0 && fov < 180.0) {
            return Err(cx.field(span, "camera_path", "fov", "must be in (0, 180) degrees"));
        }
        if k.eye == k.target {
            return Err(cx.field(span, "camera_path", "target", "must differ from eye"));
        }
        world.camera_path.push(Camera { eye: f3(k.eye), target: f3(k.target), up, fov_y_deg: fov as f32 });
    }
    if world.mesh.triangles.is_empty() && world.prims.is_empty() {
        return Err(SceneFileError::Syntax { path: path.to_path_buf(), message: "the scene has no geometry".into() });
    }
    Ok(world)
}
