//! `[[objects]]` → triangles (meshes, transformed), analytic primitives and the object table.

use std::path::Path;

use gridrt_shared::scene::{LightingRecord, MaterialModel, ObjectKind, ObjectRecord, PrimKind};
use toml::Spanned;

use super::error::{line_of, Ctx, SceneFileError};
use super::materials::MaterialTable;
use super::schema::{finite3, ObjectDef, ObjectType, ScaleDef};
use crate::render_settings::RenderSettings;
use crate::scene::analytic::AnalyticPrim;
use crate::scene::error::SceneLoadError;
use crate::scene::mesh::{Bounds, Mesh, Triangle, DEFAULT_MATERIAL};
use crate::scene::model::Scene;
use crate::scene::transform::{apply_point, compose, invert, to_wire, trs, Affine64, IDENTITY};

/// A plane waiting for the default extent: (object index, transform, material, extent, span).
type PendingPlane = (usize, Affine64, u32, Option<f64>, std::ops::Range<usize>);

/// The scene's geometry: mesh triangles first, then the analytic primitives in file order.
pub(super) struct Geometry {
    /// Triangles of every mesh, in world space.
    pub(super) triangles: Vec<Triangle>,
    /// Analytic primitives (planes as squares).
    pub(super) prims: Vec<AnalyticPrim>,
    /// One record per object: meshes, then primitives.
    pub(super) objects: Vec<ObjectRecord>,
}

/// The file's objects; a mesh's own materials are appended to `mats`.
pub(super) fn objects(
    cx: &Ctx<'_>,
    defs: &[Spanned<ObjectDef>],
    mats: &mut MaterialTable,
    load_mesh: &dyn Fn(&Path) -> Result<Mesh, SceneLoadError>,
) -> Result<Geometry, SceneFileError> {
    // Objects.
    let mut triangles: Vec<Triangle> = Vec::new();
    let mut prims: Vec<(AnalyticPrim, ObjectKind, usize)> = Vec::new();
    let mut mesh_objects: Vec<ObjectRecord> = Vec::new();
    let mut planes: Vec<PendingPlane> = Vec::new();
    if defs.is_empty() {
        return Err(SceneFileError::Syntax {
            path: cx.path.to_path_buf(),
            message: "the scene has no [[objects]]".into(),
        });
    }
    for (i, o) in defs.iter().enumerate() {
        let span = o.span();
        let o = o.get_ref();
        let table = format!("objects[{i}] ({:?})", o.kind).to_lowercase();
        let err = |field: &str, reason: String| cx.field(span.clone(), table.clone(), field, reason);
        let material = match &o.material {
            None => None,
            Some(name) => {
                Some(*mats.index_of.get(name).ok_or_else(|| err("material", format!("no material named `{name}`")))?)
            }
        };
        let scale = match o.scale {
            None => [1.0; 3],
            Some(ScaleDef::Uniform(s)) => [s; 3],
            Some(ScaleDef::Axes(s)) => s,
        };
        if !finite3(scale) || scale.contains(&0.0) {
            return Err(err("scale", "must be finite and non-zero".into()));
        }
        if !finite3(o.translate) {
            return Err(err("translate", "must be finite".into()));
        }
        if !finite3(o.rotate) {
            return Err(err("rotate", "must be finite".into()));
        }
        if o.file.is_some() != (o.kind == ObjectType::Mesh) {
            return Err(err("file", "a mesh needs `file`; other objects must not have one".into()));
        }
        if o.extent.is_some() && o.kind != ObjectType::Plane {
            return Err(err("extent", "only planes have an extent".into()));
        }
        let m = trs(o.translate, o.rotate, scale);
        let kind = match o.kind {
            ObjectType::Mesh => {
                let file = o.file.as_deref().unwrap_or(Path::new(""));
                let mesh = load_mesh(file).map_err(|source| SceneFileError::Mesh {
                    path: cx.path.to_path_buf(),
                    line: line_of(cx.text, span.start),
                    table: table.clone(),
                    source: Box::new(source),
                })?;
                // The mesh's own MTL materials follow the file's materials.
                let base = mats.materials.len() as u32;
                for (k, mm) in mesh.materials.iter().enumerate().skip(1) {
                    mats.materials.push(*mm);
                    mats.models.push(MaterialModel::default());
                    mats.names.push(format!("{}#{k}", file.display()));
                }
                let b = mesh.bounds().unwrap_or(Bounds { min: [-1.0; 3], max: [1.0; 3] });
                // Texture space: the mesh's own bounds mapped to [−1, 1]³, then the transform.
                let c = b.center();
                let e = b.extent().map(|v| (v * 0.5).max(1e-9));
                let to_unit = [
                    [1.0 / e[0], 0.0, 0.0, -c[0] / e[0]],
                    [0.0, 1.0 / e[1], 0.0, -c[1] / e[1]],
                    [0.0, 0.0, 1.0 / e[2], -c[2] / e[2]],
                ];
                let world_to_object = compose(&to_unit, &invert(&m).unwrap_or(IDENTITY));
                let first = triangles.len() as u32;
                for t in &mesh.triangles {
                    let mat = material.unwrap_or(if t.material == 0 { 0 } else { base + t.material - 1 });
                    let v = t.v.map(|p| {
                        let q = apply_point(&m, p.map(|c| c as f64));
                        q.map(|c| c as f32)
                    });
                    triangles.push(Triangle { v, material: mat });
                }
                mesh_objects.push(ObjectRecord {
                    kind: ObjectKind::Mesh,
                    material: material.unwrap_or(0) as u16,
                    first_prim: first,
                    prim_count: mesh.triangles.len() as u32,
                    world_to_object: to_wire(&world_to_object),
                });
                continue;
            }
            ObjectType::Plane => {
                if let Some(e) = o.extent {
                    if !(e.is_finite() && e > 0.0) {
                        return Err(err("extent", "must be positive".into()));
                    }
                }
                planes.push((i, m, material.unwrap_or(0), o.extent, span.clone()));
                continue;
            }
            ObjectType::Sphere => PrimKind::Sphere,
            ObjectType::Disk => PrimKind::Disk,
            ObjectType::Square => PrimKind::Square,
            ObjectType::Cylinder => PrimKind::Cylinder,
            ObjectType::Cone => PrimKind::Cone,
        };
        let p = AnalyticPrim::new(kind, material.unwrap_or(0), m)
            .ok_or_else(|| err("scale", "the transform is singular".into()))?;
        prims.push((p, Scene::object_kind(kind), i));
    }

    // Planes become squares of half-size `extent` (default: twice the diagonal of the other
    // objects' bounds, at least 1) centred at `translate`.
    let finite_world = Scene {
        mesh: Mesh { triangles: triangles.clone(), materials: vec![DEFAULT_MATERIAL], stats: Default::default() },
        material_model: vec![],
        prims: prims.iter().map(|p| p.0).collect(),
        objects: vec![],
        lighting: LightingRecord::default(),
        settings: RenderSettings::default_for(&Bounds { min: [-1.0; 3], max: [1.0; 3] }),
        material_names: vec![],
        camera_path: vec![],
    };
    let default_extent = finite_world.bounds().map_or(10.0, |b| (2.0 * b.diagonal_len()).max(1.0));
    for (i, m, material, extent, span) in planes {
        let e = extent.unwrap_or(default_extent);
        let m = compose(&m, &trs([0.0; 3], [0.0; 3], [e, 1.0, e]));
        let p = AnalyticPrim::new(PrimKind::Square, material, m)
            .ok_or_else(|| cx.field(span, format!("objects[{i}] (plane)"), "scale", "the transform is singular"))?;
        prims.push((p, ObjectKind::Plane, i));
    }
    // Keep analytic primitives in file order (ids are stable under edits of other objects).
    prims.sort_by_key(|p| p.2);

    // Object table: meshes first (their prim ids come first), then the primitives.
    let t = triangles.len() as u32;
    let mut objects = mesh_objects;
    for (k, (p, kind, _)) in prims.iter().enumerate() {
        objects.push(ObjectRecord {
            kind: *kind,
            material: p.material as u16,
            first_prim: t + k as u32,
            prim_count: 1,
            world_to_object: p.to_object,
        });
    }

    Ok(Geometry { triangles, prims: prims.into_iter().map(|p| p.0).collect(), objects })
}
