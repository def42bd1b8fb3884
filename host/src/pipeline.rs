//! Mesh → grid → scene image, the host side of data-path step 1 (DESIGN.md §4).

use gridrt_shared::scene::SceneHeader;

use crate::grid::{build, Grid, GridError, GridParams};
use crate::image_format::scene_image;
use crate::scene::Mesh;

/// A scene ready for upload.
#[derive(Debug, Clone)]
pub struct PreparedScene {
    /// The mesh.
    pub mesh: Mesh,
    /// Its grid and PE images.
    pub grid: Grid,
    /// The serialised scene image.
    pub image: Vec<u8>,
}

impl PreparedScene {
    /// Builds the grid for `mesh` with `params` and serialises the scene image.
    pub fn new(mesh: Mesh, params: &GridParams) -> Result<Self, GridError> {
        let grid = build(&mesh, params)?;
        let image = scene_image(&grid, &mesh.materials);
        Ok(Self { mesh, grid, image })
    }

    /// Builds the grid (triangles and analytic primitives) and the version-2 scene image of
    /// a scene-file world; the world's mesh becomes `mesh`.
    pub fn from_world(world: &crate::world::World, params: &GridParams) -> Result<Self, GridError> {
        let grid = crate::grid::build_with_prims(&world.mesh, &world.prims, params)?;
        let v2 = crate::image_format::V2Sections {
            material_ext: &world.material_ext,
            objects: &world.objects,
            lighting: &world.lighting,
        };
        let image = crate::image_format::scene_image_v2(&grid, &world.mesh.materials, &v2);
        Ok(Self { mesh: world.mesh.clone(), grid, image })
    }

    /// The header of the scene image.
    pub fn header(&self) -> Option<SceneHeader> {
        SceneHeader::parse(&self.image).ok()
    }
}
