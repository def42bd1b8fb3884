//! Scene-image loader: arbitrary bytes through `SceneStream` in arbitrary chunks, with a sink
//! that collects each PE block and parses it with `PeImage::parse` (what the device and the
//! co-processor do). Errors are fine; panics and unbounded memory are not.
//!
//! Seeds (`fuzz/corpus/scene_image/`): the first byte is the chunk size − 1, the rest the
//! image. `header_only` is the SPEC.md §5.9 header alone, `tiny_whole` / `tiny_chunk7` the
//! whole §5.9 image in one piece / in 7-byte pieces, `sphere_chunk3` the sphere scene of
//! `shared/tests/common` (an object record and an analytic primitive) in 3-byte pieces.
#![no_main]

use gridrt_shared::scene::{
    LightingRecord, Material, MaterialModel, ObjectRecord, PeImage, SceneError, SceneHeader, SceneSink, SceneStream,
};
use libfuzzer_sys::fuzz_target;

#[derive(Default)]
struct Sink {
    words: Vec<u32>,
    pe_words: u32,
}

impl SceneSink for Sink {
    fn header(&mut self, h: &SceneHeader) -> Result<(), SceneError> {
        let _ = (h.voxel_count(), h.voxel_map_len());
        Ok(())
    }
    fn voxel_map(&mut self, _first: u32, _owners: &[u8]) -> Result<(), SceneError> {
        Ok(())
    }
    fn material(&mut self, _index: u16, _m: Material) -> Result<(), SceneError> {
        Ok(())
    }
    fn material_model(&mut self, _index: u16, m: MaterialModel) -> Result<(), SceneError> {
        // Whatever the stream accepts serialises back to a record that parses to itself.
        assert_eq!(MaterialModel::parse(&m.to_bytes()), Ok(m));
        Ok(())
    }
    fn object(&mut self, _index: u16, o: ObjectRecord) -> Result<(), SceneError> {
        assert_eq!(ObjectRecord::parse(&o.to_bytes()), Ok(o));
        Ok(())
    }
    fn lighting(&mut self, l: LightingRecord) -> Result<(), SceneError> {
        assert_eq!(LightingRecord::parse(&l.to_bytes()), Ok(l));
        Ok(())
    }
    fn pe_begin(&mut self, _pe: u8, words: u32) -> Result<(), SceneError> {
        // A device refuses blocks larger than its PE memory before buffering anything.
        if words > 1 << 16 {
            return Err(SceneError::PeMemoryOverflow);
        }
        self.pe_words = words;
        self.words.clear();
        Ok(())
    }
    fn pe_word(&mut self, w: u32) -> Result<(), SceneError> {
        if self.words.len() as u32 >= self.pe_words {
            return Err(SceneError::BadPeBlock);
        }
        self.words.push(w);
        Ok(())
    }
    fn pe_end(&mut self) -> Result<(), SceneError> {
        if let Ok(img) = PeImage::parse(&self.words) {
            for i in 0..img.triangle_count().min(64) {
                let _ = img.triangle(i);
            }
            for i in 0..img.primitive_count().min(64) {
                let _ = img.primitive(i);
            }
            for i in 0..img.voxel_count().min(64) {
                let _ = img.voxel_entry(i);
            }
            let _ = img.ref_table();
        }
        Ok(())
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, image)) = data.split_first() else { return };
    let chunk = 1 + chunk as usize;
    let mut stream = SceneStream::new();
    let mut sink = Sink::default();
    for piece in image.chunks(chunk) {
        if stream.feed(piece, &mut sink).is_err() {
            break;
        }
    }
    let _ = (stream.is_done(), stream.offset(), stream.finish());
    // The whole image as one PE memory image, too.
    let words: Vec<u32> = image.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let _ = PeImage::parse(&words);
});
