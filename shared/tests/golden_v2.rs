//! Golden tests of scene image version 2 (SPEC.md §5.8). The version-1 golden tests
//! (`golden.rs`) are untouched: v1 images keep loading unchanged.

use gridrt_shared::frame::crc32;
use gridrt_shared::scene::{
    HeaderExt, LightingRecord, Material, MaterialModel, ObjectRecord, PeImage, PrimRecord, SceneError, SceneHeader,
    SceneSink, SceneStream, PE_IMAGE_TAG,
};
use gridrt_shared::scene::{Falloff, ObjectKind, PrimKind, TextureKind};

fn le32(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// PE image of one unit sphere scaled by 2 (W = x/2), prim 0, material 0, in voxel 0:
/// tag, T 0, V 1, R 1, P 1; voxel 0 refs [0, 1); ref 0 → local primitive 0 (T + 0).
fn pe_words() -> Vec<u32> {
    let half = 0x3F00_0000;
    vec![
        PE_IMAGE_TAG, 0, 1, 1, 1, // header
        0, 0, 1, // voxel table
        0, // ref → primitive 0
        1, 0, 0, // kind sphere, prim 0, material 0
        half, 0, 0, 0, 0, half, 0, 0, 0, 0, half, 0, // W = diag(1/2)
        0, // reserved
    ]
}

#[test]
fn pe_image_v2_words() {
    let w = pe_words();
    assert_eq!(w.len(), 5 + 3 + 1 + 16);
    let img = PeImage::parse(&w).unwrap();
    assert!(img.is_v2());
    assert_eq!((img.triangle_count(), img.primitive_count(), img.voxel_count()), (0, 1, 1));
    let p = img.primitive(0).unwrap();
    assert_eq!(p.kind, PrimKind::Sphere);
    assert_eq!(p.world_to_object[0], 0.5);
    assert_eq!(
        PrimRecord { kind: PrimKind::Sphere, prim: 0, material: 0, world_to_object: p.world_to_object }.to_words()[..],
        w[9..25]
    );
    // A ref past T + P, a count mismatch and an unknown kind are rejected.
    let mut bad = w.clone();
    bad[8] = 1;
    assert_eq!(PeImage::parse(&bad).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&w[..w.len() - 1]).err(), Some(SceneError::BadPeBlock));
    let mut bad = w.clone();
    bad[9] = 9;
    assert_eq!(PeImage::parse(&bad).err(), Some(SceneError::BadPeBlock));
    // v1 images still parse as v1.
    assert!(!PeImage::parse(&[0, 0, 0]).unwrap().is_v2());
}

#[derive(Default)]
struct Sink {
    ext: Option<HeaderExt>,
    materials: Vec<Material>,
    exts: Vec<MaterialModel>,
    objects: Vec<ObjectRecord>,
    lighting: Option<LightingRecord>,
    pe_words: Vec<u32>,
}

impl SceneSink for Sink {
    fn header(&mut self, _: &SceneHeader) -> Result<(), SceneError> {
        Ok(())
    }
    fn voxel_map(&mut self, _: u32, _: &[u8]) -> Result<(), SceneError> {
        Ok(())
    }
    fn material(&mut self, _: u16, m: Material) -> Result<(), SceneError> {
        self.materials.push(m);
        Ok(())
    }
    fn pe_begin(&mut self, _: u8, _: u32) -> Result<(), SceneError> {
        Ok(())
    }
    fn pe_word(&mut self, w: u32) -> Result<(), SceneError> {
        self.pe_words.push(w);
        Ok(())
    }
    fn pe_end(&mut self) -> Result<(), SceneError> {
        Ok(())
    }
    fn header_ext(&mut self, e: &HeaderExt) -> Result<(), SceneError> {
        self.ext = Some(*e);
        Ok(())
    }
    fn material_model(&mut self, _: u16, m: MaterialModel) -> Result<(), SceneError> {
        self.exts.push(m);
        Ok(())
    }
    fn object(&mut self, _: u16, o: ObjectRecord) -> Result<(), SceneError> {
        self.objects.push(o);
        Ok(())
    }
    fn lighting(&mut self, l: LightingRecord) -> Result<(), SceneError> {
        self.lighting = Some(l);
        Ok(())
    }
}

/// A 1×1×1 grid with one sphere, built byte by byte from SPEC.md §5.8.
#[test]
fn scene_v2_worked_example() {
    let mut body = vec![0x00, 0, 0, 0]; // voxel 0 → PE 0, padding
    body.extend(le32(&[0x3F4C_CCCD, 0x3F4C_CCCD, 0x3F4C_CCCD, 0])); // material 0: 0.8 grey, reflect 0
                                                                    // Material ext: Lambert, no specular, no reflection, checker, planar, bilinear, 2^4 texels.
    let mut ext = vec![0, 0, 0, 1, 0, 1, 4, 0];
    for f in [1.0f32, 1.0, 0.0, 0.0, 32.0, 1.0, 1.0, 1.0, 1.5, 0.0, 0.1, 0.1, 0.1, 1.0, 1.0, 0.0, 0.0, 8.0] {
        ext.extend(f.to_le_bytes());
    }
    ext.extend([0u8; 16]); // seed 0 + reserved
    assert_eq!(ext.len(), 96);
    body.extend(&ext);
    // Object 0: sphere, material 0, prims [0, 1), W = x/2.
    let mut obj = vec![1, 0, 0, 0];
    obj.extend(le32(&[0, 1, 0]));
    for f in [0.5f32, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0] {
        obj.extend(f.to_le_bytes());
    }
    assert_eq!(obj.len(), 64);
    body.extend(&obj);
    // Lighting: 1 light, depth 2, inverse square, white, omni (cones −1), ambient white, black background.
    let mut light = vec![1, 2, 1, 0];
    for f in [1.0f32, 1.0, 1.0, 0.0, 0.0, 0.0, -1.0, -1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0] {
        light.extend(f.to_le_bytes());
    }
    light.extend([0u8; 20]);
    assert_eq!(light.len(), 80);
    body.extend(&light);
    // PE block 0.
    let w = pe_words();
    body.extend(0u16.to_le_bytes());
    body.extend(0u16.to_le_bytes());
    body.extend((w.len() as u32).to_le_bytes());
    body.extend(le32(&w));
    let total = 64 + body.len() as u32;
    let mut img = b"GRTS".to_vec();
    img.extend(2u16.to_le_bytes()); // version 2
    img.extend(64u16.to_le_bytes());
    img.extend([1, 0, 1, 0, 1, 0, 1, 0]); // 1×1×1, 1 PE
    for f in [-2.0f32, -2.0, -2.0, 2.0, 2.0, 2.0] {
        img.extend(f.to_le_bytes());
    }
    img.extend(1u16.to_le_bytes()); // materials
    img.extend(0u16.to_le_bytes()); // flags
    img.extend(1u32.to_le_bytes()); // primitives (triangles + analytic)
    img.extend(64u32.to_le_bytes()); // pe_mem_words
    img.extend(total.to_le_bytes());
    img.extend(crc32(&body).to_le_bytes());
    img.extend(1u16.to_le_bytes()); // object_count
    img.extend(0u16.to_le_bytes());
    assert_eq!(img.len(), 64);
    img.extend(&body);
    assert_eq!(img.len(), 64 + 4 + 16 + 96 + 64 + 80 + 8 + 4 * 25);

    // Parse in awkward chunks.
    let mut s = SceneStream::new();
    let mut sink = Sink::default();
    for c in img.chunks(7) {
        s.feed(c, &mut sink).unwrap();
    }
    assert!(s.is_done());
    assert_eq!(sink.ext, Some(HeaderExt { version: 2, object_count: 1 }));
    assert_eq!(sink.materials, vec![Material { diffuse: [0.8; 3], reflect: 0.0 }]);
    let e = sink.exts[0];
    assert_eq!((e.texture, e.tex_log2, e.bilinear, e.tex_param), (TextureKind::Checker, 4, true, 8.0));
    assert_eq!(MaterialModel::parse(&ext).unwrap().to_bytes().to_vec(), ext);
    assert_eq!(sink.objects[0].kind, ObjectKind::Sphere);
    assert_eq!(sink.objects[0].to_bytes().to_vec(), obj);
    let l = sink.lighting.unwrap();
    assert_eq!((l.light_count, l.max_depth, l.falloff), (1, 2, Falloff::InverseSquare));
    assert_eq!(l.to_bytes().to_vec(), light);
    assert_eq!(sink.pe_words, w);
    // The header writer reproduces the v2 header.
    let (h, hx) = SceneHeader::parse_ext(&img[..64]).unwrap();
    assert_eq!(h.to_bytes_ext(&hx).to_vec(), img[..64].to_vec());
    // Truncated before the lighting record: never done.
    let mut s = SceneStream::new();
    s.feed(&img[..64 + 4 + 16 + 96 + 64 + 40], &mut Sink::default()).unwrap();
    assert_eq!(s.finish(), Err(SceneError::Truncated));
    // A bad enum in the material ext record.
    let mut bad = img.clone();
    bad[64 + 4 + 16 + 3] = 7;
    let body_crc = crc32(&bad[64..]);
    bad[56..60].copy_from_slice(&body_crc.to_le_bytes());
    assert_eq!(SceneStream::new().feed(&bad, &mut Sink::default()), Err(SceneError::BadRecord));
}
