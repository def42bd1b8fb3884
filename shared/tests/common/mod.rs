//! Helpers shared by the integration tests: the SPEC.md §5.7 image as literal bytes, an
//! independent scene-image builder (hand-written little-endian packing, not the crate's
//! serialisers), a recording `SceneSink`, and accumulator drivers.
#![allow(dead_code)]

use gridrt_shared::frame::{self, FeedResult, FrameAccumulator, FrameError};
use gridrt_shared::msg::Msg;
use gridrt_shared::scene::{Material, SceneError, SceneHeader, SceneSink, SceneStream};

/// SPEC.md §5.7: the 2×1×1 grid, 1 PE, 1 material, 1 triangle image. Computed independently
/// (Python `struct` + `zlib.crc32`), not copied from the crate's output.
#[rustfmt::skip]
pub const TINY_IMAGE: [u8; 164] = [
    0x47, 0x52, 0x54, 0x53, 0x01, 0x00, 0x40, 0x00, 0x02, 0x00, 0x01, 0x00, 0x01, 0x00, 0x01, 0x00, //
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, //
    0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x80, 0x3F, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, //
    0x40, 0x00, 0x00, 0x00, 0xA4, 0x00, 0x00, 0x00, 0x1B, 0x90, 0x0A, 0xE5, 0x00, 0x00, 0x00, 0x00, //
    0x00, 0xFF, 0x00, 0x00, 0xCD, 0xCC, 0x4C, 0x3F, 0xCD, 0xCC, 0x4C, 0x3F, 0xCD, 0xCC, 0x4C, 0x3F, //
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x12, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, //
    0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, //
    0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E, 0x00, 0x00, 0x80, 0x3E, //
    0x00, 0x00, 0x00, 0x3F, 0x00, 0x00, 0x40, 0x3F, 0x00, 0x00, 0x80, 0x3E, 0x00, 0x00, 0x00, 0x3F, //
    0x00, 0x00, 0x80, 0x3E, 0x00, 0x00, 0x40, 0x3F, 0x00, 0x00, 0x00, 0x3F, 0x00, 0x00, 0x00, 0x00, //
    0x00, 0x00, 0x00, 0x00,
];

/// The PE 0 memory image inside [`TINY_IMAGE`] (bytes 92..164).
#[rustfmt::skip]
pub const TINY_PE_WORDS: [u32; 18] = [
    1, 1, 1, // T, V, R
    0, 0, 1, // voxel 0: first ref 0, 1 ref
    0, // ref 0 -> triangle 0
    0x3E80_0000, 0x3E80_0000, 0x3F00_0000, // a
    0x3F40_0000, 0x3E80_0000, 0x3F00_0000, // b
    0x3E80_0000, 0x3F40_0000, 0x3F00_0000, // c
    0, 0, // prim 0, material 0
];

/// Section boundaries of [`TINY_IMAGE`] (SPEC.md §5.7).
pub const TINY_BOUNDARIES: [usize; 5] = [64, 68, 84, 92, 164];

/// Everything a scene image is made of, written by hand so tests can corrupt any field.
#[derive(Debug, Clone)]
pub struct ImageSpec {
    pub magic: [u8; 4],
    pub version: u16,
    pub header_len: u16,
    pub dims: [u16; 3],
    pub pe_count: u16,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub flags: u16,
    pub triangle_count: u32,
    pub pe_mem_words: u32,
    pub reserved: u32,
    /// One byte per voxel.
    pub voxel_map: Vec<u8>,
    /// Value of the voxel-map padding bytes.
    pub pad: u8,
    /// diffuse r, g, b, reflect.
    pub materials: Vec<[f32; 4]>,
    /// (pe field, reserved field, words).
    pub pe_blocks: Vec<(u16, u16, Vec<u32>)>,
    /// Overrides the declared `words` of a block (index, value).
    pub words_override: Option<(usize, u32)>,
    pub total_len_override: Option<u32>,
    pub crc_override: Option<u32>,
}

fn push_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

impl ImageSpec {
    /// The SPEC.md §5.7 image.
    pub fn tiny() -> Self {
        Self {
            magic: *b"GRTS",
            version: 1,
            header_len: 64,
            dims: [2, 1, 1],
            pe_count: 1,
            bounds_min: [0.0; 3],
            bounds_max: [2.0, 1.0, 1.0],
            flags: 0,
            triangle_count: 1,
            pe_mem_words: 64,
            reserved: 0,
            voxel_map: vec![0x00, 0xFF],
            pad: 0,
            materials: vec![[0.8, 0.8, 0.8, 0.0]],
            pe_blocks: vec![(0, 0, TINY_PE_WORDS.to_vec())],
            words_override: None,
            total_len_override: None,
            crc_override: None,
        }
    }

    /// A 3×3×1 grid with 2 PEs, 2 materials and 3 triangles, voxel map padded by 3 bytes.
    pub fn two_pe() -> Self {
        let t = |v: [[f32; 3]; 3], prim: u32, mat: u32| (v, prim, mat);
        let pe0 = pe_image(
            &[
                t([[0.1, 0.1, 0.5], [1.9, 0.2, 0.5], [0.2, 0.9, 0.5]], 0, 0),
                t([[1.2, 1.2, 0.2], [1.8, 1.3, 0.8], [1.3, 1.8, 0.4]], 1, 1),
            ],
            &[(0, vec![0]), (1, vec![0]), (4, vec![1])],
        );
        let pe1 = pe_image(
            &[t([[2.5, 0.1, 0.5], [2.6, 2.9, 0.5], [2.9, 1.5, 0.1]], 2, 1)],
            &[(2, vec![0]), (5, vec![0]), (8, vec![0])],
        );
        Self {
            magic: *b"GRTS",
            version: 1,
            header_len: 64,
            dims: [3, 3, 1],
            pe_count: 2,
            bounds_min: [0.0; 3],
            bounds_max: [3.0, 3.0, 1.0],
            flags: 0,
            triangle_count: 3,
            pe_mem_words: 256,
            reserved: 0,
            voxel_map: vec![0, 0, 1, 0xFF, 0, 1, 0xFF, 0xFF, 1],
            pad: 0,
            materials: vec![[0.8, 0.8, 0.8, 0.0], [0.9, 0.1, 0.1, 0.5]],
            pe_blocks: vec![(0, 0, pe0), (1, 0, pe1)],
            words_override: None,
            total_len_override: None,
            crc_override: None,
        }
    }

    /// Serialises the image; `total_len` and `body_crc` are computed unless overridden.
    pub fn build(&self) -> Vec<u8> {
        let mut body = Vec::new();
        body.extend_from_slice(&self.voxel_map);
        while body.len() % 4 != 0 {
            body.push(self.pad);
        }
        for m in &self.materials {
            for v in m {
                push_f32(&mut body, *v);
            }
        }
        for (i, (pe, reserved, words)) in self.pe_blocks.iter().enumerate() {
            body.extend_from_slice(&pe.to_le_bytes());
            body.extend_from_slice(&reserved.to_le_bytes());
            let n = match self.words_override {
                Some((j, n)) if j == i => n,
                _ => words.len() as u32,
            };
            body.extend_from_slice(&n.to_le_bytes());
            for w in words {
                body.extend_from_slice(&w.to_le_bytes());
            }
        }
        let total = self.total_len_override.unwrap_or(64 + body.len() as u32);
        let crc = self.crc_override.unwrap_or_else(|| frame::crc32(&body));
        let mut out = Vec::new();
        out.extend_from_slice(&self.magic);
        out.extend_from_slice(&self.version.to_le_bytes());
        out.extend_from_slice(&self.header_len.to_le_bytes());
        for d in self.dims {
            out.extend_from_slice(&d.to_le_bytes());
        }
        out.extend_from_slice(&self.pe_count.to_le_bytes());
        for v in self.bounds_min.iter().chain(self.bounds_max.iter()) {
            push_f32(&mut out, *v);
        }
        out.extend_from_slice(&(self.materials.len() as u16).to_le_bytes());
        out.extend_from_slice(&self.flags.to_le_bytes());
        out.extend_from_slice(&self.triangle_count.to_le_bytes());
        out.extend_from_slice(&self.pe_mem_words.to_le_bytes());
        out.extend_from_slice(&total.to_le_bytes());
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(&self.reserved.to_le_bytes());
        assert_eq!(out.len(), 64);
        out.extend_from_slice(&body);
        out
    }
}

/// Builds a PE memory image (SPEC.md §5.4) from triangles and (voxel id, local triangle
/// indices) in the given order.
pub fn pe_image(tris: &[([[f32; 3]; 3], u32, u32)], voxels: &[(u32, Vec<u32>)]) -> Vec<u32> {
    let refs: usize = voxels.iter().map(|v| v.1.len()).sum();
    let mut w = vec![tris.len() as u32, voxels.len() as u32, refs as u32];
    let mut first = 0u32;
    for (id, r) in voxels {
        w.extend_from_slice(&[*id, first, r.len() as u32]);
        first += r.len() as u32;
    }
    for (_, r) in voxels {
        w.extend_from_slice(r);
    }
    for (v, prim, mat) in tris {
        for c in v.iter().flatten() {
            w.push(c.to_bits());
        }
        w.push(*prim);
        w.push(*mat);
    }
    w
}

/// One call a `SceneStream` made into its sink.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Header(SceneHeader),
    VoxelMap(u32, Vec<u8>),
    Material(u16, Material),
    PeBegin(u8, u32),
    PeWord(u32),
    PeEnd,
}

/// Records every sink call; refuses the `fail_at`-th call (0-based) with `fail_with`.
#[derive(Debug, Default)]
pub struct RecordingSink {
    pub events: Vec<Event>,
    pub fail_at: Option<(usize, SceneError)>,
}

impl RecordingSink {
    fn push(&mut self, e: Event) -> Result<(), SceneError> {
        if let Some((n, err)) = self.fail_at {
            if self.events.len() == n {
                return Err(err);
            }
        }
        self.events.push(e);
        Ok(())
    }
}

impl SceneSink for RecordingSink {
    fn header(&mut self, header: &SceneHeader) -> Result<(), SceneError> {
        self.push(Event::Header(*header))
    }
    fn voxel_map(&mut self, first: u32, owners: &[u8]) -> Result<(), SceneError> {
        self.push(Event::VoxelMap(first, owners.to_vec()))
    }
    fn material(&mut self, index: u16, material: Material) -> Result<(), SceneError> {
        self.push(Event::Material(index, material))
    }
    fn pe_begin(&mut self, pe: u8, words: u32) -> Result<(), SceneError> {
        self.push(Event::PeBegin(pe, words))
    }
    fn pe_word(&mut self, word: u32) -> Result<(), SceneError> {
        self.push(Event::PeWord(word))
    }
    fn pe_end(&mut self) -> Result<(), SceneError> {
        self.push(Event::PeEnd)
    }
}

/// Merges consecutive voxel-map pieces (their split depends on chunking), checking that each
/// piece starts where the previous one ended.
pub fn coalesce(events: &[Event]) -> Vec<Event> {
    let mut out: Vec<Event> = Vec::new();
    for e in events {
        if let (Event::VoxelMap(first, owners), Some(Event::VoxelMap(f0, acc))) = (e, out.last_mut()) {
            assert_eq!(*first as usize, *f0 as usize + acc.len(), "voxel-map pieces must be contiguous");
            acc.extend_from_slice(owners);
            continue;
        }
        out.push(e.clone());
    }
    out
}

/// Streams `image` in chunks of `chunk` bytes; returns the result, the sink and the stream.
pub fn stream_in_chunks(image: &[u8], chunk: usize) -> (Result<(), SceneError>, RecordingSink, SceneStream) {
    let mut sink = RecordingSink::default();
    let mut s = SceneStream::new();
    let mut result = Ok(());
    for piece in image.chunks(chunk.max(1)) {
        result = s.feed(piece, &mut sink);
        if result.is_err() {
            break;
        }
    }
    (result, sink, s)
}

/// An accumulator outcome with owned data, for comparisons.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    Frame { kind: u8, seq: u16, payload: Vec<u8> },
    Bad(FrameError),
    Overflow,
}

/// Feeds `input` in pieces of `chunk` bytes and collects every outcome.
pub fn feed_all<const N: usize>(acc: &mut FrameAccumulator<N>, input: &[u8], chunk: usize) -> Vec<Outcome> {
    let mut out = Vec::new();
    for piece in input.chunks(chunk.max(1)) {
        let mut rest: &[u8] = piece;
        // Each outcome consumes at least the delimiter, so this terminates.
        loop {
            let before = rest.len();
            match acc.feed(rest) {
                FeedResult::Consumed => break,
                FeedResult::Overflow { rest: r } => {
                    out.push(Outcome::Overflow);
                    rest = r;
                }
                FeedResult::BadFrame { error, rest: r } => {
                    out.push(Outcome::Bad(error));
                    rest = r;
                }
                FeedResult::Frame { frame, rest: r } => {
                    out.push(Outcome::Frame { kind: frame.kind, seq: frame.seq, payload: frame.payload.to_vec() });
                    rest = r;
                }
            }
            assert!(rest.len() < before, "feed must consume at least one byte per outcome");
        }
    }
    out
}

/// `Msg::encode` into a fresh buffer.
pub fn encode_payload(msg: &Msg<'_>) -> Vec<u8> {
    let mut buf = [0u8; frame::MAX_PAYLOAD + 512];
    let n = msg.encode(&mut buf).expect("encode");
    buf[..n].to_vec()
}

/// `encode_frame` into a fresh buffer.
pub fn wire(kind: u8, seq: u16, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; frame::MAX_ENCODED];
    let n = frame::encode_frame(kind, seq, payload, &mut out).expect("encode_frame");
    out.truncate(n);
    out
}

/// A raw (pre-COBS) frame with any version byte and a correct CRC.
pub fn raw_frame(kind: u8, version: u8, seq: u16, len_field: u16, payload: &[u8]) -> Vec<u8> {
    let mut raw = vec![kind, version];
    raw.extend_from_slice(&seq.to_le_bytes());
    raw.extend_from_slice(&len_field.to_le_bytes());
    raw.extend_from_slice(payload);
    let crc = frame::crc32(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    raw
}

/// COBS-encodes `raw` and appends the delimiter.
pub fn cobs_wire(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
    let n = cobs::encode(raw, &mut out);
    out.truncate(n);
    out.push(0);
    out
}
