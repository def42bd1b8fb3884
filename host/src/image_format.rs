//! Serialisation of the versioned scene image (`shared::scene`, SPEC.md §5):
//!
//! ```text
//! header (64 B, SceneHeader::to_bytes, body CRC over bytes 64..)
//! voxel→PE map, nx·ny·nz bytes, padded to a multiple of 4 with 0x00 (SPEC.md §5.2; readers ignore it)
//! material colours (16 B each), material models (96 B each), objects (64 B each), lighting (80 B)
//! per PE in order: pe u16 ‖ reserved u16 (0) ‖ words u32 ‖ words × u32 (PeImage), all LE
//! ```

use gridrt_shared::frame::crc32;
use gridrt_shared::scene::{SceneHeader, HEADER_LEN};

use crate::grid::Grid;
use crate::scene::Scene;

/// Builds the scene image of `scene` laid out on `grid` (built from the same scene).
pub fn scene_image(grid: &Grid, scene: &Scene) -> Vec<u8> {
    let materials = &scene.mesh.materials;
    debug_assert_eq!(scene.material_model.len(), materials.len());
    let mut body = Vec::new();
    body.extend_from_slice(&grid.owners);
    while body.len() % 4 != 0 {
        body.push(0);
    }
    for m in materials {
        body.extend_from_slice(&m.to_bytes());
    }
    for m in &scene.material_model {
        body.extend_from_slice(&m.to_bytes());
    }
    for o in &scene.objects {
        body.extend_from_slice(&o.to_bytes());
    }
    body.extend_from_slice(&scene.lighting.to_bytes());
    for (pe, words) in grid.pe_images.iter().enumerate() {
        body.extend_from_slice(&(pe as u16).to_le_bytes());
        body.extend_from_slice(&0u16.to_le_bytes());
        body.extend_from_slice(&(words.len() as u32).to_le_bytes());
        for w in words {
            body.extend_from_slice(&w.to_le_bytes());
        }
    }
    let header = SceneHeader {
        dims: grid.dims,
        pe_count: grid.pe_count,
        bounds_min: grid.bounds.min,
        bounds_max: grid.bounds.max,
        material_count: materials.len() as u16,
        flags: 0,
        triangle_count: grid.triangle_count + grid.prim_count,
        pe_mem_words: grid.pe_mem_words,
        total_len: (HEADER_LEN + body.len()) as u32,
        body_crc: crc32(&body),
        object_count: scene.objects.len() as u16,
    };
    let mut out = Vec::with_capacity(HEADER_LEN + body.len());
    out.extend_from_slice(&header.to_bytes());
    out.extend_from_slice(&body);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{build, GridParams};
    use gridrt_shared::scene::{Material, PeImage, SceneError, SceneSink, SceneStream};
    use std::path::Path;

    #[derive(Default)]
    struct Collect {
        header: Option<SceneHeader>,
        owners: Vec<u8>,
        materials: Vec<Material>,
        pes: Vec<(u8, Vec<u32>)>,
        ended: usize,
    }

    impl SceneSink for Collect {
        fn header(&mut self, h: &SceneHeader) -> Result<(), SceneError> {
            self.header = Some(*h);
            Ok(())
        }
        fn voxel_map(&mut self, first: u32, owners: &[u8]) -> Result<(), SceneError> {
            assert_eq!(first as usize, self.owners.len());
            self.owners.extend_from_slice(owners);
            Ok(())
        }
        fn material(&mut self, index: u16, m: Material) -> Result<(), SceneError> {
            assert_eq!(index as usize, self.materials.len());
            self.materials.push(m);
            Ok(())
        }
        fn pe_begin(&mut self, pe: u8, words: u32) -> Result<(), SceneError> {
            self.pes.push((pe, Vec::with_capacity(words as usize)));
            Ok(())
        }
        fn pe_word(&mut self, w: u32) -> Result<(), SceneError> {
            self.pes.last_mut().unwrap().1.push(w);
            Ok(())
        }
        fn pe_end(&mut self) -> Result<(), SceneError> {
            self.ended += 1;
            Ok(())
        }
    }

    fn cornell() -> (Scene, Grid) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/cornell_box.obj");
        let scene = crate::scene::load(&path).unwrap();
        let grid = build(&scene.mesh, &GridParams { pe_count: 3, m: 3.0, ..Default::default() }).unwrap();
        (scene, grid)
    }

    #[test]
    fn scene_image_round_trips_through_scene_stream() {
        let (scene, grid) = cornell();
        let image = scene_image(&grid, &scene);
        // Feed in awkward chunk sizes, as the UART would.
        let mut stream = SceneStream::new();
        let mut sink = Collect::default();
        for chunk in image.chunks(37) {
            stream.feed(chunk, &mut sink).unwrap();
        }
        assert!(stream.is_done());
        let h = sink.header.unwrap();
        assert_eq!(h.dims, grid.dims);
        assert_eq!(h.pe_count, 3);
        assert_eq!(h.triangle_count, scene.mesh.triangles.len() as u32);
        assert_eq!(h.total_len as usize, image.len());
        assert_eq!(sink.owners, grid.owners);
        assert_eq!(sink.materials, scene.mesh.materials);
        assert_eq!(sink.ended, 3);
        for (pe, (id, words)) in sink.pes.iter().enumerate() {
            assert_eq!(*id as usize, pe);
            assert_eq!(words, &grid.pe_images[pe]);
            PeImage::parse(words).unwrap();
        }
    }

    #[test]
    fn corrupted_image_fails_its_crc() {
        let (scene, grid) = cornell();
        let mut image = scene_image(&grid, &scene);
        let last = image.len() - 1;
        image[last] ^= 0x40;
        let mut stream = SceneStream::new();
        assert_eq!(stream.feed(&image, &mut Collect::default()), Err(SceneError::BadCrc));
    }
}
