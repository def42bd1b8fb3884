//! The TOML scene file (docs/SCENE-FILE.md): camera, light, materials, textures and objects
//! (OBJ meshes with MTL, or ViRAY's analytic primitives with transforms) → [`Scene`].
//!
//! Errors name the file, the line and the field: syntax and type errors come from `toml`
//! (line, column and the offending text); semantic errors (unknown material, zero scale, …)
//! carry the line of the table they occur in, from `toml::Spanned`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use gridrt_shared::scene::Material;
use gridrt_shared::scene::{
    DiffuseModel, Falloff, LightingRecord, Mapping, MaterialModel, ObjectKind, ObjectRecord, PrimKind, ReflectMode,
    SpecularModel, TextureKind, MAX_DEPTH,
};
use serde::Deserialize;
use toml::Spanned;

use super::analytic::AnalyticPrim;
use super::error::SceneLoadError;
use super::mesh::{Bounds, Mesh, Triangle, DEFAULT_MATERIAL};
use super::mesh_file::load_mesh;
use super::model::Scene;
use super::transform::{apply_point, compose, invert, to_wire, trs, Affine64, IDENTITY};
use crate::camera::{Camera, Light, RenderSettings, DEFAULT_HEIGHT, DEFAULT_WIDTH};

/// Why a scene file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// TOML syntax or a field of the wrong type / unknown field (toml's message has the line,
    /// column and the text).
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// toml's message.
        message: String,
    },
    /// A field value that is well-typed but invalid.
    #[error("{}:line {line}: {table}: field `{field}`: {reason}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// 1-based line of the table holding the field.
        line: usize,
        /// Which table (`materials.red`, `objects[2]`, …).
        table: String,
        /// The field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// A mesh referenced by the file failed to load.
    #[error("{}:line {line}: {table}: mesh: {source}", path.display())]
    Mesh {
        /// The scene file.
        path: PathBuf,
        /// Line of the object.
        line: usize,
        /// Which object.
        table: String,
        /// The loader error.
        #[source]
        source: Box<SceneLoadError>,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDef {
    camera: Option<Spanned<CameraDef>>,
    render: Option<Spanned<RenderDef>>,
    light: Option<Spanned<LightDef>>,
    #[serde(default)]
    textures: BTreeMap<String, Spanned<TextureDef>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialDef>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectDef>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    eye: [f64; 3],
    target: [f64; 3],
    #[serde(default = "up")]
    up: [f64; 3],
    #[serde(default = "fov")]
    fov: f64,
    #[serde(default)]
    width: Option<u16>,
    #[serde(default)]
    height: Option<u16>,
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn fov() -> f64 {
    45.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDef {
    #[serde(default = "one_u8")]
    max_depth: u8,
    #[serde(default)]
    background: Option<[f64; 3]>,
    #[serde(default)]
    ambient: Option<f64>,
    #[serde(default)]
    ambient_colour: Option<[f64; 3]>,
}

fn one_u8() -> u8 {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    position: [f64; 3],
    #[serde(default = "one")]
    intensity: f64,
    #[serde(default)]
    colour: Option<[f64; 3]>,
    #[serde(default)]
    falloff: FalloffDef,
    #[serde(default)]
    spot_direction: Option<[f64; 3]>,
    #[serde(default)]
    spot_outer_deg: Option<f64>,
    #[serde(default)]
    spot_inner_deg: Option<f64>,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum FalloffDef {
    #[default]
    InverseSquare,
    None,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TextureDef {
    kind: TextureKindDef,
    #[serde(default)]
    mapping: MappingDef,
    #[serde(default = "tex_size")]
    size: u32,
    #[serde(default)]
    filter: FilterDef,
    #[serde(default = "uv_one")]
    scale: [f64; 2],
    #[serde(default)]
    offset: [f64; 2],
    #[serde(default)]
    param: Option<f64>,
    #[serde(default)]
    seed: u32,
    #[serde(default)]
    colour2: Option<[f64; 3]>,
}

fn tex_size() -> u32 {
    256
}
fn uv_one() -> [f64; 2] {
    [1.0, 1.0]
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum TextureKindDef {
    Checker,
    Xor,
    Marble,
    Wood,
    RgbDots,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum MappingDef {
    #[default]
    Planar,
    Cylindrical,
    Spherical,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum FilterDef {
    #[default]
    Bilinear,
    Nearest,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    #[serde(default = "grey")]
    colour: [f64; 3],
    #[serde(default)]
    diffuse: DiffuseDef,
    #[serde(default)]
    roughness: f64,
    #[serde(default = "one")]
    ka: f64,
    #[serde(default = "one")]
    kd: f64,
    #[serde(default)]
    ks: f64,
    #[serde(default)]
    specular: SpecularDef,
    #[serde(default = "exponent")]
    exponent: f64,
    #[serde(default)]
    specular_colour: Option<[f64; 3]>,
    #[serde(default)]
    reflection: ReflectionDef,
    #[serde(default)]
    reflectivity: f64,
    #[serde(default = "ior")]
    ior: f64,
    #[serde(default)]
    k: f64,
    #[serde(default)]
    texture: Option<String>,
}

fn grey() -> [f64; 3] {
    [0.8; 3]
}
fn exponent() -> f64 {
    32.0
}
fn ior() -> f64 {
    1.5
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum DiffuseDef {
    #[default]
    Lambert,
    OrenNayar,
    Matte,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum SpecularDef {
    #[default]
    None,
    BlinnPhong,
    TorranceSparrow,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum ReflectionDef {
    #[default]
    None,
    Constant,
    Dielectric,
    Conductor,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    #[serde(rename = "type")]
    kind: ObjectType,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    file: Option<PathBuf>,
    #[serde(default)]
    translate: [f64; 3],
    #[serde(default)]
    rotate: [f64; 3],
    #[serde(default)]
    scale: Option<ScaleDef>,
    #[serde(default)]
    extent: Option<f64>,
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(untagged)]
enum ScaleDef {
    Uniform(f64),
    Axes([f64; 3]),
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum ObjectType {
    Mesh,
    Sphere,
    Plane,
    Disk,
    Square,
    Cylinder,
    Cone,
}

/// A plane waiting for the default extent: (object index, transform, material, extent, span).
type PendingPlane = (usize, Affine64, u32, Option<f64>, std::ops::Range<usize>);

/// Line (1-based) of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes().get(..at.min(text.len())).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count()) + 1
}

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    /// An error at `field` of the table spanning `span`: the line of `field = …` inside the
    /// table if it is written there, else the table's first line.
    fn field(
        &self,
        span: std::ops::Range<usize>,
        table: impl Into<String>,
        field: &str,
        reason: impl Into<String>,
    ) -> SceneFileError {
        // The table runs from its span to the next table header.
        let body = self.text.get(span.start..).unwrap_or("");
        let mut at = span.start;
        let mut offset = 0;
        for (k, l) in body.split_inclusive('\n').enumerate() {
            let key = l.trim_start();
            if k > 0 && key.starts_with('[') {
                break;
            }
            if key.strip_prefix(field).is_some_and(|r| r.trim_start().starts_with('=')) {
                at = span.start + offset;
                break;
            }
            offset += l.len();
        }
        SceneFileError::Field {
            path: self.path.to_path_buf(),
            line: line_of(self.text, at),
            table: table.into(),
            field: field.to_string(),
            reason: reason.into(),
        }
    }
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

fn f3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

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

    // Textures.
    let mut textures: BTreeMap<String, MaterialModel> = BTreeMap::new();
    for (name, t) in &def.textures {
        let span = t.span();
        let t = t.get_ref();
        let table = format!("textures.{name}");
        if !t.size.is_power_of_two() || !(2..=4096).contains(&t.size) {
            return Err(cx.field(span, table, "size", "must be a power of two in 2..=4096"));
        }
        if !(t.scale.iter().chain(t.offset.iter()).all(|v| v.is_finite())) {
            return Err(cx.field(span, table, "scale", "scale and offset must be finite"));
        }
        let param = t.param.unwrap_or(match t.kind {
            TextureKindDef::Checker | TextureKindDef::RgbDots => 8.0,
            TextureKindDef::Xor => 1.0,
            TextureKindDef::Marble => 4.0,
            TextureKindDef::Wood => 6.0,
        });
        if !(param.is_finite() && param > 0.0) {
            return Err(cx.field(span, table, "param", "must be a positive number"));
        }
        if matches!(t.kind, TextureKindDef::Checker | TextureKindDef::RgbDots)
            && (param.fract() != 0.0 || param as u32 > t.size)
        {
            return Err(cx.field(
                span,
                table,
                "param",
                format!("cells per side must be a whole number in 1..={}", t.size),
            ));
        }
        let colour2 = t.colour2.unwrap_or([0.1; 3]);
        if !finite3(colour2) {
            return Err(cx.field(span, table, "colour2", "must be finite"));
        }
        textures.insert(
            name.clone(),
            MaterialModel {
                texture: match t.kind {
                    TextureKindDef::Checker => TextureKind::Checker,
                    TextureKindDef::Xor => TextureKind::Xor,
                    TextureKindDef::Marble => TextureKind::Marble,
                    TextureKindDef::Wood => TextureKind::Wood,
                    TextureKindDef::RgbDots => TextureKind::RgbDots,
                },
                mapping: match t.mapping {
                    MappingDef::Planar => Mapping::Planar,
                    MappingDef::Cylindrical => Mapping::Cylindrical,
                    MappingDef::Spherical => Mapping::Spherical,
                },
                bilinear: matches!(t.filter, FilterDef::Bilinear),
                tex_log2: t.size.trailing_zeros() as u8,
                colour2: f3(colour2),
                uv_scale: t.scale.map(|v| v as f32),
                uv_offset: t.offset.map(|v| v as f32),
                tex_param: param as f32,
                tex_seed: t.seed,
                ..MaterialModel::default()
            },
        );
    }

    // Materials: index 0 is the default grey (OBJ faces without a material use it).
    let mut materials = vec![DEFAULT_MATERIAL];
    let mut exts = vec![MaterialModel::default()];
    let mut names = vec!["(default)".to_string()];
    let mut index_of: BTreeMap<String, u32> = BTreeMap::new();
    for (name, m) in &def.materials {
        let span = m.span();
        let m = m.get_ref();
        let table = format!("materials.{name}");
        let err = |field: &str, reason: &str| cx.field(span.clone(), table.clone(), field, reason);
        if !finite3(m.colour) || m.colour.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(err("colour", "components must be in [0, 1]"));
        }
        for (field, v) in [("ka", m.ka), ("kd", m.kd), ("ks", m.ks), ("reflectivity", m.reflectivity)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(err(field, "must be in [0, 1]"));
            }
        }
        if !(m.roughness.is_finite() && m.roughness >= 0.0) {
            return Err(err("roughness", "σ² must be ≥ 0"));
        }
        if !(m.exponent.is_finite() && (0.0..=4096.0).contains(&m.exponent)) {
            return Err(err("exponent", "must be in [0, 4096]"));
        }
        if !(m.ior.is_finite() && m.ior > 0.0) {
            return Err(err("ior", "must be > 0"));
        }
        if !(m.k.is_finite() && m.k >= 0.0) {
            return Err(err("k", "must be ≥ 0"));
        }
        let spec = m.specular_colour.unwrap_or([1.0; 3]);
        if !finite3(spec) {
            return Err(err("specular_colour", "must be finite"));
        }
        let mut ext = match &m.texture {
            None => MaterialModel::default(),
            Some(t) => *textures
                .get(t)
                .ok_or_else(|| err("texture", &format!("no texture named `{t}` (define it under [textures.{t}])")))?,
        };
        ext.diffuse_model = match m.diffuse {
            DiffuseDef::Lambert => DiffuseModel::Lambert,
            DiffuseDef::OrenNayar => DiffuseModel::OrenNayar,
            DiffuseDef::Matte => DiffuseModel::Matte,
        };
        ext.specular_model = match m.specular {
            SpecularDef::None => SpecularModel::None,
            SpecularDef::BlinnPhong => SpecularModel::BlinnPhong,
            SpecularDef::TorranceSparrow => SpecularModel::TorranceSparrow,
        };
        ext.reflect_mode = match m.reflection {
            ReflectionDef::None => ReflectMode::None,
            ReflectionDef::Constant => ReflectMode::Constant,
            ReflectionDef::Dielectric => ReflectMode::Dielectric,
            ReflectionDef::Conductor => ReflectMode::Conductor,
        };
        if matches!(m.reflection, ReflectionDef::Constant) && m.reflectivity == 0.0 {
            return Err(err("reflectivity", "constant reflection needs reflectivity > 0"));
        }
        ext.ka = m.ka as f32;
        ext.kd = m.kd as f32;
        ext.ks = m.ks as f32;
        ext.sigma2 = m.roughness as f32;
        ext.exponent = m.exponent as f32;
        ext.specular = f3(spec);
        ext.eta = m.ior as f32;
        ext.kappa = m.k as f32;
        index_of.insert(name.clone(), materials.len() as u32);
        materials.push(Material { diffuse: f3(m.colour), reflect: m.reflectivity as f32 });
        exts.push(ext);
        names.push(name.clone());
    }
    if materials.len() > u16::MAX as usize {
        return Err(SceneFileError::Syntax { path: path.to_path_buf(), message: "too many materials".into() });
    }

    // Objects.
    let mut triangles: Vec<Triangle> = Vec::new();
    let mut prims: Vec<(AnalyticPrim, ObjectKind, usize)> = Vec::new();
    let mut mesh_objects: Vec<ObjectRecord> = Vec::new();
    let mut planes: Vec<PendingPlane> = Vec::new();
    if def.objects.is_empty() {
        return Err(SceneFileError::Syntax {
            path: path.to_path_buf(),
            message: "the scene has no [[objects]]".into(),
        });
    }
    for (i, o) in def.objects.iter().enumerate() {
        let span = o.span();
        let o = o.get_ref();
        let table = format!("objects[{i}] ({:?})", o.kind).to_lowercase();
        let err = |field: &str, reason: String| cx.field(span.clone(), table.clone(), field, reason);
        let material = match &o.material {
            None => None,
            Some(name) => {
                Some(*index_of.get(name).ok_or_else(|| err("material", format!("no material named `{name}`")))?)
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
                    path: path.to_path_buf(),
                    line: line_of(text, span.start),
                    table: table.clone(),
                    source: Box::new(source),
                })?;
                // The mesh's own MTL materials follow the file's materials.
                let base = materials.len() as u32;
                for (k, mm) in mesh.materials.iter().enumerate().skip(1) {
                    materials.push(*mm);
                    exts.push(MaterialModel::default());
                    names.push(format!("{}#{k}", file.display()));
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

    // Lighting.
    let mut lighting = LightingRecord::default();
    let render = def.render.as_ref();
    if let Some(r) = render {
        let span = r.span();
        let r = r.get_ref();
        if !(1..=MAX_DEPTH).contains(&r.max_depth) {
            return Err(cx.field(
                span,
                "render",
                "max_depth",
                format!("must be in 1..={MAX_DEPTH} (1 = primary rays only)"),
            ));
        }
        lighting.max_depth = r.max_depth;
        if let Some(b) = r.background {
            if !finite3(b) {
                return Err(cx.field(span, "render", "background", "must be finite"));
            }
            lighting.background = f3(b);
        }
        if let Some(a) = r.ambient_colour {
            if !finite3(a) {
                return Err(cx.field(span, "render", "ambient_colour", "must be finite"));
            }
            lighting.ambient_colour = f3(a);
        }
    }
    let ambient = render.and_then(|r| r.get_ref().ambient).unwrap_or(0.1);
    if !ambient.is_finite() {
        return Err(cx.field(def.render.as_ref().map_or(0..0, |r| r.span()), "render", "ambient", "must be finite"));
    }

    let mesh = Mesh { triangles, materials, stats: Default::default() };
    let mut world = Scene {
        mesh,
        material_model: exts,
        prims: prims.into_iter().map(|p| p.0).collect(),
        objects,
        lighting,
        settings: RenderSettings::default_for(&Bounds { min: [-1.0; 3], max: [1.0; 3] }),
        material_names: names,
    };
    let bounds = world.bounds().unwrap_or(Bounds { min: [-1.0; 3], max: [1.0; 3] });
    let mut settings = RenderSettings::default_for(&bounds);
    settings.ambient = ambient as f32;
    match &def.light {
        None => {
            world.lighting.light_count = 0;
            settings.light = Light { pos: settings.light.pos, intensity: 0.0 };
            settings.shadows = false;
        }
        Some(l) => {
            let span = l.span();
            let l = l.get_ref();
            if !finite3(l.position) {
                return Err(cx.field(span, "light", "position", "must be finite"));
            }
            if !(l.intensity.is_finite() && l.intensity >= 0.0) {
                return Err(cx.field(span, "light", "intensity", "must be ≥ 0"));
            }
            settings.light = Light { pos: f3(l.position), intensity: l.intensity as f32 };
            world.lighting.light_count = 1;
            world.lighting.falloff = match l.falloff {
                FalloffDef::InverseSquare => Falloff::InverseSquare,
                FalloffDef::None => Falloff::None,
            };
            if let Some(c) = l.colour {
                if !finite3(c) {
                    return Err(cx.field(span, "light", "colour", "must be finite"));
                }
                world.lighting.light_colour = f3(c);
            }
            match (l.spot_direction, l.spot_outer_deg) {
                (None, None) => {
                    if l.spot_inner_deg.is_some() {
                        return Err(cx.field(
                            span,
                            "light",
                            "spot_inner_deg",
                            "needs spot_direction and spot_outer_deg",
                        ));
                    }
                }
                (Some(d), Some(outer)) => {
                    if !finite3(d) || d == [0.0; 3] {
                        return Err(cx.field(span, "light", "spot_direction", "must be finite and non-zero"));
                    }
                    let inner = l.spot_inner_deg.unwrap_or(outer);
                    if !(0.0 < outer && outer <= 180.0 && (0.0..=outer).contains(&inner)) {
                        return Err(cx.field(
                            span,
                            "light",
                            "spot_inner_deg",
                            "need 0 ≤ spot_inner_deg ≤ spot_outer_deg ≤ 180",
                        ));
                    }
                    world.lighting.spot_dir = f3(d);
                    world.lighting.cos_outer = outer.to_radians().cos() as f32;
                    world.lighting.cos_inner = (inner.to_radians().cos() as f32).max(world.lighting.cos_outer);
                }
                _ => {
                    return Err(cx.field(
                        span,
                        "light",
                        "spot_direction",
                        "a spotlight needs both spot_direction and spot_outer_deg",
                    ))
                }
            }
        }
    }
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
    if world.mesh.triangles.is_empty() && world.prims.is_empty() {
        return Err(SceneFileError::Syntax { path: path.to_path_buf(), message: "the scene has no geometry".into() });
    }
    Ok(world)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_mesh(_: &Path) -> Result<Mesh, SceneLoadError> {
        Err(SceneLoadError::UnsupportedFormat { path: PathBuf::from("x") })
    }

    fn err(text: &str) -> String {
        parse(Path::new("s.toml"), text, &no_mesh).unwrap_err().to_string()
    }

    const OK: &str = r#"
[camera]
eye = [0, 1, 5]
target = [0, 0, 0]

[light]
position = [2, 4, 3]
intensity = 20

[textures.chk]
kind = "checker"
param = 8

[materials.red]
colour = [0.8, 0.1, 0.1]
reflection = "constant"
reflectivity = 0.5
texture = "chk"

[[objects]]
type = "sphere"
material = "red"
translate = [0, 1, 0]

[[objects]]
type = "plane"
"#;

    #[test]
    fn parses_a_small_scene() {
        let w = parse(Path::new("s.toml"), OK, &no_mesh).unwrap();
        assert_eq!(w.prims.len(), 2);
        assert_eq!(w.prims[0].kind, PrimKind::Sphere);
        assert_eq!(w.prims[1].kind, PrimKind::Square);
        assert_eq!(w.objects.len(), 2);
        assert_eq!(w.objects[1].kind, ObjectKind::Plane);
        assert_eq!(w.objects[1].first_prim, 1);
        assert_eq!(w.material_model[1].texture, TextureKind::Checker);
        assert_eq!(w.material_model[1].reflect_mode, ReflectMode::Constant);
        assert_eq!(w.mesh.materials[1].reflect, 0.5);
        assert_eq!(w.lighting.light_count, 1);
        assert_eq!(w.settings.light.intensity, 20.0);
        assert_eq!(w.settings.camera.eye, [0.0, 1.0, 5.0]);
    }

    #[test]
    fn errors_name_line_and_field() {
        let e = err(&OK.replace("translate = [0, 1, 0]", "translate = [0, 1, 0]\nscale = 0"));
        assert!(e.contains("line 24") && e.contains("field `scale`") && e.contains("objects[0]"), "{e}");
        let e = err(&OK.replace("material = \"red\"", "material = \"blue\""));
        assert!(e.contains("field `material`") && e.contains("no material named `blue`"), "{e}");
        let e = err(&OK.replace("kind = \"checker\"", "kind = \"plaid\""));
        assert!(e.contains("line 11") && e.contains("plaid"), "{e}");
        let e = err(&OK.replace("intensity = 20", "intensity = 20\nbrightness = 3"));
        assert!(e.contains("line 9") && e.contains("brightness"), "{e}");
        let e = err(&OK.replace("texture = \"chk\"", "texture = \"nope\""));
        assert!(e.contains("materials.red") && e.contains("field `texture`"), "{e}");
        let e = err(&OK.replace("reflectivity = 0.5", "reflectivity = 1.5"));
        assert!(e.contains("line 17") && e.contains("field `reflectivity`"), "{e}");
        let e = err("[camera]\neye = [0, 0, 1]\ntarget = [0, 0, 1]\n[[objects]]\ntype = \"sphere\"\n");
        assert!(e.contains("field `target`"), "{e}");
    }
}
