//! Wavefront OBJ loading (via `tobj`, materials from MTL `Kd`). Malformed input never panics;
//! a pre-scan locates what `tobj` would only reject, so errors name the file and the line.

use std::cell::RefCell;
use std::io::Cursor;
use std::path::Path;

use gridrt_shared::scene::Material;

use super::error::{read_file, Location, SceneLoadError};
use super::mesh::{Mesh, Triangle, DEFAULT_MATERIAL};

/// Loads an OBJ file (polygons are fan-triangulated by tobj; points and lines are ignored).
///
/// MTL files named by `mtllib` are looked up next to the OBJ. A missing MTL file is a warning
/// (faces fall back to material 0); a malformed one is an error. Material `i` of the MTL
/// becomes material `i + 1`; its `Kd` (clamped to `[0, 1]`) is the diffuse colour.
pub fn load_obj(path: &Path) -> Result<Mesh, SceneLoadError> {
    let bytes = read_file(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_obj_bytes(path, &bytes, &|name| std::fs::read(dir.join(name)))
}

/// Loads OBJ text already in memory. `read_mtl` opens an MTL file named by `mtllib`
/// (relative name as written in the OBJ). `name` labels errors.
pub fn load_obj_bytes(
    name: &Path,
    bytes: &[u8],
    read_mtl: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<Mesh, SceneLoadError> {
    let text = std::str::from_utf8(bytes).map_err(|e| SceneLoadError::Malformed {
        path: name.to_path_buf(),
        at: Location::Line(line_of_offset(bytes, e.valid_up_to())),
        reason: "not UTF-8 text".into(),
    })?;
    // Locate errors ourselves first: tobj's errors carry no line number, and a few malformed
    // inputs would make it panic (e.g. `Kd` with two values in an MTL file).
    prescan_obj(name, text)?;

    let mtl_problem: RefCell<Option<SceneLoadError>> = RefCell::new(None);
    let warnings: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let loader = |p: &Path| -> tobj::MTLLoadResult {
        let mtl_name = name.parent().map(|d| d.join(p)).unwrap_or_else(|| p.to_path_buf());
        let data = match read_mtl(p) {
            Ok(d) => d,
            Err(e) => {
                warnings
                    .borrow_mut()
                    .push(format!("{}: cannot read MTL ({e}); using the default material", mtl_name.display()));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        let checked = std::str::from_utf8(&data)
            .map_err(|e| SceneLoadError::Malformed {
                path: mtl_name.clone(),
                at: Location::Line(line_of_offset(&data, e.valid_up_to())),
                reason: "not UTF-8 text".into(),
            })
            .and_then(|t| prescan_mtl(&mtl_name, t));
        if let Err(e) = checked {
            mtl_problem.borrow_mut().get_or_insert(e);
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut Cursor::new(data))
    };
    // `..Default::default()` is needed when tobj's optional `merging`/`reordering` features
    // are unified in by another crate; they add fields we want off.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let result = tobj::load_obj_buf(&mut Cursor::new(bytes), &opts, loader);
    if let Some(e) = mtl_problem.into_inner() {
        return Err(e);
    }
    let (models, mtl) = result.map_err(|source| SceneLoadError::Obj { path: name.to_path_buf(), source })?;
    let mut stats_warnings = warnings.into_inner();

    let mut materials = vec![DEFAULT_MATERIAL];
    match mtl {
        Ok(ms) => {
            for m in ms {
                let kd = m.diffuse.unwrap_or(DEFAULT_MATERIAL.diffuse);
                if kd.iter().any(|c| !c.is_finite()) {
                    return Err(SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: Location::File,
                        reason: format!("material `{}` has a non-finite Kd", m.name),
                    });
                }
                materials.push(Material { diffuse: kd.map(|c| c.clamp(0.0, 1.0)), reflect: 0.0 });
            }
        }
        Err(e) => {
            if stats_warnings.is_empty() {
                stats_warnings
                    .push(format!("{}: materials not loaded ({e}); using the default material", name.display()));
            }
        }
    }

    let mut tris = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(id) if id + 1 < materials.len() => (id + 1) as u32,
            _ => 0,
        };
        for face in mesh.indices.chunks_exact(3) {
            let mut v = [[0.0f32; 3]; 3];
            for (k, &idx) in face.iter().enumerate() {
                let base = idx as usize * 3;
                let p = mesh.positions.get(base..base + 3).ok_or_else(|| SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::File,
                    reason: format!("object `{}`: index {idx} outside its vertex list", model.name),
                })?;
                v[k] = [p[0], p[1], p[2]];
            }
            tris.push(Triangle { v, material });
        }
    }
    let mut mesh = Mesh::from_triangles(name, tris, materials)?;
    mesh.stats.warnings = stats_warnings;
    Ok(mesh)
}

fn line_of_offset(bytes: &[u8], offset: usize) -> u64 {
    bytes.get(..offset).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count() as u64) + 1
}

/// Checks the parts of an OBJ file that tobj reports without a location: vertex coordinates
/// (count, syntax, finiteness, `w` scaling) and face indices (syntax, range, relative indices).
fn prescan_obj(name: &Path, text: &str) -> Result<(), SceneLoadError> {
    let mut vertices: u64 = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i as u64 + 1;
        let at = || Location::Line(line_no);
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let vals: Vec<&str> = words.collect();
                let malformed =
                    |reason: String| SceneLoadError::Malformed { path: name.to_path_buf(), at: at(), reason };
                if vals.len() < 3 {
                    return Err(malformed(format!("vertex needs 3 coordinates, found {}", vals.len())));
                }
                let mut xyz = [0.0f32; 3];
                for (k, s) in vals.iter().take(3).enumerate() {
                    xyz[k] = s.parse::<f32>().map_err(|_| malformed(format!("`{s}` is not a number")))?;
                }
                if vals.len() == 4 {
                    let w = vals[3].parse::<f32>().map_err(|_| malformed(format!("`{}` is not a number", vals[3])))?;
                    if w == 0.0 {
                        return Err(malformed("vertex w is zero".into()));
                    }
                    xyz = xyz.map(|c| c / w);
                }
                if xyz.iter().any(|c| !c.is_finite()) {
                    return Err(SceneLoadError::NonFinite { path: name.to_path_buf(), at: at() });
                }
                vertices += 1;
            }
            Some("f") => {
                let mut count = 0;
                for w in words {
                    count += 1;
                    let first = w.split('/').next().unwrap_or("");
                    let index: i64 = first.parse().map_err(|_| SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: at(),
                        reason: format!("`{w}` is not a face vertex index"),
                    })?;
                    let ok = if index < 0 {
                        index.unsigned_abs() <= vertices
                    } else {
                        index >= 1 && index as u64 <= vertices
                    };
                    if !ok {
                        return Err(SceneLoadError::IndexOutOfRange {
                            path: name.to_path_buf(),
                            at: at(),
                            index,
                            vertex_count: vertices,
                        });
                    }
                }
                if count == 0 {
                    return Err(SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: at(),
                        reason: "face without vertices".into(),
                    });
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks colour statements of an MTL file (tobj panics on fewer than three values).
fn prescan_mtl(name: &Path, text: &str) -> Result<(), SceneLoadError> {
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let vals: Vec<&str> = words.collect();
            let ok = vals.len() >= 3 && vals.iter().take(3).all(|s| s.parse::<f32>().is_ok_and(f32::is_finite));
            if !ok {
                return Err(SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::Line(i as u64 + 1),
                    reason: format!("`{key}` needs three finite numbers"),
                });
            }
        }
    }
    Ok(())
}
