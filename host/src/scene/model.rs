//! The one scene model of the host: a triangle mesh plus ViRAY's analytic primitives, the
//! materials (colour + shading model), the object table (texture spaces), the lighting record
//! and the render settings (camera, light, frame size). A mesh file (OBJ, PLY) is simply a
//! scene with defaults ([`Scene::from_mesh`]); a TOML scene file sets everything.
//!
//! Primitive ids: triangles `0..T` (the mesh, in order), analytic primitives `T..T+P`.

use gridrt_shared::scene::{LightingRecord, Material, MaterialModel, ObjectKind, ObjectRecord, PrimKind};

use super::analytic::AnalyticPrim;
use super::mesh::{Bounds, Mesh, DEFAULT_MATERIAL};
use crate::render_settings::RenderSettings;

/// Everything of a scene: geometry, materials, lights and camera.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Triangles (prim ids `0..T`) and the material colours (index = material id).
    pub mesh: Mesh,
    /// Shading models, parallel to `mesh.materials`.
    pub material_model: Vec<MaterialModel>,
    /// Analytic primitives (prim ids `T + i`).
    pub prims: Vec<AnalyticPrim>,
    /// Object table (prim id ranges and texture spaces).
    pub objects: Vec<ObjectRecord>,
    /// Lighting and path record.
    pub lighting: LightingRecord,
    /// Camera, light position and intensity, ambient strength, frame size.
    pub settings: RenderSettings,
    /// Material names (for messages), parallel to `mesh.materials`.
    pub material_names: Vec<String>,
    /// Keyframes of a stream's camera path (a scene file's `[[camera_path]]`; empty: none).
    pub camera_path: Vec<crate::render_settings::Camera>,
}

impl Scene {
    /// Bounds of all geometry.
    pub fn bounds(&self) -> Option<Bounds> {
        Bounds::of_geometry(&self.mesh, &self.prims)
    }

    /// The material of index `i` (colour and shading model).
    pub fn material(&self, i: u32) -> (Material, MaterialModel) {
        (
            self.mesh.materials.get(i as usize).copied().unwrap_or(DEFAULT_MATERIAL),
            self.material_model.get(i as usize).copied().unwrap_or(MaterialModel::MATTE),
        )
    }

    /// Object kind of an analytic primitive kind.
    pub fn object_kind(kind: PrimKind) -> ObjectKind {
        match kind {
            PrimKind::Sphere => ObjectKind::Sphere,
            PrimKind::Cylinder => ObjectKind::Cylinder,
            PrimKind::Cone => ObjectKind::Cone,
            PrimKind::Disk => ObjectKind::Disk,
            PrimKind::Square => ObjectKind::Square,
        }
    }

    /// A mesh file's scene: its triangles and materials with the matte model, the mesh
    /// lighting, no analytic primitives or objects, the default camera and light of its box.
    pub fn from_mesh(mesh: Mesh) -> Self {
        let bounds = mesh.bounds().unwrap_or(Bounds { min: [0.0; 3], max: [1.0; 3] });
        let material_names = (0..mesh.materials.len()).map(|i| format!("material {i}")).collect();
        Self {
            material_model: vec![MaterialModel::MATTE; mesh.materials.len()],
            prims: Vec::new(),
            objects: Vec::new(),
            lighting: LightingRecord::DEFAULT,
            settings: RenderSettings::default_for(&bounds),
            material_names,
            mesh,
            camera_path: Vec::new(),
        }
    }
}
