//! Golden-byte tests: every table and worked example of `shared/SPEC.md`, against literal
//! bytes computed independently (Python `struct`, `zlib.crc32` and a hand-written COBS
//! encoder), never copied from this crate's output.

mod common;

use common::*;
use gridrt_shared::frame::{self, FeedResult, FrameAccumulator, FrameError};
use gridrt_shared::fsl::{self, op, FslError, FslWord, ListEntry, RayKind, RayResult};
use gridrt_shared::msg::{
    self, render_flags, stat, DeviceInfo, ErrorCode, FlashError, FlashStatus, Msg, MsgType, PixelEncoding,
    RenderRequest, Sack, SackRanges, SceneStatus,
};
use gridrt_shared::scene::{
    self, DiffuseModel, Falloff, LightingRecord, Mapping, Material, MaterialModel, ObjectKind, ObjectRecord, PeImage,
    PrimKind, PrimRecord, ReflectMode, SceneError, SceneHeader, SceneStream, SpecularModel, TextureKind,
    TriangleRecord,
};
use gridrt_shared::PROTOCOL_VERSION;

// ---------------------------------------------------------------- §1, §2 frame

#[test]
fn versions_are_pinned() {
    assert_eq!(PROTOCOL_VERSION, 1);
    assert_eq!(scene::VERSION, 2);
}

/// §2.2 CRC parameter table: check value, residue, incremental digest.
#[test]
fn crc32_iso_hdlc_parameters() {
    assert_eq!(frame::crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(frame::crc32(b""), 0);
    let mut with_crc = b"123456789".to_vec();
    with_crc.extend_from_slice(&0xCBF4_3926u32.to_le_bytes());
    assert_eq!(frame::crc32(&with_crc), 0x2144_DF1C);
    let mut d = frame::Crc32Digest::default();
    d.update(b"1234");
    d.update(b"");
    d.update(b"56789");
    assert_eq!(d.finalize(), 0xCBF4_3926);
}

/// §2.4 limits table.
#[test]
fn frame_limits_table() {
    assert_eq!(frame::HEADER_LEN, 6);
    assert_eq!(frame::CRC_LEN, 4);
    assert_eq!(frame::MAX_PAYLOAD, 2048);
    assert_eq!(frame::MAX_RAW, 2058);
    assert_eq!(frame::MAX_ENCODED, 2068);
}

/// §2.1 header layout with distinct values in every field.
#[test]
fn frame_header_layout() {
    let w = wire(0xA5, 0x1234, &[0x77; 3]);
    let mut raw = vec![0u8; w.len()];
    let n = cobs::decode(&w[..w.len() - 1], &mut raw).unwrap();
    raw.truncate(n);
    assert_eq!(raw[..9], [0xA5, 0x01, 0x34, 0x12, 0x03, 0x00, 0x77, 0x77, 0x77]);
    assert_eq!(raw[9..], frame::crc32(&raw[..9]).to_le_bytes());
}

/// §2.3 worked example.
#[test]
fn frame_hello_worked_example() {
    let raw = [0x01, 0x01, 0x07, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00];
    assert_eq!(frame::crc32(&raw), 0x32DB_3B61);
    let expected = [0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00];
    assert_eq!(wire(0x01, 7, &[0x01, 0x00, 0x00, 0x00]), expected);
    let raw_full = [0x01, 0x01, 0x07, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00, 0x61, 0x3B, 0xDB, 0x32];
    assert_eq!(
        frame::parse_raw(&raw_full),
        Ok(frame::Frame { kind: 0x01, seq: 7, payload: &[0x01, 0x00, 0x00, 0x00] })
    );
}

/// §2.5 worked example: noise, a frame, a lone delimiter.
#[test]
fn accumulator_worked_example() {
    let hello = [0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00];
    let mut stream = vec![0x02, 0xAB, 0x00];
    stream.extend_from_slice(&hello);
    stream.push(0x00);
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    let rest = match acc.feed(&stream) {
        FeedResult::BadFrame { error: FrameError::DecodeTruncated, rest } => rest,
        other => panic!("{other:?}"),
    };
    assert_eq!(rest, &stream[3..]);
    let rest = match acc.feed(rest) {
        FeedResult::Frame { frame, rest } => {
            assert_eq!((frame.kind, frame.seq, frame.payload), (0x01, 7, &[1u8, 0, 0, 0][..]));
            rest
        }
        other => panic!("{other:?}"),
    };
    assert_eq!(rest, &[0x00]);
    assert_eq!(acc.feed(rest), FeedResult::Consumed);
    assert!(!acc.has_partial());
}

/// §2.5 worked example of a correction: the §2.3 Hello frame with bit 4 of wire byte 3 (the
/// low byte of `seq`) flipped arrives as seq 7; with bits 4 and 0 flipped it is rejected.
#[test]
fn accumulator_corrects_one_flipped_bit_worked_example() {
    let one = [0x04, 0x01, 0x01, 0x17, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00];
    let mut raw = [0x01, 0x01, 0x17, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00, 0x61, 0x3B, 0xDB, 0x32];
    assert_eq!(frame::crc32(&raw) ^ frame::CRC_OF_VALID_RAW, 0x0C18_EDFC, "the syndrome");
    assert!(frame::correct_single_bit(&mut raw));
    assert_eq!(raw[2], 0x07);
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    match acc.feed(&one) {
        FeedResult::Frame { frame, .. } => {
            assert_eq!((frame.kind, frame.seq, frame.payload), (0x01, 7, &[1u8, 0, 0, 0][..]))
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(acc.corrected(), 1);
    let two = [0x04, 0x01, 0x01, 0x16, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00];
    assert!(matches!(acc.feed(&two), FeedResult::BadFrame { error: FrameError::DecodeBadCrc, .. }));
    assert_eq!((acc.corrected(), frame::CORRECTABLE_RAW), (1, 375));
}

/// §2.2: a raw frame that ends right after a 254-byte non-zero run is encoded without the
/// final 0x01 code; decoders accept the form with it too.
#[test]
fn cobs_254_run_at_end_of_frame() {
    // Header 11 01 01 01 01 01 (kind 0x11, v1, seq 0x0101, len 257) has no zero byte; the only
    // zero of the raw frame is payload[6] (raw[12]); raw[13..267] must be non-zero.
    let mut payload = vec![0x5Au8; 257];
    payload[6] = 0;
    let raw = (1..=255u8)
        .find_map(|b| {
            payload[7] = b;
            let raw = raw_frame(0x11, 1, 0x0101, 257, &payload);
            raw[263..].iter().all(|&x| x != 0).then_some(raw)
        })
        .unwrap();
    assert_eq!(raw.len(), 267);
    let mut expected = vec![13u8];
    expected.extend_from_slice(&raw[..12]);
    expected.push(0xFF);
    expected.extend_from_slice(&raw[13..]);
    expected.push(0x00);
    assert_eq!(wire(0x11, 0x0101, &payload), expected);
    let mut with_code = expected.clone();
    with_code.insert(with_code.len() - 1, 0x01);
    for form in [&expected, &with_code] {
        let mut acc = FrameAccumulator::<1024>::new();
        assert_eq!(feed_all(&mut acc, form, 7), [Outcome::Frame { kind: 0x11, seq: 0x0101, payload: payload.clone() }]);
    }
}

/// §2.4: the largest frame, worst-case payload, fits the default accumulator.
#[test]
fn largest_frame_fits_default_accumulator() {
    let payload = [0xFFu8; frame::MAX_PAYLOAD];
    let w = wire(0x21, 0xFFFF, &payload);
    assert!(w.len() <= frame::MAX_ENCODED);
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    assert_eq!(feed_all(&mut acc, &w, 4096), [Outcome::Frame { kind: 0x21, seq: 0xFFFF, payload: payload.to_vec() }]);
}

// ---------------------------------------------------------------- §3 messages

/// §3.0 type table; every other byte is unknown.
#[test]
fn msg_type_table() {
    let table = [
        (0x01, MsgType::Hello),
        (0x02, MsgType::Version),
        (0x10, MsgType::SceneBegin),
        (0x11, MsgType::SceneChunk),
        (0x12, MsgType::SceneAck),
        (0x13, MsgType::SceneData),
        (0x14, MsgType::SceneSack),
        (0x20, MsgType::RenderRequest),
        (0x21, MsgType::PixelSpan),
        (0x22, MsgType::FrameEnd),
        (0x23, MsgType::Stats),
        (0x24, MsgType::RenderRegion),
        (0x25, MsgType::RegionEnd),
        (0x30, MsgType::FlashBegin),
        (0x31, MsgType::FlashChunk),
        (0x32, MsgType::FlashAck),
        (0x33, MsgType::FlashBoot),
        (0x34, MsgType::FlashData),
        (0x35, MsgType::FlashSack),
        (0x7F, MsgType::Error),
    ];
    for (b, t) in table {
        assert_eq!(t as u8, b);
    }
    for b in 0..=255u8 {
        assert_eq!(MsgType::from_u8(b), table.iter().find(|(x, _)| *x == b).map(|(_, t)| *t), "byte {b:#04x}");
    }
}

#[test]
fn msg_hello() {
    check_msg(
        Msg::Hello { protocol: 1 },
        7,
        &[0x01, 0x00, 0x00, 0x00],
        &[0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00],
    );
}

#[test]
fn msg_version() {
    let d = DeviceInfo {
        protocol: 1,
        firmware: [0, 1, 0],
        board: 0,
        max_payload: 2048,
        pe_count: 4,
        voxel_capacity: 262_144,
        pe_mem_words: 16_384,
        features: 3,
    };
    check_msg(
        Msg::Version(d),
        7,
        &[
            0x01, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x08, 0x04, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x40, 0x00, 0x00,
            0x03, 0x00, 0x00, 0x00,
        ],
        &[
            0x04, 0x02, 0x01, 0x07, 0x02, 0x16, 0x02, 0x01, 0x01, 0x02, 0x01, 0x01, 0x01, 0x03, 0x08, 0x04, 0x01, 0x01,
            0x02, 0x04, 0x01, 0x02, 0x40, 0x01, 0x02, 0x03, 0x01, 0x01, 0x05, 0x30, 0x1D, 0xB8, 0xB3, 0x00,
        ],
    );
}

/// §3.2 table offsets, with a distinct value in every field.
#[test]
fn msg_version_field_offsets() {
    let d = DeviceInfo {
        protocol: 0x0201,
        firmware: [0x03, 0x04, 0x05],
        board: 0x06,
        max_payload: 0x0807,
        pe_count: 0x0A09,
        voxel_capacity: 0x0E0D_0C0B,
        pe_mem_words: 0x1211_100F,
        features: 0x1615_1413,
    };
    let p = encode_payload(&Msg::Version(d));
    assert_eq!(p, (1..=22).collect::<Vec<u8>>());
}

#[test]
fn msg_scene_begin() {
    // Protocol-1 golden bytes, frozen (§1): the numbers are those of a 164-byte image of the
    // scene layout before the version-2 merge; the message does not depend on the image.
    check_msg(
        Msg::SceneBegin { total_len: 164, crc: 0x0134_40EF },
        8,
        &[0xA4, 0x00, 0x00, 0x00, 0xEF, 0x40, 0x34, 0x01],
        &[
            0x04, 0x10, 0x01, 0x08, 0x02, 0x08, 0x02, 0xA4, 0x01, 0x01, 0x09, 0xEF, 0x40, 0x34, 0x01, 0x9D, 0x5C, 0xE8,
            0x63, 0x00,
        ],
    );
}

#[test]
fn msg_scene_chunk() {
    check_msg(
        // Protocol-1 golden bytes, frozen (§1): the first 8 bytes of a pre-merge image.
        Msg::SceneChunk { offset: 0, data: b"GRTS\x01\x00\x40\x00" },
        9,
        &[0x00, 0x00, 0x00, 0x00, 0x47, 0x52, 0x54, 0x53, 0x01, 0x00, 0x40, 0x00],
        &[
            0x04, 0x11, 0x01, 0x09, 0x02, 0x0C, 0x01, 0x01, 0x01, 0x01, 0x06, 0x47, 0x52, 0x54, 0x53, 0x01, 0x02, 0x40,
            0x05, 0xF4, 0x95, 0xB9, 0xE1, 0x00,
        ],
    );
}

#[test]
fn msg_scene_ack() {
    assert_eq!(SceneStatus::Receiving as u8, 0);
    assert_eq!(SceneStatus::Loaded as u8, 1);
    check_msg(
        Msg::SceneAck { next_offset: 8, status: SceneStatus::Receiving },
        9,
        &[0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00],
        &[
            0x04, 0x12, 0x01, 0x09, 0x02, 0x08, 0x02, 0x08, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x05, 0x53, 0x39, 0x6A,
            0xD6, 0x00,
        ],
    );
}

#[test]
fn msg_scene_ack_loaded() {
    check_msg(
        Msg::SceneAck { next_offset: 164, status: SceneStatus::Loaded },
        10,
        &[0xA4, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00],
        &[
            0x04, 0x12, 0x01, 0x0A, 0x02, 0x08, 0x02, 0xA4, 0x01, 0x01, 0x02, 0x01, 0x01, 0x01, 0x05, 0x05, 0x7E, 0xAA,
            0xE4, 0x00,
        ],
    );
}

#[test]
fn msg_render_request() {
    assert_eq!(msg::RENDER_REQUEST_LEN, 72);
    assert_eq!((render_flags::SHADOWS, render_flags::PRIM_IDS), (1, 2));
    assert_eq!(0.15f32.to_bits(), 0x3E19_999A);
    check_msg(
        Msg::RenderRequest(example_request(PixelEncoding::Rgb888)),
        11,
        &[
            0x01, 0x00, 0x40, 0x01, 0xF0, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
            0xA0, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
            0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x34, 0x42, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00,
            0x80, 0x40, 0x00, 0x00, 0x40, 0x40, 0x00, 0x00, 0x80, 0x3F, 0x9A, 0x99, 0x19, 0x3E, 0x00, 0x00, 0x00, 0x00,
        ],
        &[
            0x04, 0x20, 0x01, 0x0B, 0x02, 0x48, 0x02, 0x01, 0x04, 0x40, 0x01, 0xF0, 0x02, 0x03, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xA0, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x80, 0x3F, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x34,
            0x42, 0x01, 0x01, 0x02, 0x40, 0x01, 0x03, 0x80, 0x40, 0x01, 0x03, 0x40, 0x40, 0x01, 0x07, 0x80, 0x3F, 0x9A,
            0x99, 0x19, 0x3E, 0x01, 0x01, 0x01, 0x05, 0x9B, 0x4F, 0x5F, 0x9A, 0x00,
        ],
    );
}

/// §3.6 table offsets, with a distinct value in every field.
#[test]
fn msg_render_request_field_offsets() {
    let f = |i: u32| f32::from_bits(0x4000_0000 | i);
    let r = RenderRequest {
        frame: 0x0101,
        width: 0x0202,
        height: 0x0303,
        flags: 0x0404,
        eye: [f(8), f(12), f(16)],
        target: [f(20), f(24), f(28)],
        up: [f(32), f(36), f(40)],
        fov_y_deg: f(44),
        light_pos: [f(48), f(52), f(56)],
        light_intensity: f(60),
        ambient: f(64),
        encoding: PixelEncoding::PrimId32,
    };
    let p = encode_payload(&Msg::RenderRequest(r));
    assert_eq!(p.len(), 72);
    assert_eq!(p[..8], [1, 1, 2, 2, 3, 3, 4, 4]);
    for off in (8..68).step_by(4) {
        assert_eq!(p[off..off + 4], [off as u8, 0, 0, 0x40], "f32 at offset {off}");
    }
    assert_eq!(p[68..], [0x80, 0, 0, 0]);
    assert_eq!(Msg::decode(0x20, &p), Ok(Msg::RenderRequest(r)));
}

#[test]
fn msg_pixel_span_rgb888() {
    assert_eq!(PixelEncoding::Rgb888 as u8, 0);
    assert_eq!(PixelEncoding::Rgb888.bytes_per_pixel(), 3);
    check_msg(
        Msg::PixelSpan {
            frame: 1,
            y: 2,
            x0: 3,
            count: 2,
            encoding: PixelEncoding::Rgb888,
            data: &[0xFF, 0x00, 0x80, 0x10, 0x20, 0x30],
        },
        12,
        &[0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x02, 0x00, 0x00, 0x00, 0xFF, 0x00, 0x80, 0x10, 0x20, 0x30],
        &[
            0x04, 0x21, 0x01, 0x0C, 0x02, 0x10, 0x02, 0x01, 0x02, 0x02, 0x02, 0x03, 0x02, 0x02, 0x01, 0x01, 0x02, 0xFF,
            0x09, 0x80, 0x10, 0x20, 0x30, 0xF6, 0x58, 0x5A, 0xCF, 0x00,
        ],
    );
}

#[test]
fn msg_pixel_span_primid32() {
    assert_eq!(PixelEncoding::PrimId32 as u8, 0x80);
    assert_eq!(PixelEncoding::PrimId32.bytes_per_pixel(), 4);
    for b in 0..=255u8 {
        let expected = match b {
            0 => Some(PixelEncoding::Rgb888),
            1 => Some(PixelEncoding::Rgb565),
            2 => Some(PixelEncoding::Rle),
            0x80 => Some(PixelEncoding::PrimId32),
            _ => None,
        };
        assert_eq!(PixelEncoding::from_u8(b), expected);
    }
    check_msg(
        Msg::PixelSpan {
            frame: 1,
            y: 2,
            x0: 3,
            count: 2,
            encoding: PixelEncoding::PrimId32,
            data: &[0x2A, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF],
        },
        13,
        &[0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x02, 0x00, 0x80, 0x00, 0x2A, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF],
        &[
            0x04, 0x21, 0x01, 0x0D, 0x02, 0x12, 0x02, 0x01, 0x02, 0x02, 0x02, 0x03, 0x02, 0x02, 0x02, 0x80, 0x02, 0x2A,
            0x01, 0x01, 0x09, 0xFF, 0xFF, 0xFF, 0xFF, 0x7A, 0xC8, 0x23, 0x37, 0x00,
        ],
    );
}

#[test]
fn msg_frame_end() {
    check_msg(
        Msg::FrameEnd { frame: 1, spans: 480, image_crc: 0x1234_5678 },
        15,
        &[0x01, 0x00, 0x00, 0x00, 0xE0, 0x01, 0x00, 0x00, 0x78, 0x56, 0x34, 0x12],
        &[
            0x04, 0x22, 0x01, 0x0F, 0x02, 0x0C, 0x02, 0x01, 0x01, 0x01, 0x03, 0xE0, 0x01, 0x01, 0x09, 0x78, 0x56, 0x34,
            0x12, 0xDE, 0x1B, 0x1B, 0x2C, 0x00,
        ],
    );
}

/// §3.8 key table.
#[test]
fn msg_stat_key_table() {
    assert_eq!(msg::STAT_ENTRY_LEN, 9);
    let keys = [
        stat::PRIMARY_RAYS,
        stat::SHADOW_RAYS,
        stat::COPROC_RAYS,
        stat::CULLED_RAYS,
        stat::FSL_WORDS_OUT,
        stat::FSL_WORDS_IN,
        stat::INTERSECTION_TESTS,
        stat::COPROC_CYCLES,
        stat::PIXELS,
        stat::LIST_ENTRIES,
    ];
    assert_eq!(keys, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
    assert_eq!(stat::STAGE_BASE, 0x40);
    assert_eq!((stat::MODEL_INSTRUCTIONS, stat::LINK_WRAPPER_INSTRUCTIONS), (0x28, 0x29));
}

#[test]
fn msg_stats() {
    let entries = [
        0x01, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, //
        0x08, 0x15, 0xCD, 0x5B, 0x07, 0x00, 0x00, 0x00, 0x00,
    ];
    assert_eq!(
        msg::stat_entries(&entries).collect::<Vec<_>>(),
        [(stat::PRIMARY_RAYS, 76_800), (stat::COPROC_CYCLES, 123_456_789)]
    );
    check_msg(
        Msg::Stats { frame: 1, entries: &entries },
        14,
        &[
            0x01, 0x00, 0x02, 0x00, 0x01, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x15, 0xCD, 0x5B, 0x07,
            0x00, 0x00, 0x00, 0x00,
        ],
        &[
            0x04, 0x23, 0x01, 0x0E, 0x02, 0x16, 0x02, 0x01, 0x02, 0x02, 0x02, 0x01, 0x03, 0x2C, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x06, 0x08, 0x15, 0xCD, 0x5B, 0x07, 0x01, 0x01, 0x01, 0x05, 0x87, 0x85, 0x4E, 0xB2, 0x00,
        ],
    );
}

/// §3.9 code table.
#[test]
fn msg_error_code_table() {
    let table = [
        (1, ErrorCode::BadFrame),
        (2, ErrorCode::UnexpectedMessage),
        (3, ErrorCode::SceneRejected),
        (4, ErrorCode::Coprocessor),
        (5, ErrorCode::NoScene),
        (6, ErrorCode::BadRequest),
        (7, ErrorCode::BadOffset),
        (8, ErrorCode::FlashRejected),
    ];
    for (c, e) in table {
        assert_eq!(e.code(), c);
        assert_eq!(ErrorCode::from_code(c), e);
    }
    for c in [0u16, 9, 0x7F, 0xFFFF] {
        assert_eq!(ErrorCode::from_code(c), ErrorCode::Unknown(c));
        assert_eq!(ErrorCode::Unknown(c).code(), c);
    }
    assert_eq!(msg::MAX_ERROR_TEXT, 128);
}

#[test]
fn msg_error() {
    check_msg(
        Msg::Error { code: ErrorCode::NoScene, detail: 0, text: "no scene" },
        16,
        &[0x05, 0x00, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x6E, 0x6F, 0x20, 0x73, 0x63, 0x65, 0x6E, 0x65],
        &[
            0x04, 0x7F, 0x01, 0x10, 0x02, 0x10, 0x02, 0x05, 0x02, 0x08, 0x01, 0x01, 0x01, 0x01, 0x0D, 0x6E, 0x6F, 0x20,
            0x73, 0x63, 0x65, 0x6E, 0x65, 0x12, 0x76, 0x42, 0x27, 0x00,
        ],
    );
}

/// §2.4: the per-message limits implied by MAX_PAYLOAD.
#[test]
fn msg_size_limits() {
    let mut out = vec![0u8; frame::MAX_ENCODED];
    let fits = |m: Msg<'_>, out: &mut [u8]| frame::encode_frame(m.kind() as u8, 0, &encode_payload(&m), out).is_ok();
    let data = vec![0x11u8; 4 * 680];
    assert!(fits(Msg::SceneChunk { offset: 0, data: &data[..2044] }, &mut out));
    assert!(!fits(Msg::SceneChunk { offset: 0, data: &data[..2045] }, &mut out));
    let span = |count: u16, encoding: PixelEncoding| Msg::PixelSpan {
        frame: 0,
        y: 0,
        x0: 0,
        count,
        encoding,
        data: &data[..count as usize * encoding.bytes_per_pixel()],
    };
    assert!(fits(span(679, PixelEncoding::Rgb888), &mut out));
    assert!(!fits(span(680, PixelEncoding::Rgb888), &mut out));
    assert!(fits(span(509, PixelEncoding::PrimId32), &mut out));
    assert!(!fits(span(510, PixelEncoding::PrimId32), &mut out));
    assert!(fits(Msg::Stats { frame: 0, entries: &data[..227 * 9] }, &mut out));
    assert!(!fits(Msg::Stats { frame: 0, entries: &data[..228 * 9] }, &mut out));
    let text = "x".repeat(128);
    assert_eq!(encode_payload(&Msg::Error { code: ErrorCode::BadFrame, detail: 0, text: &text }).len(), 136);
}

// ---------------------------------------------------------------- §3.11 flashing

/// §3.11 constants and the FlashError / FlashStatus numbering.
#[test]
fn msg_flash_tables() {
    assert_eq!(msg::FLASH_FORMAT_VERSION, 1);
    assert_eq!(msg::FEATURE_BOOTLOADER, 0x8000_0000);
    assert_eq!([FlashStatus::Receiving as u8, FlashStatus::Verified as u8, FlashStatus::Booting as u8], [0, 1, 2]);
    let table = [
        (1, FlashError::BadVersion),
        (2, FlashError::TooLarge),
        (3, FlashError::BadAddress),
        (4, FlashError::BadEntry),
        (5, FlashError::BadCrc),
        (6, FlashError::NotBegun),
        (7, FlashError::NotVerified),
        (8, FlashError::Overrun),
    ];
    for (c, e) in table {
        assert_eq!(e.code(), c);
        assert_eq!(FlashError::from_code(c), Some(e));
    }
    assert_eq!(FlashError::from_code(0), None);
    assert_eq!(FlashError::from_code(9), None);
}

#[test]
fn msg_flash_begin() {
    check_msg(
        Msg::FlashBegin { version: 1, total_len: 0x1234, crc: 0xDEAD_BEEF, load_addr: 0x8010_0000, entry: 0x8010_0000 },
        1,
        &[
            0x01, 0x00, 0x00, 0x00, 0x34, 0x12, 0x00, 0x00, 0xEF, 0xBE, 0xAD, 0xDE, 0x00, 0x00, 0x10, 0x80, 0x00, 0x00,
            0x10, 0x80,
        ],
        &[
            0x04, 0x30, 0x01, 0x01, 0x02, 0x14, 0x02, 0x01, 0x01, 0x01, 0x03, 0x34, 0x12, 0x01, 0x05, 0xEF, 0xBE, 0xAD,
            0xDE, 0x01, 0x03, 0x10, 0x80, 0x01, 0x07, 0x10, 0x80, 0xC1, 0x94, 0xEC, 0x55, 0x00,
        ],
    );
}

#[test]
fn msg_flash_chunk() {
    check_msg(
        Msg::FlashChunk { offset: 0x400, data: &[0x97, 0x01, 0x00, 0x00] },
        2,
        &[0x00, 0x04, 0x00, 0x00, 0x97, 0x01, 0x00, 0x00],
        &[
            0x04, 0x31, 0x01, 0x02, 0x02, 0x08, 0x01, 0x02, 0x04, 0x01, 0x03, 0x97, 0x01, 0x01, 0x05, 0xD2, 0x4C, 0x02,
            0x10, 0x00,
        ],
    );
}

#[test]
fn msg_flash_ack() {
    check_msg(
        Msg::FlashAck { next_offset: 0x404, status: FlashStatus::Receiving, crc: 0 },
        3,
        &[0x04, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00],
        &[
            0x04, 0x32, 0x01, 0x03, 0x02, 0x0C, 0x03, 0x04, 0x04, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x05, 0x87, 0xE6, 0x6E, 0x26, 0x00,
        ],
    );
    check_msg(
        Msg::FlashAck { next_offset: 0x1234, status: FlashStatus::Verified, crc: 0xDEAD_BEEF },
        4,
        &[0x34, 0x12, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0xEF, 0xBE, 0xAD, 0xDE],
        &[
            0x04, 0x32, 0x01, 0x04, 0x02, 0x0C, 0x03, 0x34, 0x12, 0x01, 0x02, 0x01, 0x01, 0x01, 0x09, 0xEF, 0xBE, 0xAD,
            0xDE, 0xE3, 0x99, 0x49, 0x7E, 0x00,
        ],
    );
    // Status 3 is not assigned.
    let bad = [0x34, 0x12, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0xEF, 0xBE, 0xAD, 0xDE];
    assert_eq!(Msg::decode(0x32, &bad), Err(msg::MsgError::DecodeBadField));
}

#[test]
fn msg_flash_boot() {
    check_msg(
        Msg::FlashBoot { crc: 0xDEAD_BEEF },
        5,
        &[0xEF, 0xBE, 0xAD, 0xDE],
        &[0x04, 0x33, 0x01, 0x05, 0x02, 0x04, 0x09, 0xEF, 0xBE, 0xAD, 0xDE, 0x7F, 0xB6, 0x5A, 0x9F, 0x00],
    );
}

#[test]
fn msg_flash_rejected_error() {
    check_msg(
        Msg::Error { code: ErrorCode::FlashRejected, detail: FlashError::BadCrc.code(), text: "bad crc" },
        6,
        &[0x08, 0x00, 0x07, 0x00, 0x05, 0x00, 0x00, 0x00, 0x62, 0x61, 0x64, 0x20, 0x63, 0x72, 0x63],
        &[
            0x04, 0x7F, 0x01, 0x06, 0x02, 0x0F, 0x02, 0x08, 0x02, 0x07, 0x02, 0x05, 0x01, 0x01, 0x0C, 0x62, 0x61, 0x64,
            0x20, 0x63, 0x72, 0x63, 0x12, 0xF4, 0x6A, 0x48, 0x00,
        ],
    );
}

// ---------------------------------------------------------------- §3.14 windowed transfers

fn sack(next_offset: u32, heard: u16, window: u16, crc: u32, ranges: &[(u16, u16)]) -> Sack {
    let mut r = SackRanges::new();
    for &(a, b) in ranges {
        assert!(r.push(a, b));
    }
    Sack { next_offset, heard, window, crc, ranges: r }
}

/// §3.14 constants: the feature bit, the range limit and the layout sizes.
#[test]
fn msg_windowed_tables() {
    assert_eq!(msg::feature::WINDOWED, 1 << 11);
    assert_eq!(msg::region_options::NO_STATS, 1 << 1);
    assert_eq!((msg::MAX_SACK_RANGES, msg::SACK_HEAD_LEN, msg::SACK_RANGE_LEN), (4, 16, 4));
}

#[test]
fn msg_scene_data() {
    check_msg(
        Msg::SceneData { offset: 0x400, data: b"GRTS" },
        9,
        &[0x00, 0x04, 0x00, 0x00, 0x47, 0x52, 0x54, 0x53],
        &[
            0x04, 0x13, 0x01, 0x09, 0x02, 0x08, 0x01, 0x02, 0x04, 0x01, 0x09, 0x47, 0x52, 0x54, 0x53, 0xC7, 0xE5, 0x81,
            0x29, 0x00,
        ],
    );
}

/// §3.14 worked example: the device holds bytes 0..0x200, 0x400..0x600 and 0x800..0x810 of the
/// §5.9 image's upload (named by its CRC) after frame 12.
#[test]
fn msg_scene_sack_with_ranges() {
    check_msg(
        Msg::SceneSack {
            status: SceneStatus::Receiving,
            sack: sack(0x200, 12, 4096, TINY_IMAGE_CRC, &[(0x200, 0x400), (0x600, 0x610)]),
        },
        10,
        &[
            0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x0C, 0x00, 0x00, 0x10, 0x00, 0x00, 0xA2, 0x82, 0x96, 0x2A, 0x00, 0x02,
            0x00, 0x04, 0x00, 0x06, 0x10, 0x06,
        ],
        &[
            0x04, 0x14, 0x01, 0x0A, 0x02, 0x18, 0x01, 0x02, 0x02, 0x01, 0x01, 0x03, 0x02, 0x0C, 0x01, 0x02, 0x10, 0x01,
            0x05, 0xA2, 0x82, 0x96, 0x2A, 0x02, 0x02, 0x02, 0x04, 0x08, 0x06, 0x10, 0x06, 0x8D, 0x2A, 0x73, 0x77, 0x00,
        ],
    );
}

#[test]
fn msg_scene_sack_loaded() {
    check_msg(
        Msg::SceneSack { status: SceneStatus::Loaded, sack: sack(348, 13, 4096, TINY_IMAGE_CRC, &[]) },
        11,
        &[0x5C, 0x01, 0x00, 0x00, 0x01, 0x00, 0x0D, 0x00, 0x00, 0x10, 0x00, 0x00, 0xA2, 0x82, 0x96, 0x2A],
        &[
            0x04, 0x14, 0x01, 0x0B, 0x02, 0x10, 0x03, 0x5C, 0x01, 0x01, 0x02, 0x01, 0x02, 0x0D, 0x01, 0x02, 0x10, 0x01,
            0x09, 0xA2, 0x82, 0x96, 0x2A, 0x20, 0x4D, 0x02, 0xF8, 0x00,
        ],
    );
}

#[test]
fn msg_flash_data() {
    check_msg(
        Msg::FlashData { offset: 0x400, data: &[0x97, 0x01, 0x00, 0x00] },
        2,
        &[0x00, 0x04, 0x00, 0x00, 0x97, 0x01, 0x00, 0x00],
        &[
            0x04, 0x34, 0x01, 0x02, 0x02, 0x08, 0x01, 0x02, 0x04, 0x01, 0x03, 0x97, 0x01, 0x01, 0x05, 0xBF, 0x22, 0xA1,
            0x94, 0x00,
        ],
    );
}

#[test]
fn msg_flash_sack_verified() {
    check_msg(
        Msg::FlashSack { status: FlashStatus::Verified, sack: sack(0x1234, 5, 0xFFFF, 0xDEAD_BEEF, &[]) },
        4,
        &[0x34, 0x12, 0x00, 0x00, 0x01, 0x00, 0x05, 0x00, 0xFF, 0xFF, 0x00, 0x00, 0xEF, 0xBE, 0xAD, 0xDE],
        &[
            0x04, 0x35, 0x01, 0x04, 0x02, 0x10, 0x03, 0x34, 0x12, 0x01, 0x02, 0x01, 0x02, 0x05, 0x03, 0xFF, 0xFF, 0x01,
            0x09, 0xEF, 0xBE, 0xAD, 0xDE, 0x39, 0xF9, 0x7E, 0x06, 0x00,
        ],
    );
}

/// §3.14 Sack table offsets, with a distinct value in every field.
#[test]
fn msg_sack_field_offsets() {
    let m = Msg::FlashSack {
        status: FlashStatus::Verified,
        sack: sack(0x0403_0201, 0x0807, 0x0A09, 0x100F_0E0D, &[(0x1211, 0x1413), (0x1615, 0x1817)]),
    };
    let p = encode_payload(&m);
    let want: Vec<u8> =
        [0x01, 0x02, 0x03, 0x04, 0x01, 0x02, 0x07, 0x08, 0x09, 0x0A, 0x00, 0x00, 0x0D, 0x0E, 0x0F, 0x10]
            .into_iter()
            .chain(0x11..=0x18)
            .collect();
    assert_eq!(p, want);
}

// ---------------------------------------------------------------- §4 FSL

/// §4.1 opcode table.
#[test]
fn fsl_opcode_table() {
    assert_eq!(
        [op::LOAD_PE, op::RAY_CLOSEST, op::RAY_ANY, op::CLEAR, op::RESULT, op::ACK, op::ERROR],
        [0x1, 0x2, 0x3, 0x4, 0x8, 0x9, 0xE]
    );
    assert_eq!(RayKind::Closest.opcode(), 0x2);
    assert_eq!(RayKind::Any.opcode(), 0x3);
    assert_eq!(fsl::opcode(0xE007_0009), 0xE);
    assert_eq!(fsl::opcode(0x0FFF_FFFF), 0x0);
    assert_eq!((fsl::RAY_HEADER_WORDS, fsl::ENTRY_WORDS, fsl::RESULT_WORDS, fsl::MAX_LIST_ENTRIES), (8, 2, 8, 0x0FFF));
    assert_eq!(FslWord::data(5), FslWord { data: 5, control: false });
    assert_eq!(FslWord::last(5), FslWord { data: 5, control: true });
}

/// §4.2 worked example: GridRT's 8-word request and response.
#[test]
fn fsl_gridrt_baseline_worked_example() {
    let list = fsl::pack_gridrt_list(&[2, 0, 3]).unwrap();
    let request = [
        0.0f32.to_bits(),
        0.5f32.to_bits(),
        2.0f32.to_bits(),
        0.0f32.to_bits(),
        0.0f32.to_bits(),
        (-1.0f32).to_bits(),
        list,
        0,
    ];
    assert_eq!(
        request,
        [0x0000_0000, 0x3F00_0000, 0x4000_0000, 0x0000_0000, 0x0000_0000, 0xBF80_0000, 0xFFFF_F302, 0x0000_0000]
    );
    // Response: res0..res3, then res0 four times; PE 2 found t = 1.25, the others FLT_MAX.
    let res = [f32::MAX.to_bits(), f32::MAX.to_bits(), 1.25f32.to_bits(), f32::MAX.to_bits()];
    let response = [res[0], res[1], res[2], res[3], res[0], res[0], res[0], res[0]];
    assert_eq!(
        response,
        [0x7F7F_FFFF, 0x7F7F_FFFF, 0x3FA0_0000, 0x7F7F_FFFF, 0x7F7F_FFFF, 0x7F7F_FFFF, 0x7F7F_FFFF, 0x7F7F_FFFF]
    );
    // Nibble k holds the k-th voxel; -1 is 0xF; 8 slots at most; ids must fit 4 signed bits.
    assert_eq!(fsl::pack_gridrt_list(&[]), Some(0xFFFF_FFFF));
    assert_eq!(fsl::pack_gridrt_list(&[0, 1, 2, 3, 4, 5, 6, 7]), Some(0x7654_3210));
    assert_eq!(fsl::pack_gridrt_list(&[-1, 1]), Some(0xFFFF_FF1F));
    assert_eq!(fsl::pack_gridrt_list(&[0; 9]), None);
    assert_eq!(fsl::pack_gridrt_list(&[8]), None);
    assert_eq!(fsl::pack_gridrt_list(&[-2]), None);
}

/// §4.3 worked example: extended request with two entries, control bit on the last word.
#[test]
fn fsl_ray_request_worked_example() {
    let entries = [ListEntry { voxel: 5, pe: 3, t_exit: 1.5 }, ListEntry { voxel: 6, pe: 0, t_exit: 2.5 }];
    let mut words: Vec<u32> =
        fsl::ray_request_head(RayKind::Closest, [0.0, 0.5, 2.0], [0.0, 0.0, -1.0], f32::INFINITY, 2).to_vec();
    for e in entries {
        words.extend_from_slice(&fsl::entry_words(e));
    }
    assert_eq!(
        words,
        [
            0x2000_0002,
            0x0000_0000,
            0x3F00_0000,
            0x4000_0000,
            0x0000_0000,
            0x0000_0000,
            0xBF80_0000,
            0x7F80_0000,
            0x0300_0005,
            0x3FC0_0000,
            0x0000_0006,
            0x4020_0000
        ]
    );
    let n = words.len();
    let link: Vec<FslWord> =
        words.iter().enumerate().map(|(i, &w)| if i + 1 == n { FslWord::last(w) } else { FslWord::data(w) }).collect();
    assert_eq!(link.iter().filter(|w| w.control).count(), 1);
    assert!(link[n - 1].control);
    for (k, e) in entries.iter().enumerate() {
        assert_eq!(fsl::entry_from_words(words[8 + 2 * k], words[9 + 2 * k]), *e);
    }
    // Acceptance limit of entry 0: fl32(1.5 × (1 + 2^-12)).
    let slack = f32::from_bits(0x3F80_0800);
    assert_eq!(slack as f64, 1.0 + 2f64.powi(-12));
    assert_eq!((1.5f32 * slack).to_bits(), 0x3FC0_0C00);
    assert_eq!((1.5f32 * slack) as f64, 1.500_366_210_937_5);
}

#[test]
fn fsl_shadow_request() {
    let t_max = 1.0 - 2f32.powi(-10);
    assert_eq!(t_max.to_bits(), 0x3F7F_C000);
    let mut words = fsl::ray_request_head(RayKind::Any, [0.25, 0.25, 1.0], [1.0, 2.0, 1.0], t_max, 1).to_vec();
    words.extend_from_slice(&fsl::entry_words(ListEntry { voxel: 0, pe: 0, t_exit: 0.5 }));
    assert_eq!(
        words,
        [
            0x3000_0001,
            0x3E80_0000,
            0x3E80_0000,
            0x3F80_0000,
            0x3F80_0000,
            0x4000_0000,
            0x3F80_0000,
            0x3F7F_C000,
            0x0000_0000,
            0x3F00_0000
        ]
    );
}

/// §4.3 bit table of word 0 and of an entry's first word.
#[test]
fn fsl_request_bit_layout() {
    assert_eq!(fsl::ray_header(RayKind::Closest, 0xFFFF), 0x2000_FFFF);
    assert_eq!(fsl::ray_header(RayKind::Any, 0), 0x3000_0000);
    assert_eq!(fsl::VOXEL_MASK, 0x00FF_FFFF);
    let e = ListEntry { voxel: 0x00AB_CDEF, pe: 0x12, t_exit: -0.0 };
    assert_eq!(fsl::entry_words(e), [0x12AB_CDEF, 0x8000_0000]);
    assert_eq!(
        fsl::entry_from_words(0xFEFF_FFFF, 0x7F80_0000),
        ListEntry { voxel: 0x00FF_FFFF, pe: 0xFE, t_exit: f32::INFINITY }
    );
}

/// §4.4 worked example and the RESULT bit table.
#[test]
fn fsl_result_worked_example() {
    let r = RayResult {
        hit: true,
        pe: 2,
        list_pos: 1,
        t: 1.25,
        prim: 42,
        material: 3,
        tests: 17,
        normal: [0.0, 0.0, 1.0],
        cycles: 11_016,
    };
    let w = [0x8001_0201, 0x3FA0_0000, 0x0000_002A, 0x0011_0003, 0x0000_0000, 0x0000_0000, 0x3F80_0000, 0x0000_2B08];
    assert_eq!(r.to_words(), w);
    assert_eq!(RayResult::from_words(&w), Ok(r));
    assert_eq!(RayResult::MISS.to_words(), [0x8000_0000, 0x7F80_0000, 0, 0, 0, 0, 0, 0]);
    // Distinct values in every field.
    let r = RayResult {
        hit: true,
        pe: 0xAB,
        list_pos: 0xCDE,
        t: f32::from_bits(0x1111_1111),
        prim: 0x2222_2222,
        material: 0x3333,
        tests: 0x4444,
        normal: [f32::from_bits(0x5555_5555), f32::from_bits(0x6666_6666), f32::from_bits(0x0777_7777)],
        cycles: 0x8888_8888,
    };
    let w = [0x8CDE_AB01, 0x1111_1111, 0x2222_2222, 0x4444_3333, 0x5555_5555, 0x6666_6666, 0x0777_7777, 0x8888_8888];
    assert_eq!(r.to_words(), w);
    assert_eq!(RayResult::from_words(&w), Ok(r));
    // Reserved bits 7..1 are ignored by the decoder.
    assert_eq!(RayResult::from_words(&[0x8000_00FE, 0x7F80_0000, 0, 0, 0, 0, 0, 0]).map(|r| r.hit), Ok(false));
}

/// §4.4 worked example: LOAD_PE of the §5.9 image's PE 0, CLEAR and their ACK words.
#[test]
fn fsl_load_pe_worked_example() {
    assert_eq!(fsl::load_header(0), 0x1000_0000);
    assert_eq!(fsl::load_header(0xFE), 0x1000_00FE);
    let image: Vec<u32> = TINY_IMAGE[268..].chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    assert_eq!(image, TINY_PE_WORDS);
    let mut packet = vec![fsl::load_header(0), image.len() as u32];
    packet.extend_from_slice(&image);
    #[rustfmt::skip]
    let expected = [
        0x1000_0000, 0x0000_0014, // LOAD_PE to PE 0, 20 words
        0xFFFF_0002, 0x0000_0001, 0x0000_0001, 0x0000_0001, 0x0000_0000, // tag, T, V, R, P
        0x0000_0000, 0x0000_0000, 0x0000_0001, // voxel 0: first ref 0, 1 ref
        0x0000_0000, // ref 0 -> triangle 0
        0x3E80_0000, 0x3E80_0000, 0x3F00_0000, 0x3F40_0000, 0x3E80_0000, 0x3F00_0000,
        0x3E80_0000, 0x3F40_0000, 0x3F00_0000, 0x0000_0000, 0x0000_0000,
    ];
    assert_eq!(packet, expected);
    assert_eq!(fsl::CLEAR_WORD, 0x4000_0000);
    // ACK layout (§4.4): opcode, acknowledged opcode in 27..24, PE id in 7..0.
    assert_eq!(fsl::ack_word(op::LOAD_PE, 0), 0x9100_0000);
    assert_eq!(fsl::ack_word(op::LOAD_PE, 3), 0x9100_0003);
    assert_eq!(fsl::ack_word(op::CLEAR, 0), 0x9400_0000);
}

/// §4.5 ERROR code table and worked example.
#[test]
fn fsl_error_worked_example() {
    assert_eq!(FslError::ListTooLong.to_word(9), 0xE007_0009);
    assert_eq!(FslError::from_word(0xE007_0009), (FslError::ListTooLong, 9));
    let table = [
        (1, FslError::UnknownOpcode),
        (2, FslError::PacketTooShort),
        (3, FslError::MissingControl),
        (4, FslError::PeOutOfRange),
        (5, FslError::VoxelOutOfRange),
        (6, FslError::VoxelNotLoaded),
        (7, FslError::ListTooLong),
        (8, FslError::PeMemoryOverflow),
        (9, FslError::PeImageMalformed),
        (10, FslError::SceneNotLoaded),
        (11, FslError::NonFiniteRay),
        (0xFFF, FslError::UnknownError),
    ];
    for (c, e) in table {
        assert_eq!(e.code(), c);
        assert_eq!(FslError::from_code(c), e);
        assert_eq!(e.to_word(0xBEEF), 0xE000_BEEF | ((c as u32) << 16));
    }
    for c in [0u16, 14, 0x7FF, 0xFFFF] {
        assert_eq!(FslError::from_code(c), FslError::UnknownError);
    }
}

/// §4.5 codes added with FRAME (§4.6): 12 `BadFrame`, 13 `Unsupported`.
#[test]
fn fsl_error_codes_of_frame_and_unsupported_primitives() {
    assert_eq!(FslError::BadFrame.to_word(4), 0xE00C_0004);
    assert_eq!(FslError::Unsupported.to_word(2), 0xE00D_0002);
    assert_eq!(FslError::from_word(0xE00C_0004), (FslError::BadFrame, 4));
    assert_eq!(FslError::from_word(0xE00D_0002), (FslError::Unsupported, 2));
}

/// §4.6 FRAME worked example: the box (−1, 0, 0.5)..(1, 2, 4.5), its ACK `95000000`.
#[test]
fn fsl_frame_worked_example() {
    assert_eq!(fsl::op::FRAME, 0x5);
    assert_eq!(
        fsl::frame_packet([-1.0, 0.0, 0.5], [1.0, 2.0, 4.5]),
        [0x5000_0000, 0xBF80_0000, 0x0000_0000, 0x3F00_0000, 0x3F80_0000, 0x4000_0000, 0x4090_0000]
    );
    assert_eq!(fsl::ack_word(fsl::op::FRAME, 0), 0x9500_0000);
}

// ---------------------------------------------------------------- §5 scene image

/// §5.1 constants table.
#[test]
fn scene_constants_table() {
    assert_eq!(scene::MAGIC, [0x47, 0x52, 0x54, 0x53]);
    assert_eq!(scene::VERSION, 2);
    assert_eq!(scene::HEADER_LEN, 64);
    assert_eq!(scene::MATERIAL_LEN, 16);
    assert_eq!(scene::MATERIAL_MODEL_LEN, 96);
    assert_eq!(scene::OBJECT_LEN, 64);
    assert_eq!(scene::LIGHTING_LEN, 80);
    assert_eq!(scene::EMPTY_VOXEL, 0xFF);
    assert_eq!(scene::MAX_PES, 255);
    assert_eq!(scene::MAX_VOXELS, 1 << 24);
    assert_eq!(scene::MAX_DEPTH, 8);
    assert_eq!(scene::PE_IMAGE_TAG, 0xFFFF_0002);
    assert_eq!(
        (scene::PE_HEADER_WORDS, scene::VOXEL_ENTRY_WORDS, scene::TRIANGLE_WORDS, scene::PRIM_WORDS),
        (5, 3, 11, 16)
    );
}

/// §5.1 header table offsets, with a distinct value in every field.
#[test]
fn scene_header_field_offsets() {
    let h = SceneHeader {
        dims: [0x0201, 0x0403, 0x0605],
        pe_count: 0x0807,
        bounds_min: [f32::from_bits(0x1111_1111), f32::from_bits(0x2222_2222), f32::from_bits(0x3333_3333)],
        bounds_max: [f32::from_bits(0x4444_4444), f32::from_bits(0x5555_5555), f32::from_bits(0x6666_6666)],
        material_count: 0x0A09,
        flags: 0x0C0B,
        triangle_count: 0x100F_0E0D,
        pe_mem_words: 0x1413_1211,
        total_len: 0x1817_1615,
        body_crc: 0x1C1B_1A19,
        object_count: 0x1E1D,
    };
    let b = h.to_bytes();
    let expected: Vec<u8> = [
        &b"GRTS"[..],
        &[0x02, 0x00, 0x40, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08],
        &[0x11; 4],
        &[0x22; 4],
        &[0x33; 4],
        &[0x44; 4],
        &[0x55; 4],
        &[0x66; 4],
        &[0x09, 0x0A, 0x0B, 0x0C],
        &[0x0D, 0x0E, 0x0F, 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x17, 0x18, 0x19, 0x1A, 0x1B, 0x1C],
        &[0x1D, 0x1E, 0x00, 0x00],
    ]
    .concat();
    assert_eq!(b.to_vec(), expected);
    // Reserved bytes 62..64 are ignored by the reader.
    let mut with_reserved = TINY_IMAGE[..64].to_vec();
    with_reserved[62..64].copy_from_slice(&[0xAA, 0xBB]);
    assert_eq!(SceneHeader::parse(&with_reserved), SceneHeader::parse(&TINY_IMAGE[..64]));
}

/// §5.2 padding rule.
#[test]
fn scene_voxel_map_padding() {
    let h = SceneHeader::parse(&TINY_IMAGE[..64]).unwrap();
    for (dims, count, len) in [
        ([1, 1, 1], 1, 4),
        ([2, 1, 1], 2, 4),
        ([4, 1, 1], 4, 4),
        ([5, 1, 1], 5, 8),
        ([3, 3, 1], 9, 12),
        ([2, 3, 4], 24, 24),
    ] {
        let h = SceneHeader { dims, ..h };
        assert_eq!((h.voxel_count(), h.voxel_map_len()), (count, len), "{dims:?}");
    }
}

/// §5.3 material model table, with a distinct value in every field.
#[test]
fn scene_material_model_field_offsets() {
    let f = |i: u32| f32::from_bits(0x4000_0000 | i);
    let m = MaterialModel {
        diffuse_model: DiffuseModel::Matte,
        specular_model: SpecularModel::TorranceSparrow,
        reflect_mode: ReflectMode::Conductor,
        texture: TextureKind::RgbDots,
        mapping: Mapping::Cylindrical,
        bilinear: true,
        tex_log2: 12,
        ka: f(8),
        kd: f(12),
        ks: f(16),
        sigma2: f(20),
        exponent: f(24),
        specular: [f(28), f(32), f(36)],
        eta: f(40),
        kappa: f(44),
        colour2: [f(48), f(52), f(56)],
        uv_scale: [f(60), f(64)],
        uv_offset: [f(68), f(72)],
        tex_param: f(76),
        tex_seed: 0x8483_8281,
    };
    let b = m.to_bytes();
    assert_eq!(b.len(), 96);
    assert_eq!(b[..8], [2, 2, 3, 5, 1, 1, 12, 0]);
    for off in (8..80).step_by(4) {
        assert_eq!(b[off..off + 4], [off as u8, 0, 0, 0x40], "f32 at offset {off}");
    }
    assert_eq!(b[80..84], [0x81, 0x82, 0x83, 0x84]);
    assert_eq!(b[84..], [0; 12]);
    assert_eq!(MaterialModel::parse(&b), Ok(m));
    // Reserved bytes (7, 84..96) are ignored by the reader.
    let mut r = b;
    r[7] = 0xAA;
    r[84..].fill(0xBB);
    assert_eq!(MaterialModel::parse(&r), Ok(m));
}

/// §5.3 enum tables of the material model; every other value is `BadRecord`.
#[test]
fn scene_material_model_enum_tables() {
    assert_eq!([DiffuseModel::Lambert, DiffuseModel::OrenNayar, DiffuseModel::Matte].map(|d| d as u8), [0, 1, 2]);
    assert_eq!(
        [SpecularModel::None, SpecularModel::BlinnPhong, SpecularModel::TorranceSparrow].map(|s| s as u8),
        [0, 1, 2]
    );
    assert_eq!(
        [ReflectMode::None, ReflectMode::Constant, ReflectMode::Dielectric, ReflectMode::Conductor].map(|r| r as u8),
        [0, 1, 2, 3]
    );
    assert_eq!(
        [
            TextureKind::None,
            TextureKind::Checker,
            TextureKind::Xor,
            TextureKind::Marble,
            TextureKind::Wood,
            TextureKind::RgbDots
        ]
        .map(|t| t as u8),
        [0, 1, 2, 3, 4, 5]
    );
    assert_eq!([Mapping::Planar, Mapping::Cylindrical, Mapping::Spherical].map(|m| m as u8), [0, 1, 2]);
    // (byte, number of valid values).
    for (byte, valid) in [(0usize, 3u8), (1, 3), (2, 4), (3, 6), (4, 3), (5, 2)] {
        for v in 0..=255u8 {
            let mut b = matte_model();
            b[byte] = v;
            let r = MaterialModel::parse(&b);
            if v < valid {
                assert!(r.is_ok(), "byte {byte} = {v}");
            } else {
                assert_eq!(r, Err(SceneError::BadRecord), "byte {byte} = {v}");
            }
        }
    }
    for v in 0..=255u8 {
        let mut b = matte_model();
        b[6] = v;
        assert_eq!(MaterialModel::parse(&b).is_ok(), (1..=12).contains(&v), "tex_log2 {v}");
    }
    // The crate's presets are the records the test builder writes by hand.
    assert_eq!(MaterialModel::MATTE.to_bytes(), matte_model());
    assert_eq!(MaterialModel::DEFAULT.to_bytes(), model_bytes([0, 0, 0, 0, 0, 1, 8, 0], DEFAULT_MODEL_FLOATS, 0));
}

/// §5.5 object table, with a distinct value in every field, and the kind table.
#[test]
fn scene_object_field_offsets() {
    let f = |i: u32| f32::from_bits(0x4000_0000 | i);
    let o = ObjectRecord {
        kind: ObjectKind::Plane,
        material: 0x0302,
        first_prim: 0x0706_0504,
        prim_count: 0x0B0A_0908,
        world_to_object: core::array::from_fn(|k| f(16 + 4 * k as u32)),
    };
    let b = o.to_bytes();
    assert_eq!(b.len(), 64);
    assert_eq!(b[..16], [6, 0, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B, 0, 0, 0, 0]);
    for off in (16..64).step_by(4) {
        assert_eq!(b[off..off + 4], [off as u8, 0, 0, 0x40], "f32 at offset {off}");
    }
    assert_eq!(ObjectRecord::parse(&b), Ok(o));
    let kinds = [
        ObjectKind::Mesh,
        ObjectKind::Sphere,
        ObjectKind::Cylinder,
        ObjectKind::Cone,
        ObjectKind::Disk,
        ObjectKind::Square,
        ObjectKind::Plane,
    ];
    for v in 0..=255u8 {
        let mut b = object_bytes(v, 0, 0, 1, HALF_SCALE);
        match kinds.get(v as usize) {
            Some(&k) => assert_eq!(ObjectRecord::parse(&b).map(|o| o.kind), Ok(k)),
            None => assert_eq!(ObjectRecord::parse(&b), Err(SceneError::BadRecord), "kind {v}"),
        }
        // Reserved bytes 1 and 12..16 are ignored.
        b[1] = 0xAA;
        b[12..16].fill(0xBB);
        assert_eq!(ObjectRecord::parse(&b).is_ok(), (v as usize) < kinds.len());
    }
}

/// §5.6 lighting table, with a distinct value in every field, and its presets.
#[test]
fn scene_lighting_field_offsets() {
    let f = |i: u32| f32::from_bits(0x4000_0000 | i);
    let l = LightingRecord {
        light_count: 1,
        max_depth: 8,
        falloff: Falloff::InverseSquare,
        light_colour: [f(4), f(8), f(12)],
        spot_dir: [f(16), f(20), f(24)],
        cos_outer: f(28),
        cos_inner: f(32),
        ambient_colour: [f(36), f(40), f(44)],
        background: [f(48), f(52), f(56)],
    };
    let b = l.to_bytes();
    assert_eq!(b.len(), 80);
    assert_eq!(b[..4], [1, 8, 1, 0]);
    for off in (4..60).step_by(4) {
        assert_eq!(b[off..off + 4], [off as u8, 0, 0, 0x40], "f32 at offset {off}");
    }
    assert_eq!(b[60..], [0; 20]);
    assert_eq!(LightingRecord::parse(&b), Ok(l));
    let mut r = b;
    r[3] = 0xAA;
    r[60..].fill(0xBB);
    assert_eq!(LightingRecord::parse(&r), Ok(l), "reserved bytes are ignored");
    assert_eq!((Falloff::None as u8, Falloff::InverseSquare as u8), (0, 1));
    assert_eq!(LightingRecord::DEFAULT.to_bytes(), default_lighting());
}

/// §5.4 PE memory image words of the §5.9 example (triangles only, P = 0).
#[test]
fn scene_pe_image_words() {
    let img = PeImage::parse(&TINY_PE_WORDS).unwrap();
    assert_eq!(TINY_PE_WORDS[..5], [scene::PE_IMAGE_TAG, 1, 1, 1, 0]);
    assert_eq!(img.header_words(), 5);
    assert_eq!((img.triangle_count(), img.voxel_count(), img.primitive_count()), (1, 1, 0));
    assert_eq!(img.voxel_entry(0), Some((0, 0, 1)));
    assert_eq!(img.voxel_entry(1), None);
    assert_eq!(img.ref_table(), &[0]);
    assert_eq!((img.triangle_offset(), img.primitive_offset()), (9, 20));
    let tri =
        TriangleRecord { vertices: [[0.25, 0.25, 0.5], [0.75, 0.25, 0.5], [0.25, 0.75, 0.5]], prim: 0, material: 0 };
    assert_eq!(img.triangle(0), Some(tri));
    assert_eq!(tri.to_words(), TINY_PE_WORDS[9..]);
    assert_eq!(img.triangle(1), None);
    assert_eq!(img.primitive(0), None);
    // An empty PE is 0 words.
    let empty = PeImage::parse(&[]).unwrap();
    assert_eq!(
        (empty.triangle_count(), empty.voxel_count(), empty.primitive_count(), empty.ref_table().len()),
        (0, 0, 0, 0)
    );
}

/// §5.4 PE memory image with an analytic primitive: the sphere of [`ImageSpec::sphere`].
#[test]
fn scene_pe_image_words_with_primitive() {
    let half = 0x3F00_0000;
    #[rustfmt::skip]
    let expected: [u32; 25] = [
        0xFFFF_0002, 0, 1, 1, 1, // tag, T 0, V 1, R 1, P 1
        0, 0, 1, // voxel 0: refs [0, 1)
        0, // ref 0 = T + 0 → primitive 0
        1, 0, 0, // kind sphere, prim 0, material 0
        half, 0, 0, 0, 0, half, 0, 0, 0, 0, half, 0, // W = diag(1/2)
        0, // reserved
    ];
    let spec = ImageSpec::sphere();
    let words = &spec.pe_blocks[0].2;
    assert_eq!(words[..], expected);
    let img = PeImage::parse(words).unwrap();
    assert_eq!((img.triangle_count(), img.voxel_count(), img.primitive_count()), (0, 1, 1));
    assert_eq!((img.triangle_offset(), img.primitive_offset()), (9, 9));
    let p = PrimRecord { kind: PrimKind::Sphere, prim: 0, material: 0, world_to_object: HALF_SCALE };
    assert_eq!(img.primitive(0), Some(p));
    assert_eq!(p.to_words()[..], expected[9..]);
    assert_eq!(img.primitive(1), None);
    // Kind table (§5.4).
    for v in 0..=255u32 {
        let kind = PrimKind::from_u32(v).map(|k| k as u32);
        assert_eq!(kind, (1..=5).contains(&v).then_some(v), "kind {v}");
    }
}

/// §5.4 PE memory image layout with several voxels, refs and triangles.
#[test]
fn scene_pe_image_layout() {
    let spec = ImageSpec::two_pe();
    let words = &spec.pe_blocks[0].2;
    // Tag, T=2 V=3 R=3 P=0; table (0,0,1) (1,1,1) (4,2,1); refs 0 0 1; then 2 × 11 words.
    assert_eq!(words[..14], [0xFFFF_0002, 2, 3, 3, 0, 0, 0, 1, 1, 1, 1, 4, 2, 1]);
    assert_eq!(words[14..17], [0, 0, 1]);
    assert_eq!(words.len(), 5 + 9 + 3 + 22);
    let img = PeImage::parse(words).unwrap();
    assert_eq!(img.voxel_entry(2), Some((4, 2, 1)));
    assert_eq!(img.ref_table(), &[0, 0, 1]);
    let t1 = img.triangle(1).unwrap();
    assert_eq!((t1.prim, t1.material), (1, 1));
    assert_eq!(t1.vertices[2], [1.3, 1.8, 0.4]);
    assert_eq!(t1.to_words()[..], words[28..39]);
}

/// §5.9 worked example: every byte, both CRCs, every header field, every record, the sink
/// calls and the PE image.
#[test]
fn scene_tiny_worked_example() {
    // The test's own builder reproduces the literal, and the CRCs are pinned.
    assert_eq!(ImageSpec::tiny().build(), TINY_IMAGE);
    assert_eq!(TINY_IMAGE.len(), 348);
    assert_eq!(frame::crc32(&TINY_IMAGE[64..]), 0xEF03_A2D3);
    assert_eq!(TINY_BODY_CRC, 0xEF03_A2D3);
    assert_eq!(frame::crc32(&TINY_IMAGE), 0x2A96_82A2);
    assert_eq!(TINY_IMAGE_CRC, 0x2A96_82A2);

    // The crate's serialisers reproduce it too, section by section.
    let h = SceneHeader {
        dims: [2, 1, 1],
        pe_count: 1,
        bounds_min: [0.0; 3],
        bounds_max: [2.0, 1.0, 1.0],
        material_count: 1,
        flags: 0,
        triangle_count: 1,
        pe_mem_words: 64,
        total_len: 348,
        body_crc: 0xEF03_A2D3,
        object_count: 0,
    };
    let [header, map, colours, models, lighting, block_head, end] = TINY_BOUNDARIES;
    assert_eq!(h.to_bytes(), TINY_IMAGE[..header]);
    assert_eq!(SceneHeader::parse(&TINY_IMAGE[..header]), Ok(h));
    assert_eq!(TINY_IMAGE[header..map], [0x00, 0xFF, 0x00, 0x00]);
    let m = Material { diffuse: [0.8; 3], reflect: 0.0 };
    assert_eq!(m.to_bytes(), TINY_IMAGE[map..colours]);
    assert_eq!(Material::parse(&TINY_IMAGE[map..colours]), Ok(m));
    assert_eq!(MaterialModel::MATTE.to_bytes(), TINY_IMAGE[colours..models]);
    assert_eq!(MaterialModel::parse(&TINY_IMAGE[colours..models]), Ok(MaterialModel::MATTE));
    assert_eq!(LightingRecord::DEFAULT.to_bytes(), TINY_IMAGE[models..lighting]);
    assert_eq!(LightingRecord::parse(&TINY_IMAGE[models..lighting]), Ok(LightingRecord::DEFAULT));
    assert_eq!(TINY_IMAGE[lighting..block_head], [0, 0, 0, 0, 20, 0, 0, 0]);
    let words: Vec<u32> =
        TINY_IMAGE[block_head..end].chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    assert_eq!(words, TINY_PE_WORDS);

    // Streaming it gives exactly these sink calls.
    let (r, sink, s) = stream_in_chunks(&TINY_IMAGE, TINY_IMAGE.len());
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    assert_eq!(s.offset(), 348);
    assert_eq!(s.header(), Some(&h));
    let mut expected = vec![
        Event::Header(h),
        Event::VoxelMap(0, vec![0x00, 0xFF]),
        Event::Material(0, m),
        Event::MaterialModel(0, MaterialModel::MATTE),
        Event::Lighting(LightingRecord::DEFAULT),
        Event::PeBegin(0, 20),
    ];
    expected.extend(TINY_PE_WORDS.iter().map(|&w| Event::PeWord(w)));
    expected.push(Event::PeEnd);
    assert_eq!(sink.events, expected);
}

/// The sphere scene (an analytic primitive, an object, a textured material, two-bounce
/// lighting): section bytes, sink calls in SPEC.md §5.1 order, awkward chunking.
#[test]
fn scene_sphere_sections_and_sink_order() {
    let image = ImageSpec::sphere().build();
    assert_eq!(image.len(), 64 + 4 + 16 + 96 + 64 + 80 + 8 + 4 * 25);
    assert_eq!(image[60..64], [1, 0, 0, 0], "object_count 1");
    let model = MaterialModel { texture: TextureKind::Checker, tex_log2: 4, ..MaterialModel::DEFAULT };
    assert_eq!(model.to_bytes(), image[84..180]);
    let object = ObjectRecord {
        kind: ObjectKind::Sphere,
        material: 0,
        first_prim: 0,
        prim_count: 1,
        world_to_object: HALF_SCALE,
    };
    assert_eq!(object.to_bytes(), image[180..244]);
    let lighting = LightingRecord {
        max_depth: 2,
        falloff: Falloff::InverseSquare,
        background: [0.0; 3],
        ..LightingRecord::DEFAULT
    };
    assert_eq!(lighting.to_bytes(), image[244..324]);
    let (r, sink, s) = stream_in_chunks(&image, 7);
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    let calls = coalesce(&sink.events);
    assert_eq!(
        calls[1..6],
        [
            Event::VoxelMap(0, vec![0]),
            Event::Material(0, Material { diffuse: [0.8; 3], reflect: 0.0 }),
            Event::MaterialModel(0, model),
            Event::Object(0, object),
            Event::Lighting(lighting),
        ]
    );
    assert_eq!(calls[6], Event::PeBegin(0, 25));
    assert_eq!(calls.last(), Some(&Event::PeEnd));
}

/// The scene stream drives a LOAD_PE per block; its words are the FSL payload verbatim.
#[test]
fn scene_blocks_become_load_pe_packets() {
    let image = ImageSpec::two_pe().build();
    let (r, sink, s) = stream_in_chunks(&image, 1000);
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    let mut packets: Vec<Vec<FslWord>> = Vec::new();
    for e in &sink.events {
        match e {
            Event::PeBegin(pe, _) => packets.push(vec![FslWord::data(fsl::load_header(*pe))]),
            Event::PeWord(w) => packets.last_mut().unwrap().push(FslWord::data(*w)),
            Event::PeEnd => packets.last_mut().unwrap().last_mut().unwrap().control = true,
            _ => {}
        }
    }
    assert_eq!(packets.len(), 2);
    for (pe, p) in packets.iter().enumerate() {
        assert_eq!(p[0].data, 0x1000_0000 | pe as u32);
        assert_eq!(p.iter().filter(|w| w.control).count(), 1);
        let words: Vec<u32> = p[1..].iter().map(|w| w.data).collect();
        assert!(PeImage::parse(&words).is_ok());
    }
}

/// SceneBegin / SceneChunk / SceneAck of the session (§3.10) carrying the §5.9 image in
/// 50-byte chunks.
#[test]
fn session_uploads_tiny_image() {
    let begin = encode_payload(&Msg::SceneBegin { total_len: TINY_IMAGE.len() as u32, crc: TINY_IMAGE_CRC });
    assert_eq!(begin, [0x5C, 0x01, 0x00, 0x00, 0xA2, 0x82, 0x96, 0x2A]);
    let mut s = SceneStream::new();
    let mut sink = RecordingSink::default();
    let mut next = 0u32;
    for (i, chunk) in TINY_IMAGE.chunks(50).enumerate() {
        let w = wire(0x11, i as u16, &encode_payload(&Msg::SceneChunk { offset: next, data: chunk }));
        let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
        let out = feed_all(&mut acc, &w, 13);
        let [Outcome::Frame { kind, payload, .. }] = &out[..] else { panic!("{out:?}") };
        let Ok(Msg::SceneChunk { offset, data }) = Msg::decode(*kind, payload) else { panic!() };
        assert_eq!(offset, next);
        s.feed(data, &mut sink).unwrap();
        next = s.offset();
    }
    assert_eq!(next, 348);
    assert!(s.is_done());
}
