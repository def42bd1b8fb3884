//! Scene-image loader: arbitrary bytes through `SceneStream` in arbitrary chunks, with a sink
//! that collects each PE block and parses it with `PeImage::parse` (what the device and the
//! co-processor do). Errors are fine; panics and unbounded memory are not.
#![no_main]

use gridrt_shared::scene::{Material, PeImage, SceneError, SceneHeader, SceneSink, SceneStream};
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
    let _ = (stream.is_done(), stream.offset());
    // The whole image as one PE memory image, too.
    let words: Vec<u32> = image.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let _ = PeImage::parse(&words);
});
