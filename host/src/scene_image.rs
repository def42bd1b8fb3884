//! Scene → grid → scene image, the host side of data-path step 1 (DESIGN.md §4).

use gridrt_shared::scene::SceneHeader;

use crate::grid::{build_with_prims, Grid, GridError, GridParams};
use crate::image_format::scene_image;
use crate::scene::Scene;

/// A scene ready for upload.
#[derive(Debug, Clone)]
pub struct PreparedScene {
    /// The scene.
    pub scene: Scene,
    /// Its grid and PE images.
    pub grid: Grid,
    /// The serialised scene image.
    pub image: Vec<u8>,
}

impl PreparedScene {
    /// Builds the grid (triangles and analytic primitives) of `scene` with `params` and
    /// serialises the scene image.
    pub fn new(scene: Scene, params: &GridParams) -> Result<Self, GridError> {
        let grid = build_with_prims(&scene.mesh, &scene.prims, params)?;
        let image = scene_image(&grid, &scene);
        Ok(Self { scene, grid, image })
    }

    /// The header of the scene image.
    pub fn header(&self) -> Option<SceneHeader> {
        SceneHeader::parse(&self.image).ok()
    }
}
