//! The file's tables as `serde` reads them (docs/SCENE-FILE.md); defaults live here, checks in
//! the modules that turn them into the scene.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Deserialize;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileDef {
    pub(super) camera: Option<Spanned<CameraDef>>,
    pub(super) render: Option<Spanned<RenderDef>>,
    pub(super) light: Option<Spanned<LightDef>>,
    #[serde(default)]
    pub(super) textures: BTreeMap<String, Spanned<TextureDef>>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, Spanned<MaterialDef>>,
    #[serde(default)]
    pub(super) objects: Vec<Spanned<ObjectDef>>,
    /// Keyframes of a stream's camera path (`gridrt render --frames N`).
    #[serde(default)]
    pub(super) camera_path: Vec<Spanned<KeyframeDef>>,
}

/// One keyframe of `[[camera_path]]`; `up` and `fov` default to the `[camera]`'s.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct KeyframeDef {
    pub(super) eye: [f64; 3],
    pub(super) target: [f64; 3],
    #[serde(default)]
    pub(super) up: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) fov: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraDef {
    pub(super) eye: [f64; 3],
    pub(super) target: [f64; 3],
    #[serde(default = "up")]
    pub(super) up: [f64; 3],
    #[serde(default = "fov")]
    pub(super) fov: f64,
    #[serde(default)]
    pub(super) width: Option<u16>,
    #[serde(default)]
    pub(super) height: Option<u16>,
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn fov() -> f64 {
    45.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RenderDef {
    #[serde(default = "one_u8")]
    pub(super) max_depth: u8,
    #[serde(default)]
    pub(super) background: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) ambient: Option<f64>,
    #[serde(default)]
    pub(super) ambient_colour: Option<[f64; 3]>,
}

fn one_u8() -> u8 {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightDef {
    pub(super) position: [f64; 3],
    #[serde(default = "one")]
    pub(super) intensity: f64,
    #[serde(default)]
    pub(super) colour: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) falloff: FalloffDef,
    #[serde(default)]
    pub(super) spot_direction: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) spot_outer_deg: Option<f64>,
    #[serde(default)]
    pub(super) spot_inner_deg: Option<f64>,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum FalloffDef {
    #[default]
    InverseSquare,
    None,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TextureDef {
    pub(super) kind: TextureKindDef,
    #[serde(default)]
    pub(super) mapping: MappingDef,
    #[serde(default = "tex_size")]
    pub(super) size: u32,
    #[serde(default)]
    pub(super) filter: FilterDef,
    #[serde(default = "uv_one")]
    pub(super) scale: [f64; 2],
    #[serde(default)]
    pub(super) offset: [f64; 2],
    #[serde(default)]
    pub(super) param: Option<f64>,
    #[serde(default)]
    pub(super) seed: u32,
    #[serde(default)]
    pub(super) colour2: Option<[f64; 3]>,
}

fn tex_size() -> u32 {
    256
}
fn uv_one() -> [f64; 2] {
    [1.0, 1.0]
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum TextureKindDef {
    Checker,
    Xor,
    Marble,
    Wood,
    RgbDots,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MappingDef {
    #[default]
    Planar,
    Cylindrical,
    Spherical,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum FilterDef {
    #[default]
    Bilinear,
    Nearest,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialDef {
    #[serde(default = "grey")]
    pub(super) colour: [f64; 3],
    #[serde(default)]
    pub(super) diffuse: DiffuseDef,
    #[serde(default)]
    pub(super) roughness: f64,
    #[serde(default = "one")]
    pub(super) ka: f64,
    #[serde(default = "one")]
    pub(super) kd: f64,
    #[serde(default)]
    pub(super) ks: f64,
    #[serde(default)]
    pub(super) specular: SpecularDef,
    #[serde(default = "exponent")]
    pub(super) exponent: f64,
    #[serde(default)]
    pub(super) specular_colour: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) reflection: ReflectionDef,
    #[serde(default)]
    pub(super) reflectivity: f64,
    #[serde(default = "ior")]
    pub(super) ior: f64,
    #[serde(default)]
    pub(super) k: f64,
    #[serde(default)]
    pub(super) texture: Option<String>,
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
pub(super) enum DiffuseDef {
    #[default]
    Lambert,
    OrenNayar,
    Matte,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum SpecularDef {
    #[default]
    None,
    BlinnPhong,
    TorranceSparrow,
}

#[derive(Debug, Default, Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ReflectionDef {
    #[default]
    None,
    Constant,
    Dielectric,
    Conductor,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectDef {
    #[serde(rename = "type")]
    pub(super) kind: ObjectType,
    #[serde(default)]
    pub(super) material: Option<String>,
    #[serde(default)]
    pub(super) file: Option<PathBuf>,
    #[serde(default)]
    pub(super) translate: [f64; 3],
    #[serde(default)]
    pub(super) rotate: [f64; 3],
    #[serde(default)]
    pub(super) scale: Option<ScaleDef>,
    #[serde(default)]
    pub(super) extent: Option<f64>,
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(untagged)]
pub(super) enum ScaleDef {
    Uniform(f64),
    Axes([f64; 3]),
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ObjectType {
    Mesh,
    Sphere,
    Plane,
    Disk,
    Square,
    Cylinder,
    Cone,
}

pub(super) fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

pub(super) fn f3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}
