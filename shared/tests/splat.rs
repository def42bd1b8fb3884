//! Seed 001's splat codewords and the scene image's point section (SPEC.md §6, §5.10):
//! golden bytes worked out by hand in the spec, and corrupted words and sections rejected.

mod common;

use common::TINY_IMAGE;
use gridrt_shared::frame::crc32;
use gridrt_shared::scene::{
    scene_flags, PointRecord, PointsHead, SceneError, SceneHeader, SceneSink, SceneStream, POINTS_HEAD_LEN, POINT_LEN,
};
use gridrt_shared::splat::{
    is_command, shade, CodewordError, Command, DepthWord, MaterialTerm, Mode, RowCode, SplatWord,
};

fn row(start: u8, length: u8) -> RowCode {
    RowCode { start, length }
}

/// SPEC.md §6.1 worked example 1: a symmetric splat.
fn symmetric_example() -> SplatWord {
    SplatWord {
        mode: Mode::Symmetric,
        scans: [row(3, 1), row(2, 3), row(1, 5), row(1, 5)],
        diffuse: 100,
        specular: 5,
        material: 3,
        x: 260,
        z: 77,
    }
}

/// SPEC.md §6.1 worked example 2: one tile of a larger splat, every field at its maximum.
fn tile_example() -> SplatWord {
    SplatWord {
        mode: Mode::Interpolated,
        scans: [row(2, 3), row(1, 6), row(0, 7), RowCode::EMPTY],
        diffuse: 127,
        specular: 0,
        material: 127,
        x: 511,
        z: 511,
    }
}

#[test]
fn golden_symmetric_codeword_bytes_and_rows() {
    let w = symmetric_example().pack();
    assert_eq!(w, 0x3299_A6E4_0A0E_084D);
    assert_eq!(w.to_be_bytes(), [0x32, 0x99, 0xA6, 0xE4, 0x0A, 0x0E, 0x08, 0x4D]);
    // The DSP's two 32-bit halves (point splatting): mode + scans + diffuse, then the rest.
    assert_eq!(((w >> 32) as u32, w as u32), (0x3299_A6E4, 0x0A0E_084D));
    assert!(!is_command(w));
    assert_eq!(SplatWord::unpack(w), symmetric_example());
    let rows = SplatWord::unpack(w).rows();
    let want = [(3, 4), (2, 5), (1, 6), (1, 6), (1, 6), (1, 6), (2, 5), (3, 4)].map(Some);
    assert_eq!(rows, want);
}

#[test]
fn golden_interpolated_tile_codeword_bytes_and_rows() {
    let w = tile_example().pack();
    assert_eq!(w, 0xA670_FCFF_01FF_FFFF);
    assert!(!is_command(w));
    assert_eq!(SplatWord::unpack(w), tile_example());
    // Sent rows 0, 2, 5, 7; row 1 halfway between 0 and 2, rows 3 and 4 a third and two
    // thirds from 2 to 5 (rounded half up), row 6 empty because row 7 is.
    let want = [Some((2, 5)), Some((2, 6)), Some((1, 7)), Some((1, 7)), Some((0, 7)), Some((0, 7)), None, None];
    assert_eq!(SplatWord::unpack(w).rows(), want);
}

#[test]
fn golden_command_words() {
    assert_eq!(Command::StartLoad.pack(), 0xFF00_0000_0000_0000);
    assert_eq!(Command::EndLoad.pack(), 0xFF40_0000_0000_0000);
    assert_eq!(Command::Shift(12).pack(), 0xFF80_0000_0000_000C);
    assert_eq!(Command::Ambient(38).pack(), 0xFFC0_0000_0000_0026);
    for c in [Command::StartLoad, Command::EndLoad, Command::Shift(65535), Command::Ambient(127)] {
        assert!(is_command(c.pack()));
        assert_eq!(Command::unpack(c.pack()), Ok(c));
    }
}

#[test]
fn golden_material_and_depth_words() {
    let t = MaterialTerm([300, 514, 0]);
    assert_eq!(t.pack(), 0x0000_012C_0202_0000);
    assert_eq!(MaterialTerm::unpack(t.pack()), Ok(t));
    // 1.0 per unit term is 255·256/127 = 514.02 → 514; a full term (127) then gives 255.
    assert_eq!(MaterialTerm::from_coefficient([1.0, 0.5, 0.0]), MaterialTerm([514, 257, 0]));
    let full = [MaterialTerm::default(), MaterialTerm([514, 257, 0]), MaterialTerm::default()];
    // (514·127 + 128) >> 8 = 255, (257·127 + 128) >> 8 = 127.
    assert_eq!(shade(&full, 0, 127, 0), [255, 127, 0]);
    // Saturation at 255.
    let hot = [MaterialTerm([65535; 3]), MaterialTerm([65535; 3]), MaterialTerm([65535; 3])];
    assert_eq!(shade(&hot, 127, 127, 127), [255; 3]);

    let d = DepthWord { z: 1000, dzdx: -3, dzdy: 200 };
    assert_eq!(d.pack(), 0x0003_E8FF_FD00_C800);
    assert_eq!(DepthWord::unpack(d.pack()), Ok(d));
    // Pixel (7, 0): 1000 + ((−3·7 + 200·(−7)) >> 5) = 1000 + (−1421 >> 5) = 1000 − 45.
    assert_eq!(d.at(7, 0), 955);
    assert_eq!(d.at(0, 7), 1000 + ((21 + 1400) >> 5));
}

#[test]
fn no_splat_codeword_is_a_command() {
    // The only row-0 code that could put 0xFF in the first byte is (7, 7); the encoder writes
    // every empty row as (7, 1).
    let mut w = tile_example();
    w.scans[0] = row(7, 7);
    let packed = w.pack();
    assert!(!is_command(packed));
    assert_eq!(SplatWord::unpack(packed).scans[0], RowCode::EMPTY);
    // Hand-made word with (7, 7) in row 0 and mode 1: a command, and not a valid one.
    let forged = (1u64 << 63) | (0x3F << 57) | (1 << 56) | (1 << 20);
    assert!(is_command(forged));
    assert_eq!(Command::unpack(forged), Err(CodewordError::ReservedBits));
}

#[test]
fn corrupted_command_and_load_words_are_rejected() {
    assert_eq!(Command::unpack(symmetric_example().pack()), Err(CodewordError::NotCommand));
    // Every bit outside a command's parameter.
    for (c, param_bits) in
        [(Command::StartLoad, 0), (Command::EndLoad, 0), (Command::Shift(0), 16), (Command::Ambient(0), 7)]
    {
        for bit in param_bits..54 {
            assert_eq!(Command::unpack(c.pack() | 1 << bit), Err(CodewordError::ReservedBits), "{c:?} bit {bit}");
        }
    }
    for bit in 48..64 {
        assert_eq!(MaterialTerm::unpack(1 << bit), Err(CodewordError::ReservedBits), "bit {bit}");
    }
    for bit in (0..8).chain(56..64) {
        assert_eq!(DepthWord::unpack(1 << bit), Err(CodewordError::ReservedBits), "bit {bit}");
    }
}

#[test]
fn every_row_code_round_trips_or_reads_as_empty() {
    for start in 0..8u8 {
        for length in 0..8u8 {
            let mut w = symmetric_example();
            w.scans[1] = row(start, length);
            let back = SplatWord::unpack(w.pack());
            if start + length <= 7 {
                assert_eq!(back.scans[1], row(start, length));
                assert_eq!(back.rows()[1], Some((start, start + length)));
                // Mirror about the box centre.
                assert_eq!(back.rows()[6], Some((7 - start - length, 7 - start)));
            } else {
                assert_eq!(back.scans[1], RowCode::EMPTY);
                assert_eq!(back.rows()[1], None);
                assert_eq!(back.rows()[6], None);
            }
        }
    }
    assert_eq!(RowCode::span(-3, 2), row(0, 2));
    assert_eq!(RowCode::span(5, 12), row(5, 2));
    assert_eq!(RowCode::span(4, 3), RowCode::EMPTY);
    assert_eq!(RowCode::span(8, 9), RowCode::EMPTY);
}

// ---------------------------------------------------------------- point section (§5.10)

fn point(i: u16) -> PointRecord {
    PointRecord { pos: [0.5, 0.25 * i as f32, 0.5], normal: [0.0, 0.0, 1.0], radius: 0.125, material: 0 }
}

/// TINY_IMAGE (SPEC.md §5.9) with a point section of `points` appended.
fn tiny_with_points(points: &[PointRecord]) -> Vec<u8> {
    let head = PointsHead { count: points.len() as u32, bounds_min: [0.0; 3], bounds_max: [1.0; 3] };
    let mut body = TINY_IMAGE[64..].to_vec();
    body.extend_from_slice(&head.to_bytes());
    for p in points {
        body.extend_from_slice(&p.to_bytes());
    }
    let mut h = SceneHeader::parse(&TINY_IMAGE).unwrap();
    h.flags |= scene_flags::POINTS;
    h.total_len = (64 + body.len()) as u32;
    h.body_crc = crc32(&body);
    let mut image = h.to_bytes().to_vec();
    image.extend_from_slice(&body);
    image
}

#[derive(Default)]
struct Points {
    head: Option<PointsHead>,
    points: Vec<(u32, PointRecord)>,
}

impl SceneSink for Points {
    fn header(&mut self, _: &SceneHeader) -> Result<(), SceneError> {
        Ok(())
    }
    fn voxel_map(&mut self, _: u32, _: &[u8]) -> Result<(), SceneError> {
        Ok(())
    }
    fn material(&mut self, _: u16, _: gridrt_shared::scene::Material) -> Result<(), SceneError> {
        Ok(())
    }
    fn pe_begin(&mut self, _: u8, _: u32) -> Result<(), SceneError> {
        Ok(())
    }
    fn pe_word(&mut self, _: u32) -> Result<(), SceneError> {
        Ok(())
    }
    fn pe_end(&mut self) -> Result<(), SceneError> {
        Ok(())
    }
    fn points_begin(&mut self, head: &PointsHead) -> Result<(), SceneError> {
        self.head = Some(*head);
        Ok(())
    }
    fn point(&mut self, index: u32, p: PointRecord) -> Result<(), SceneError> {
        self.points.push((index, p));
        Ok(())
    }
}

fn stream(image: &[u8], chunk: usize) -> (Result<(), SceneError>, Points, bool) {
    let mut s = SceneStream::new();
    let mut sink = Points::default();
    for piece in image.chunks(chunk) {
        if let Err(e) = s.feed(piece, &mut sink) {
            return (Err(e), sink, false);
        }
    }
    (s.finish(), sink, s.is_done())
}

#[test]
fn golden_point_record_and_head_bytes() {
    let p = PointRecord { pos: [1.0, -2.0, 0.5], normal: [0.0, 1.0, 0.0], radius: 0.25, material: 2 };
    let want: [u8; POINT_LEN] = [
        0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0xC0, 0x00, 0x00, 0x00, 0x3F, // pos
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0x00, // normal
        0x00, 0x00, 0x80, 0x3E, // radius 0.25
        0x02, 0x00, 0x00, 0x00, // material 2, reserved
    ];
    assert_eq!(p.to_bytes(), want);
    assert_eq!(PointRecord::parse(&want, 3), Ok(p));
    let h = PointsHead { count: 3, bounds_min: [-1.0, 0.0, 0.0], bounds_max: [1.0, 2.0, 0.5] };
    let hb = h.to_bytes();
    assert_eq!(hb.len(), POINTS_HEAD_LEN);
    assert_eq!(hb[..12], [3, 0, 0, 0, 0, 0, 0, 0, 0x00, 0x00, 0x80, 0xBF]);
    assert_eq!(PointsHead::parse(&hb), Ok(h));
}

#[test]
fn point_section_streams_after_the_pe_blocks_in_any_chunking() {
    let pts: Vec<PointRecord> = (0..3).map(point).collect();
    let image = tiny_with_points(&pts);
    assert_eq!(image.len(), 348 + 32 + 3 * 32);
    for chunk in [1, 7, 32, 1000] {
        let (r, sink, done) = stream(&image, chunk);
        assert_eq!(r, Ok(()), "chunk {chunk}");
        assert!(done);
        assert_eq!(sink.head.unwrap().count, 3);
        assert_eq!(sink.points, pts.iter().enumerate().map(|(i, p)| (i as u32, *p)).collect::<Vec<_>>());
    }
    // An empty section is valid too.
    assert_eq!(stream(&tiny_with_points(&[]), 5).0, Ok(()));
    // Without the flag nothing changes: the §5.9 image still parses and has no section.
    let (r, sink, _) = stream(&TINY_IMAGE, 9);
    assert_eq!(r, Ok(()));
    assert!(sink.head.is_none());
}

#[test]
fn corrupted_point_sections_are_rejected() {
    let pts: Vec<PointRecord> = (0..2).map(point).collect();
    let good = tiny_with_points(&pts);
    // Truncated at every byte of the section: never done.
    for cut in 348..good.len() {
        let (r, _, done) = stream(&good[..cut], 16);
        assert!(!done && r == Err(SceneError::Truncated), "cut {cut}: {r:?}");
    }
    // Records that break a rule (header total_len and CRC fixed up so the record is judged).
    let bad = |p: PointRecord| stream(&tiny_with_points(&[point(0), p]), 13).0;
    assert_eq!(bad(PointRecord { radius: 0.0, ..point(1) }), Err(SceneError::BadRecord));
    assert_eq!(bad(PointRecord { radius: -1.0, ..point(1) }), Err(SceneError::BadRecord));
    assert_eq!(bad(PointRecord { normal: [0.0; 3], ..point(1) }), Err(SceneError::BadRecord));
    assert_eq!(bad(PointRecord { material: 1, ..point(1) }), Err(SceneError::BadRecord));
    assert_eq!(bad(PointRecord { pos: [f32::NAN, 0.0, 0.0], ..point(1) }), Err(SceneError::NonFinite));
    assert_eq!(bad(PointRecord { radius: f32::INFINITY, ..point(1) }), Err(SceneError::NonFinite));
    // A head whose count claims more points than the image holds ends early; one that claims
    // fewer leaves trailing bytes.
    let mut more = good.clone();
    more[348] = 3;
    let mut h = SceneHeader::parse(&more).unwrap();
    h.body_crc = crc32(&more[64..]);
    more[..64].copy_from_slice(&h.to_bytes());
    assert_eq!(stream(&more, 11).0, Err(SceneError::Truncated));
    let mut fewer = good.clone();
    fewer[348] = 1;
    let mut h = SceneHeader::parse(&fewer).unwrap();
    h.body_crc = crc32(&fewer[64..]);
    fewer[..64].copy_from_slice(&h.to_bytes());
    assert_eq!(stream(&fewer, 11).0, Err(SceneError::BadHeader));
    // Inverted or non-finite bounds.
    let mut head = PointsHead { count: 0, bounds_min: [1.0; 3], bounds_max: [0.0; 3] }.to_bytes();
    assert_eq!(PointsHead::parse(&head), Err(SceneError::BadRecord));
    head[8..12].copy_from_slice(&f32::NAN.to_le_bytes());
    assert_eq!(PointsHead::parse(&head), Err(SceneError::NonFinite));
    // A flipped body byte in the section: CRC.
    let mut flipped = good.clone();
    *flipped.last_mut().unwrap() ^= 1;
    assert_eq!(stream(&flipped, 64).0, Err(SceneError::BadCrc));
    // An image with the points but without the flag: the old reader's view, bytes after the end.
    let mut unflagged = good.clone();
    let mut h = SceneHeader::parse(&unflagged).unwrap();
    h.flags = 0;
    unflagged[..64].copy_from_slice(&h.to_bytes());
    assert_eq!(stream(&unflagged, 64).0, Err(SceneError::BadHeader));
}
