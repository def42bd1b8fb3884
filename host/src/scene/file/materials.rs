//! `[textures.*]` and `[materials.*]` → the material table (index 0 is the default grey).

use std::collections::BTreeMap;

use gridrt_shared::scene::{DiffuseModel, Mapping, Material, MaterialModel, ReflectMode, SpecularModel, TextureKind};

use super::error::{Ctx, SceneFileError};
use super::schema::{
    f3, finite3, DiffuseDef, FileDef, FilterDef, MappingDef, ReflectionDef, SpecularDef, TextureKindDef,
};
use crate::scene::mesh::DEFAULT_MATERIAL;

/// Materials by index, with their shading models and names; meshes append their own.
pub(super) struct MaterialTable {
    /// Colour and reflectivity.
    pub(super) materials: Vec<Material>,
    /// Shading model and texture of each material.
    pub(super) models: Vec<MaterialModel>,
    /// Names (the file's, `(default)`, or `mesh#k` for a mesh's own).
    pub(super) names: Vec<String>,
    /// Index of each material the file names.
    pub(super) index_of: BTreeMap<String, u32>,
}

/// The file's materials, textures applied.
pub(super) fn materials(cx: &Ctx<'_>, def: &FileDef) -> Result<MaterialTable, SceneFileError> {
    let textures = textures(cx, def)?;

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
        return Err(SceneFileError::Syntax { path: cx.path.to_path_buf(), message: "too many materials".into() });
    }
    Ok(MaterialTable { materials, models: exts, names, index_of })
}

/// The file's textures, as material models to start a material from.
fn textures(cx: &Ctx<'_>, def: &FileDef) -> Result<BTreeMap<String, MaterialModel>, SceneFileError> {
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
    Ok(textures)
}
