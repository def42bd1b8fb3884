//! Helpers shared by the integration tests: the SPEC.md §5.9 image as literal bytes, an
//! independent scene-image builder (hand-written little-endian packing, not the crate's
//! serialisers), a recording `SceneSink`, and accumulator drivers.
#![allow(dead_code)]

use gridrt_shared::frame::{self, FeedResult, FrameAccumulator, FrameError};
use gridrt_shared::msg::{render_flags, Msg, PixelEncoding, RenderRequest};
use gridrt_shared::scene::{
    LightingRecord, Material, MaterialModel, ObjectRecord, SceneError, SceneHeader, SceneSink, SceneStream,
};

include!("tiny.rs");
include!("compact_decode.rs");

/// Body CRC of [`TINY_IMAGE`] (bytes 64..348), header bytes 56..60.
pub const TINY_BODY_CRC: u32 = 0xEF03_A2D3;
/// CRC of all of [`TINY_IMAGE`] (what `SceneBegin.crc` carries).
pub const TINY_IMAGE_CRC: u32 = 0x2A96_82A2;

/// The PE 0 memory image inside [`TINY_IMAGE`] (bytes 268..348).
#[rustfmt::skip]
pub const TINY_PE_WORDS: [u32; 20] = [
    0xFFFF_0002, 1, 1, 1, 0, // tag, T, V, R, P
    0, 0, 1, // voxel 0: first ref 0, 1 ref
    0, // ref 0 -> triangle 0
    0x3E80_0000, 0x3E80_0000, 0x3F00_0000, // a
    0x3F40_0000, 0x3E80_0000, 0x3F00_0000, // b
    0x3E80_0000, 0x3F40_0000, 0x3F00_0000, // c
    0, 0, // prim 0, material 0
];

/// Section ends of [`TINY_IMAGE`] (SPEC.md §5.9): header, voxel map + padding, material
/// colours, material models (= objects: there are none), lighting, PE block head, end.
pub const TINY_BOUNDARIES: [usize; 7] = [64, 68, 84, 180, 260, 268, 348];

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
    /// Header bytes 62..64.
    pub reserved: u16,
    /// One byte per voxel.
    pub voxel_map: Vec<u8>,
    /// Value of the voxel-map padding bytes.
    pub pad: u8,
    /// diffuse r, g, b, reflect.
    pub materials: Vec<[f32; 4]>,
    /// Material model records (96 B each), normally one per material.
    pub models: Vec<[u8; 96]>,
    /// Object records (64 B each).
    pub objects: Vec<[u8; 64]>,
    /// The lighting record.
    pub lighting: [u8; 80],
    /// (pe field, reserved field, words).
    pub pe_blocks: Vec<(u16, u16, Vec<u32>)>,
    /// Overrides the declared `words` of a block (index, value).
    pub words_override: Option<(usize, u32)>,
    /// Overrides the header's `material_count` (else `materials.len()`).
    pub material_count_override: Option<u16>,
    /// Overrides the header's `object_count` (else `objects.len()`).
    pub object_count_override: Option<u16>,
    pub total_len_override: Option<u32>,
    pub crc_override: Option<u32>,
}

fn push_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

fn f32s(out: &mut Vec<u8>, v: &[f32]) {
    for x in v {
        push_f32(out, *x);
    }
}

fn fixed<const N: usize>(v: Vec<u8>) -> [u8; N] {
    assert!(v.len() <= N, "record of {} bytes > {N}", v.len());
    let mut b = [0u8; N];
    b[..v.len()].copy_from_slice(&v);
    b
}

/// A material model record (SPEC.md §5.3): the 8 enum/flag bytes (diffuse, specular, reflect,
/// texture, mapping, bilinear, tex_log2, reserved), the 18 floats, the seed, 12 reserved.
pub fn model_bytes(head: [u8; 8], floats: [f32; 18], seed: u32) -> [u8; 96] {
    let mut b = head.to_vec();
    f32s(&mut b, &floats);
    b.extend_from_slice(&seed.to_le_bytes());
    fixed(b)
}

/// The 18 floats of `MaterialModel::DEFAULT`: ka kd ks σ² e, specular, η κ, colour2, uv
/// scale, uv offset, texture param.
pub const DEFAULT_MODEL_FLOATS: [f32; 18] =
    [1.0, 1.0, 0.0, 0.0, 32.0, 1.0, 1.0, 1.0, 1.5, 0.0, 0.1, 0.1, 0.1, 1.0, 1.0, 0.0, 0.0, 8.0];

/// `MaterialModel::MATTE`, what a mesh file's materials get: diffuse model 2, bilinear, 2^8.
pub fn matte_model() -> [u8; 96] {
    model_bytes([2, 0, 0, 0, 0, 1, 8, 0], DEFAULT_MODEL_FLOATS, 0)
}

/// A lighting record (SPEC.md §5.6): light count, max depth, falloff, reserved, then light
/// colour, spot axis, cos outer, cos inner, ambient colour, background; 20 reserved bytes.
pub fn lighting_bytes(head: [u8; 4], floats: [f32; 14]) -> [u8; 80] {
    let mut b = head.to_vec();
    f32s(&mut b, &floats);
    fixed(b)
}

/// `LightingRecord::DEFAULT`: one white omni light, no falloff, depth 1, white ambient, the
/// contract's background (0.08, 0.08, 0.12).
pub fn default_lighting() -> [u8; 80] {
    lighting_bytes([1, 1, 0, 0], [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, -1.0, -1.0, 1.0, 1.0, 1.0, 0.08, 0.08, 0.12])
}

/// An object record (SPEC.md §5.5).
pub fn object_bytes(kind: u8, material: u16, first_prim: u32, prim_count: u32, affine: [f32; 12]) -> [u8; 64] {
    let mut b = vec![kind, 0];
    b.extend_from_slice(&material.to_le_bytes());
    b.extend_from_slice(&first_prim.to_le_bytes());
    b.extend_from_slice(&prim_count.to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    f32s(&mut b, &affine);
    fixed(b)
}

/// World → object map of a sphere of radius 2 at the origin: W = diag(1/2).
pub const HALF_SCALE: [f32; 12] = [0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0];

impl ImageSpec {
    /// The SPEC.md §5.9 image.
    pub fn tiny() -> Self {
        Self {
            magic: *b"GRTS",
            version: 2,
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
            models: vec![matte_model()],
            objects: vec![],
            lighting: default_lighting(),
            pe_blocks: vec![(0, 0, TINY_PE_WORDS.to_vec())],
            words_override: None,
            material_count_override: None,
            object_count_override: None,
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
            dims: [3, 3, 1],
            pe_count: 2,
            bounds_max: [3.0, 3.0, 1.0],
            triangle_count: 3,
            pe_mem_words: 256,
            voxel_map: vec![0, 0, 1, 0xFF, 0, 1, 0xFF, 0xFF, 1],
            materials: vec![[0.8, 0.8, 0.8, 0.0], [0.9, 0.1, 0.1, 0.5]],
            models: vec![matte_model(), matte_model()],
            pe_blocks: vec![(0, 0, pe0), (1, 0, pe1)],
            ..Self::tiny()
        }
    }

    /// A 1×1×1 grid in (−2, −2, −2)–(2, 2, 2) with one sphere of radius 2 (prim 0, material 0):
    /// a checker material, one object, depth-2 inverse-square lighting, a PE image with an
    /// analytic primitive. Section ends: 64, 68, 84, 180, 244, 324, 332, 432.
    pub fn sphere() -> Self {
        Self {
            dims: [1, 1, 1],
            bounds_min: [-2.0; 3],
            bounds_max: [2.0; 3],
            voxel_map: vec![0x00],
            models: vec![model_bytes([0, 0, 0, 1, 0, 1, 4, 0], DEFAULT_MODEL_FLOATS, 0)],
            objects: vec![object_bytes(1, 0, 0, 1, HALF_SCALE)],
            lighting: lighting_bytes(
                [1, 2, 1, 0],
                [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, -1.0, -1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
            ),
            pe_blocks: vec![(0, 0, pe_image_with_prims(&[], &[(1, 0, 0, HALF_SCALE)], &[(0, vec![0])]))],
            ..Self::tiny()
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
            f32s(&mut body, m);
        }
        for m in &self.models {
            body.extend_from_slice(m);
        }
        for o in &self.objects {
            body.extend_from_slice(o);
        }
        body.extend_from_slice(&self.lighting);
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
        let materials = self.material_count_override.unwrap_or(self.materials.len() as u16);
        let objects = self.object_count_override.unwrap_or(self.objects.len() as u16);
        let mut out = Vec::new();
        out.extend_from_slice(&self.magic);
        out.extend_from_slice(&self.version.to_le_bytes());
        out.extend_from_slice(&self.header_len.to_le_bytes());
        for d in self.dims {
            out.extend_from_slice(&d.to_le_bytes());
        }
        out.extend_from_slice(&self.pe_count.to_le_bytes());
        f32s(&mut out, &self.bounds_min);
        f32s(&mut out, &self.bounds_max);
        out.extend_from_slice(&materials.to_le_bytes());
        out.extend_from_slice(&self.flags.to_le_bytes());
        out.extend_from_slice(&self.triangle_count.to_le_bytes());
        out.extend_from_slice(&self.pe_mem_words.to_le_bytes());
        out.extend_from_slice(&total.to_le_bytes());
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(&objects.to_le_bytes());
        out.extend_from_slice(&self.reserved.to_le_bytes());
        assert_eq!(out.len(), 64);
        out.extend_from_slice(&body);
        out
    }
}

/// A triangle of a hand-built PE image: vertices, prim id, material.
pub type Tri = ([[f32; 3]; 3], u32, u32);
/// An analytic primitive of a hand-built PE image: kind, prim id, material, world → object.
pub type Prim = (u32, u32, u32, [f32; 12]);

/// Builds a tagged PE memory image (SPEC.md §5.4) from triangles and (voxel id, local
/// triangle indices) in the given order.
pub fn pe_image(tris: &[Tri], voxels: &[(u32, Vec<u32>)]) -> Vec<u32> {
    pe_image_with_prims(tris, &[], voxels)
}

/// Builds a tagged PE memory image with analytic primitives; a ref `T + i` names primitive i.
pub fn pe_image_with_prims(tris: &[Tri], prims: &[Prim], voxels: &[(u32, Vec<u32>)]) -> Vec<u32> {
    let refs: usize = voxels.iter().map(|v| v.1.len()).sum();
    let mut w = vec![0xFFFF_0002, tris.len() as u32, voxels.len() as u32, refs as u32, prims.len() as u32];
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
    for (kind, prim, mat, affine) in prims {
        w.extend_from_slice(&[*kind, *prim, *mat]);
        w.extend(affine.iter().map(|c| c.to_bits()));
        w.push(0);
    }
    w
}

/// One call a `SceneStream` made into its sink.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Header(SceneHeader),
    VoxelMap(u32, Vec<u8>),
    Material(u16, Material),
    MaterialModel(u16, MaterialModel),
    Object(u16, ObjectRecord),
    Lighting(LightingRecord),
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
    fn material_model(&mut self, index: u16, model: MaterialModel) -> Result<(), SceneError> {
        self.push(Event::MaterialModel(index, model))
    }
    fn object(&mut self, index: u16, object: ObjectRecord) -> Result<(), SceneError> {
        self.push(Event::Object(index, object))
    }
    fn lighting(&mut self, lighting: LightingRecord) -> Result<(), SceneError> {
        self.push(Event::Lighting(lighting))
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

/// Checks payload bytes, wire bytes and decode of one worked example (SPEC.md §3).
pub fn check_msg(m: Msg<'_>, seq: u16, payload: &[u8], wire_bytes: &[u8]) {
    assert_eq!(encode_payload(&m), payload, "payload of {m:?}");
    assert_eq!(wire(m.kind() as u8, seq, payload), wire_bytes, "wire of {m:?}");
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    let out = feed_all(&mut acc, wire_bytes, wire_bytes.len());
    let [Outcome::Frame { kind, seq: s, payload: p }] = &out[..] else { panic!("{out:?}") };
    assert_eq!((*kind, *s), (m.kind() as u8, seq));
    assert_eq!(Msg::decode(*kind, p), Ok(m));
}

/// The render request of the worked examples, with pixel `encoding`.
pub fn example_request(encoding: PixelEncoding) -> RenderRequest {
    RenderRequest {
        frame: 1,
        width: 320,
        height: 240,
        flags: render_flags::SHADOWS | render_flags::PRIM_IDS,
        eye: [0.0, 0.0, 5.0],
        target: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 45.0,
        light_pos: [2.0, 4.0, 3.0],
        light_intensity: 1.0,
        ambient: 0.15,
        encoding,
    }
}
