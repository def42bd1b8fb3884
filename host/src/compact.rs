//! The compact scene stream's encoder (SPEC.md §5.12; the decoder is
//! `gridrt_shared::scene::Unpacker`, in the firmware).
//!
//! The encoder walks the image's layout so that it knows where the triangle records are: their
//! vertices go through the vertex cache (`VREF` for a vertex the cache holds, `VNEW` for a new
//! one, coded against the vertex before it), their prim id and material through `TAIL`. Every
//! other word is coded by [`WordCoder::word`]: a run of the last word, a small increment, a
//! short delta against a recent word, or a literal. The ops only say how to produce words, so
//! any choice the encoder makes decodes to the same image.

use std::collections::HashMap;

use gridrt_shared::frame::crc32;
use gridrt_shared::scene::{
    compact_op as op, zigzag, CompactHeader, SceneHeader, HEADER_LEN, HISTORY_WORDS, LIGHTING_LEN, MATERIAL_LEN,
    MATERIAL_MODEL_LEN, OBJECT_LEN, PE_HEADER_WORDS, PE_IMAGE_TAG, TRIANGLE_WORDS, VOXEL_ENTRY_WORDS,
};

/// `cache_log2` the reference host writes: 4096 vertices (48 KiB on the device).
pub const CACHE_LOG2: u8 = 12;

/// Codes `image` (a scene image, SPEC.md §5) as a compact stream with a vertex cache of
/// `1 << cache_log2` entries; `None` when its length is 0, not a multiple of 4 (no scene
/// image is) or past `u32`. An image whose layout cannot be read is still coded exactly, word
/// by word (only less compactly).
pub fn encode(image: &[u8], cache_log2: u8) -> Option<Vec<u8>> {
    if image.is_empty() || !image.len().is_multiple_of(4) || u32::try_from(image.len()).is_err() {
        return None;
    }
    let header = CompactHeader { cache_log2, image_len: image.len() as u32, image_crc: crc32(image) };
    let mut c = WordCoder::new(cache_log2);
    c.out.extend_from_slice(&header.to_bytes());
    let words: Vec<u32> = image.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    let triangles = triangle_spans(image);
    let mut i = 0;
    let mut spans = triangles.iter().peekable();
    while i < words.len() {
        if let Some(&&(start, count)) = spans.peek() {
            if i == start {
                for t in 0..count {
                    c.triangle(&words[i + t * TRIANGLE_WORDS..i + (t + 1) * TRIANGLE_WORDS]);
                }
                i += count * TRIANGLE_WORDS;
                spans.next();
                continue;
            }
        }
        c.word(words[i]);
        i += 1;
    }
    c.flush_lit();
    Some(c.out)
}

/// `(first word, triangles)` of every PE image's triangle table, in order.
fn triangle_spans(image: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let Ok(h) = SceneHeader::parse(image) else { return spans };
    let word = |i: usize| image.get(4 * i..4 * i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let voxels = h.voxel_count() as usize;
    let mut off = HEADER_LEN
        + voxels.div_ceil(4) * 4
        + h.material_count as usize * (MATERIAL_LEN + MATERIAL_MODEL_LEN)
        + h.object_count as usize * OBJECT_LEN
        + LIGHTING_LEN;
    for _ in 0..h.pe_count {
        let (Some(n), true) = (word(off / 4 + 1), off.is_multiple_of(4)) else { return spans };
        let base = off / 4 + 2;
        if n >= PE_HEADER_WORDS as u32 && word(base) == Some(PE_IMAGE_TAG) {
            let f = |k: usize| word(base + k).unwrap_or(0) as usize;
            let (t, v, r) = (f(1), f(2), f(3));
            let start = base + PE_HEADER_WORDS + VOXEL_ENTRY_WORDS * v + r;
            if start + t * TRIANGLE_WORDS <= base + n as usize {
                spans.push((start, t));
            }
        }
        off += 8 + 4 * n as usize;
    }
    spans
}

/// The encoder's state: the decoder's history and vertex cache, mirrored.
struct WordCoder {
    out: Vec<u8>,
    history: [u32; HISTORY_WORDS],
    hpos: usize,
    /// Literal words not yet written (at most 32).
    lits: Vec<u32>,
    /// A run of the last word not yet written.
    run: usize,
    cache: Vec<[u32; 3]>,
    cache_size: usize,
    cache_next: usize,
    where_cached: HashMap<[u32; 3], usize>,
}

fn varint(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push((v as u8 & 0x7F) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn varint_len(v: u32) -> usize {
    (32 - v.leading_zeros() as usize).max(1).div_ceil(7)
}

impl WordCoder {
    fn new(cache_log2: u8) -> Self {
        Self {
            out: Vec::new(),
            history: [0; HISTORY_WORDS],
            hpos: 0,
            lits: Vec::new(),
            run: 0,
            cache: Vec::new(),
            cache_size: 1 << cache_log2,
            cache_next: 0,
            where_cached: HashMap::new(),
        }
    }

    fn h(&self, back: usize) -> u32 {
        self.history[(self.hpos + HISTORY_WORDS - back) % HISTORY_WORDS]
    }

    fn push_history(&mut self, w: u32) {
        self.history[self.hpos] = w;
        self.hpos = (self.hpos + 1) % HISTORY_WORDS;
    }

    /// Writes the pending literals or the pending run (never both pending at once).
    fn flush_lit(&mut self) {
        self.flush_run();
        if !self.lits.is_empty() {
            self.out.push((op::LIT << 5) | (self.lits.len() as u8 - 1));
            for w in self.lits.drain(..) {
                self.out.extend_from_slice(&w.to_le_bytes());
            }
        }
    }

    fn flush_run(&mut self) {
        if self.run > 0 {
            self.out.push((op::RUN << 5) | (self.run as u8 - 1));
            self.run = 0;
        }
    }

    /// Any word: the cheapest of run, increment, delta against a recent word, literal.
    fn word(&mut self, w: u32) {
        if w == self.h(1) {
            if self.run == 0 {
                self.flush_lit();
            }
            self.run += 1;
            self.push_history(w);
            if self.run == 32 {
                self.flush_run();
            }
            return;
        }
        self.flush_run();
        let inc = w.wrapping_sub(self.h(1));
        let best = (1..=HISTORY_WORDS)
            .map(|back| (varint_len(zigzag(w.wrapping_sub(self.h(back)))), back))
            .min()
            .unwrap_or((5, 1));
        if (1..=32).contains(&inc) {
            self.flush_lit();
            self.out.push((op::INC << 5) | (inc - 1) as u8);
        } else if best.0 < 3 {
            self.flush_lit();
            self.out.push((op::DELTA << 5) | (best.1 - 1) as u8);
            let d = zigzag(w.wrapping_sub(self.h(best.1)));
            varint(&mut self.out, d);
        } else {
            self.lits.push(w);
            if self.lits.len() == 32 {
                self.flush_lit();
            }
        }
        self.push_history(w);
    }

    /// A triangle record: three vertices through the cache, then prim id and material.
    fn triangle(&mut self, rec: &[u32]) {
        self.flush_lit();
        for k in 0..3 {
            let v = [rec[3 * k], rec[3 * k + 1], rec[3 * k + 2]];
            match self.where_cached.get(&v) {
                Some(&slot) => {
                    self.out.push((op::VREF << 5) | (slot >> 8) as u8);
                    self.out.push(slot as u8);
                    for w in v {
                        self.push_history(w);
                    }
                }
                None => {
                    self.out.push(op::VNEW << 5);
                    for w in v {
                        let d = zigzag(w.wrapping_sub(self.h(3)));
                        varint(&mut self.out, d);
                        self.push_history(w);
                    }
                    if let Some(old) = self.cache.get(self.cache_next).copied() {
                        if self.where_cached.get(&old) == Some(&self.cache_next) {
                            self.where_cached.remove(&old);
                        }
                        self.cache[self.cache_next] = v;
                    } else {
                        self.cache.push(v);
                    }
                    self.where_cached.insert(v, self.cache_next);
                    self.cache_next = (self.cache_next + 1) % self.cache_size;
                }
            }
        }
        let (prim, material) = (rec[9], rec[10]);
        let d = prim.wrapping_sub(self.h(11));
        if d < 32 && material == self.h(10) {
            self.out.push((op::TAIL << 5) | d as u8);
            self.push_history(prim);
            self.push_history(material);
        } else {
            self.word(prim);
            self.word(material);
            self.flush_lit();
        }
    }
}

#[cfg(test)]
mod tests;
