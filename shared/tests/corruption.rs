//! Corruption tests: every decoder in the crate rejects damaged input with the error
//! SPEC.md names, never panics, and the byte stream resynchronises.
//!
//! Tests named `regression_*` pin defects that were fixed in `shared/src`.

mod common;

use common::*;
use gridrt_shared::frame::{self, FeedResult, FrameAccumulator, FrameError};
use gridrt_shared::fsl::{self, RayResult};
use gridrt_shared::msg::{ErrorCode, Msg, MsgError, PixelEncoding};
use gridrt_shared::scene::{PeImage, SceneError, SceneHeader, SceneStream};

const HELLO_WIRE: [u8; 16] =
    [0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00];
const HELLO_RAW: [u8; 14] = [0x01, 0x01, 0x07, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00, 0x61, 0x3B, 0xDB, 0x32];

fn hello_frame() -> Outcome {
    Outcome::Frame { kind: 1, seq: 7, payload: vec![1, 0, 0, 0] }
}

fn acc() -> FrameAccumulator<{ frame::MAX_ENCODED }> {
    FrameAccumulator::new()
}

// ---------------------------------------------------------------- frames (§2)

#[test]
fn frame_bad_crc_every_bit_flip() {
    for bit in 0..HELLO_RAW.len() * 8 {
        let mut raw = HELLO_RAW;
        raw[bit / 8] ^= 1 << (bit % 8);
        let expected = if (4..6).contains(&(bit / 8)) { FrameError::DecodeBadLength } else { FrameError::DecodeBadCrc };
        assert_eq!(frame::parse_raw(&raw), Err(expected), "bit {bit}");
        let mut a = acc();
        assert_eq!(feed_all(&mut a, &cobs_wire(&raw), 64), [Outcome::Bad(expected)], "bit {bit}");
    }
}

#[test]
fn frame_bad_crc_on_the_wire_then_resync() {
    let mut stream = HELLO_WIRE.to_vec();
    stream[12] ^= 0x40; // a CRC byte
    stream.extend_from_slice(&HELLO_WIRE);
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &stream, 5), [Outcome::Bad(FrameError::DecodeBadCrc), hello_frame()]);
}

#[test]
fn frame_truncated() {
    for n in 0..10 {
        assert_eq!(frame::parse_raw(&HELLO_RAW[..n]), Err(FrameError::DecodeTruncated), "{n} bytes");
    }
    for n in 10..HELLO_RAW.len() {
        assert_eq!(frame::parse_raw(&HELLO_RAW[..n]), Err(FrameError::DecodeBadLength), "{n} bytes");
    }
    // Every cut of the wire frame followed by a delimiter is rejected, and the next frame decodes.
    for n in 0..HELLO_WIRE.len() - 1 {
        let mut stream = HELLO_WIRE[..n].to_vec();
        stream.push(0);
        stream.extend_from_slice(&HELLO_WIRE);
        let mut a = acc();
        let out = feed_all(&mut a, &stream, 3);
        let (last, bad) = out.split_last().unwrap();
        assert_eq!(*last, hello_frame(), "cut at {n}");
        assert_eq!(bad.len(), usize::from(n > 0), "cut at {n}: {out:?}");
        assert!(bad.iter().all(|o| matches!(o, Outcome::Bad(_))), "cut at {n}: {out:?}");
    }
}

#[test]
fn frame_length_field_larger_than_max_payload() {
    // len = 2049 with 2049 bytes and a correct CRC: fits the default accumulator, still rejected.
    let raw = raw_frame(0x11, 1, 0, 2049, &[0x33; 2049]);
    assert_eq!(frame::parse_raw(&raw), Err(FrameError::DecodeBadLength));
    let w = cobs_wire(&raw);
    assert!(w.len() - 1 <= frame::MAX_ENCODED);
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &w, 700), [Outcome::Bad(FrameError::DecodeBadLength)]);
    // len = 0xFFFF on a short frame.
    let raw = raw_frame(0x11, 1, 0, 0xFFFF, &[1, 2, 3]);
    assert_eq!(frame::parse_raw(&raw), Err(FrameError::DecodeBadLength));
}

#[test]
fn frame_larger_than_accumulator_overflows_then_resyncs() {
    let raw = raw_frame(0x11, 1, 0, 3000, &[0x33; 3000]);
    let mut stream = cobs_wire(&raw);
    stream.extend_from_slice(&HELLO_WIRE);
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &stream, 1000), [Outcome::Overflow, hello_frame()]);
    // Pure noise longer than the buffer.
    let mut stream = vec![0x55u8; 3 * frame::MAX_ENCODED];
    stream.push(0);
    stream.extend_from_slice(&HELLO_WIRE);
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &stream, 4096), [Outcome::Overflow, hello_frame()]);
}

#[test]
fn frame_trailing_bytes_after_crc() {
    let mut raw = HELLO_RAW.to_vec();
    raw.push(0x00);
    assert_eq!(frame::parse_raw(&raw), Err(FrameError::DecodeBadLength));
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &cobs_wire(&raw), 64), [Outcome::Bad(FrameError::DecodeBadLength)]);
}

#[test]
fn frame_wrong_version() {
    // Independently computed: Hello{protocol 2} in a version-2 frame, seq 7.
    let v2 = [0x04, 0x01, 0x02, 0x07, 0x02, 0x04, 0x02, 0x02, 0x01, 0x01, 0x05, 0x4A, 0xA8, 0xE3, 0x19, 0x00];
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &v2, 64), [Outcome::Bad(FrameError::DecodeBadVersion)]);
    for v in [0u8, 2, 0x81, 0xFF] {
        let raw = raw_frame(0x01, v, 7, 4, &[1, 0, 0, 0]);
        assert_eq!(frame::parse_raw(&raw), Err(FrameError::DecodeBadVersion), "version {v}");
    }
    // A corrupted version byte is a CRC error, not a version mismatch.
    let mut raw = HELLO_RAW;
    raw[1] = 2;
    assert_eq!(frame::parse_raw(&raw), Err(FrameError::DecodeBadCrc));
}

#[test]
fn frame_unknown_type_is_a_frame_but_not_a_message() {
    // Independently computed: type 0x55, seq 1, empty payload.
    let w = [0x04, 0x55, 0x01, 0x01, 0x01, 0x01, 0x05, 0x32, 0x76, 0x5D, 0x68, 0x00];
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &w, 64), [Outcome::Frame { kind: 0x55, seq: 1, payload: vec![] }]);
    let known = [0x01, 0x02, 0x10, 0x11, 0x12, 0x20, 0x21, 0x22, 0x23, 0x24, 0x25, 0x30, 0x31, 0x32, 0x33, 0x7F];
    for kind in (0..=255u8).filter(|k| !known.contains(k)) {
        assert_eq!(Msg::decode(kind, &[]), Err(MsgError::DecodeUnknownType), "type {kind:#04x}");
        assert_eq!(Msg::decode(kind, &[1, 0, 0, 0]), Err(MsgError::DecodeUnknownType), "type {kind:#04x}");
    }
}

#[test]
fn frame_bad_cobs_and_empty_frames() {
    let mut stream = vec![0x00, 0x00, 0x11, 0x22, 0x00, 0x00];
    stream.extend_from_slice(&HELLO_WIRE);
    stream.extend_from_slice(&[0x00, 0x00]);
    let mut a = acc();
    assert_eq!(feed_all(&mut a, &stream, 2), [Outcome::Bad(FrameError::DecodeBadCobs), hello_frame()]);
    assert!(!a.has_partial());
}

#[test]
fn frame_split_anywhere_gives_the_same_frames() {
    let mut stream = vec![0x13, 0x37, 0x00];
    stream.extend_from_slice(&HELLO_WIRE);
    stream.extend_from_slice(&wire(0x21, 9, &[0, 0, 0, 0xAA]));
    let whole = feed_all(&mut acc(), &stream, stream.len());
    assert_eq!(whole.len(), 3);
    for chunk in 1..stream.len() {
        assert_eq!(feed_all(&mut acc(), &stream, chunk), whole, "chunk {chunk}");
    }
}

#[test]
fn accumulator_partial_and_reset() {
    let mut a = acc();
    assert_eq!(a.feed(&HELLO_WIRE[..7]), FeedResult::Consumed);
    assert!(a.has_partial());
    a.reset();
    assert!(!a.has_partial());
    // After a reset the rest of the old frame is noise; the next frame decodes.
    let mut stream = HELLO_WIRE[7..].to_vec();
    stream.extend_from_slice(&HELLO_WIRE);
    assert_eq!(feed_all(&mut a, &stream, 64)[1..], [hello_frame()]);
    // A small accumulator reports Overflow and has_partial while discarding.
    let mut small = FrameAccumulator::<8>::new();
    assert_eq!(small.feed(&[0x55; 20]), FeedResult::Consumed);
    assert!(small.has_partial());
    assert!(matches!(small.feed(&[0x00, 0x01]), FeedResult::Overflow { rest: &[0x01] }));
}

#[test]
fn frame_encoder_limits() {
    let mut out = vec![0u8; frame::MAX_ENCODED];
    assert_eq!(
        frame::encode_frame(1, 0, &[0; frame::MAX_PAYLOAD + 1], &mut out),
        Err(FrameError::EncodePayloadTooLarge)
    );
    assert!(frame::encode_frame(1, 0, &[0; frame::MAX_PAYLOAD], &mut out).is_ok());
    // The encoder wants room for the worst case of the raw length plus the delimiter.
    let need = cobs::max_encoding_length(14) + 1;
    for n in 0..need {
        let mut small = vec![0u8; n];
        assert_eq!(frame::encode_frame(1, 7, &[1, 0, 0, 0], &mut small), Err(FrameError::EncodeBufferTooSmall), "{n}");
    }
    let mut exact = vec![0u8; need];
    assert_eq!(frame::encode_frame(1, 7, &[1, 0, 0, 0], &mut exact), Ok(16));
    assert_eq!(exact[..16], HELLO_WIRE);
}

// ---------------------------------------------------------------- messages (§3)

/// (type, valid payload) of every worked example in SPEC.md §3.
fn golden_payloads() -> Vec<(u8, Vec<u8>)> {
    let mut rr = vec![0x01, 0x00, 0x40, 0x01, 0xF0, 0x00, 0x03, 0x00];
    rr.extend_from_slice(&[0; 8]);
    rr.extend_from_slice(&[0x00, 0x00, 0xA0, 0x40]);
    rr.extend_from_slice(&[0; 16]);
    rr.extend_from_slice(&[0x00, 0x00, 0x80, 0x3F, 0, 0, 0, 0, 0x00, 0x00, 0x34, 0x42]);
    rr.extend_from_slice(&[0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x80, 0x40, 0x00, 0x00, 0x40, 0x40]);
    rr.extend_from_slice(&[0x00, 0x00, 0x80, 0x3F, 0x9A, 0x99, 0x19, 0x3E, 0, 0, 0, 0]);
    assert_eq!(rr.len(), 72);
    vec![
        (0x01, vec![0x01, 0x00, 0x00, 0x00]),
        (0x02, vec![1, 0, 0, 1, 0, 0, 0, 8, 4, 0, 0, 0, 4, 0, 0, 0x40, 0, 0, 3, 0, 0, 0]),
        (0x10, vec![0xA4, 0, 0, 0, 0xEF, 0x40, 0x34, 0x01]),
        (0x11, vec![0, 0, 0, 0, 0x47, 0x52, 0x54, 0x53, 0x01, 0x00, 0x40, 0x00]),
        (0x12, vec![0x08, 0, 0, 0, 0, 0, 0, 0]),
        (0x20, rr),
        (0x21, vec![1, 0, 2, 0, 3, 0, 2, 0, 0x00, 0, 0xFF, 0x00, 0x80, 0x10, 0x20, 0x30]),
        (0x21, vec![1, 0, 2, 0, 3, 0, 2, 0, 0x80, 0, 0x2A, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]),
        (0x22, vec![1, 0, 0, 0, 0xE0, 0x01, 0, 0, 0x78, 0x56, 0x34, 0x12]),
        (0x23, vec![1, 0, 2, 0, 1, 0x00, 0x2C, 0x01, 0, 0, 0, 0, 0, 0x08, 0x15, 0xCD, 0x5B, 0x07, 0, 0, 0, 0]),
        (0x7F, vec![5, 0, 8, 0, 0, 0, 0, 0, b'n', b'o', b' ', b's', b'c', b'e', b'n', b'e']),
    ]
}

#[test]
fn msg_golden_payloads_decode() {
    for (kind, p) in golden_payloads() {
        let m = Msg::decode(kind, &p).unwrap_or_else(|e| panic!("type {kind:#04x}: {e:?}"));
        assert_eq!(encode_payload(&m), p);
    }
}

#[test]
fn msg_truncated_at_every_length() {
    for (kind, p) in golden_payloads() {
        for n in 0..p.len() {
            let r = Msg::decode(kind, &p[..n]);
            match kind {
                // The data of a chunk is "the rest": every cut after the offset is a shorter chunk.
                0x11 if n >= 4 => assert!(r.is_ok(), "type {kind:#04x} cut {n}"),
                // A span cut inside its pixels has the wrong pixel byte count.
                0x21 if n >= 10 => assert_eq!(r, Err(MsgError::DecodeBadField), "type {kind:#04x} cut {n}"),
                // An error cut inside its text is short of text_len bytes.
                _ => assert_eq!(r, Err(MsgError::DecodeTruncated), "type {kind:#04x} cut {n}"),
            }
        }
    }
}

#[test]
fn msg_trailing_bytes() {
    for (kind, p) in golden_payloads() {
        let mut long = p.clone();
        long.push(0);
        let r = Msg::decode(kind, &long);
        match kind {
            0x11 => assert!(matches!(r, Ok(Msg::SceneChunk { data, .. }) if data.len() == 9)),
            0x21 => assert_eq!(r, Err(MsgError::DecodeBadField), "type {kind:#04x}"),
            _ => assert_eq!(r, Err(MsgError::DecodeTrailingBytes), "type {kind:#04x}"),
        }
    }
    // Stats: a partial entry after `count` entries.
    let p = [1, 0, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0xAA];
    assert_eq!(Msg::decode(0x23, &p), Err(MsgError::DecodeTrailingBytes));
}

#[test]
fn msg_bad_enum_fields() {
    // SceneAck status 2..=255.
    for s in 2..=255u8 {
        assert_eq!(Msg::decode(0x12, &[8, 0, 0, 0, s, 0, 0, 0]), Err(MsgError::DecodeBadField), "status {s}");
    }
    let rr = golden_payloads()[5].1.clone();
    let span = golden_payloads()[6].1.clone();
    for e in 0..=255u8 {
        let ok = matches!(e, 0 | 1 | 2 | 0x80);
        let mut r = rr.clone();
        r[68] = e;
        assert_eq!(Msg::decode(0x20, &r).is_ok(), ok, "request encoding {e:#04x}");
        if !ok {
            assert_eq!(Msg::decode(0x20, &r), Err(MsgError::DecodeBadField));
        }
        let mut s = span.clone();
        s[8] = e;
        // Rgb888 data of 6 bytes is also 0 PrimId32 pixels short, so only 0 decodes.
        let expect = if e == 0 { Ok(()) } else { Err(MsgError::DecodeBadField) };
        assert_eq!(Msg::decode(0x21, &s).map(|_| ()), expect, "span encoding {e:#04x}");
    }
    // Pixel count disagreeing with the data.
    let mut s = span.clone();
    s[6] = 3;
    assert_eq!(Msg::decode(0x21, &s), Err(MsgError::DecodeBadField));
    // Error text longer than 128, or not UTF-8.
    let mut e = vec![1, 0, 129, 0, 0, 0, 0, 0];
    e.extend_from_slice(&[b'x'; 129]);
    assert_eq!(Msg::decode(0x7F, &e), Err(MsgError::DecodeBadField));
    assert_eq!(Msg::decode(0x7F, &[1, 0, 2, 0, 0, 0, 0, 0, 0xC3, 0x28]), Err(MsgError::DecodeBadText));
    // Unknown error codes are kept, not rejected.
    assert_eq!(
        Msg::decode(0x7F, &[0x34, 0x12, 0, 0, 9, 0, 0, 0]),
        Ok(Msg::Error { code: ErrorCode::Unknown(0x1234), detail: 9, text: "" })
    );
}

#[test]
fn msg_reserved_bytes_are_ignored() {
    assert_eq!(Msg::decode(0x01, &[1, 0, 0xAA, 0xBB]), Ok(Msg::Hello { protocol: 1 }));
    assert!(Msg::decode(0x12, &[8, 0, 0, 0, 1, 0xAA, 0xBB, 0xCC]).is_ok());
    let mut rr = golden_payloads()[5].1.clone();
    rr[69..].copy_from_slice(&[0xAA, 0xBB, 0xCC]);
    assert_eq!(Msg::decode(0x20, &rr), Msg::decode(0x20, &golden_payloads()[5].1));
    let mut span = golden_payloads()[6].1.clone();
    span[9] = 0xAA;
    assert!(Msg::decode(0x21, &span).is_ok());
    assert!(Msg::decode(0x22, &[1, 0, 0xAA, 0xBB, 0, 0, 0, 0, 0, 0, 0, 0]).is_ok());
}

#[test]
fn msg_encode_buffer_too_small() {
    for (kind, p) in golden_payloads() {
        let m = Msg::decode(kind, &p).unwrap();
        for n in 0..p.len() {
            let mut buf = vec![0u8; n];
            assert_eq!(m.encode(&mut buf), Err(MsgError::EncodeBufferTooSmall), "type {kind:#04x} buffer {n}");
        }
    }
}

/// `Msg::encode` truncates error text to 128 bytes without respecting UTF-8 boundaries, so the
/// encoder emits a payload its own decoder rejects with `DecodeBadText`.
#[test]
fn regression_error_text_truncation_splits_utf8() {
    let text = format!("{}é", "a".repeat(127)); // 'é' occupies bytes 127..129
    let p = encode_payload(&Msg::Error { code: ErrorCode::BadFrame, detail: 0, text: &text });
    assert_eq!(Msg::decode(0x7F, &p), Ok(Msg::Error { code: ErrorCode::BadFrame, detail: 0, text: &text[..127] }));
}

/// `Msg::encode` writes `entries.len() / 9` as the count but all the bytes, so a slice that is
/// not a whole number of entries encodes into a payload the decoder rejects.
#[test]
fn regression_stats_encode_accepts_partial_entry() {
    let m = Msg::Stats { frame: 1, entries: &[1, 2, 3] };
    let mut buf = [0u8; 64];
    assert!(m.encode(&mut buf).is_err(), "encoder must refuse what the decoder rejects");
}

/// `Msg::encode` does not check `data.len() == count × bytes_per_pixel`.
#[test]
fn regression_pixel_span_encode_accepts_wrong_data_length() {
    let m = Msg::PixelSpan { frame: 1, y: 0, x0: 0, count: 2, encoding: PixelEncoding::Rgb888, data: &[1, 2, 3] };
    let mut buf = [0u8; 64];
    assert!(m.encode(&mut buf).is_err(), "encoder must refuse what the decoder rejects");
}

// ---------------------------------------------------------------- FSL (§4)

/// RESULT carries `list_pos` in 12 bits, so requests are limited to 4095 entries.
#[test]
fn regression_result_list_pos_covers_every_allowed_list_position() {
    const { assert!(fsl::MAX_LIST_ENTRIES <= 0x0FFF) };
    let last = (fsl::MAX_LIST_ENTRIES - 1) as u16;
    let r = RayResult { hit: true, list_pos: last, t: 1.0, ..RayResult::MISS };
    assert_eq!(RayResult::from_words(&r.to_words()).map(|r| r.list_pos), Ok(last));
}

#[test]
fn fsl_result_rejects_other_opcodes() {
    for opc in (0..16u32).filter(|&o| o != 0x8) {
        let mut w = RayResult::MISS.to_words();
        w[0] = (w[0] & 0x0FFF_FFFF) | (opc << 28);
        assert!(RayResult::from_words(&w).is_err(), "opcode {opc:#x}");
    }
}

// ---------------------------------------------------------------- scene image (§5)

fn stream(image: &[u8]) -> (Result<(), SceneError>, RecordingSink, SceneStream) {
    stream_in_chunks(image, image.len())
}

fn err_of(spec: &ImageSpec) -> Result<(), SceneError> {
    let image = spec.build();
    let (r, _, s) = stream(&image);
    if r.is_ok() {
        assert!(s.is_done(), "a complete image must finish");
    }
    r
}

/// The SPEC.md §5.7 worked example of the scene layout before the version-2 merge (version
/// 1, no material models, objects or lighting, untagged PE image), as it was pinned then.
#[rustfmt::skip]
const PRE_MERGE_V1_IMAGE: [u8; 164] = [
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

/// The untagged PE memory image of [`PRE_MERGE_V1_IMAGE`] (T, V, R first).
const PRE_MERGE_V1_PE_WORDS: [u32; 18] = [
    1,
    1,
    1,
    0,
    0,
    1,
    0,
    0x3E80_0000,
    0x3E80_0000,
    0x3F00_0000,
    0x3F40_0000,
    0x3E80_0000,
    0x3F00_0000,
    0x3E80_0000,
    0x3F40_0000,
    0x3F00_0000,
    0,
    0,
];

#[test]
fn scene_bad_magic() {
    for i in 0..4 {
        let mut img = TINY_IMAGE;
        img[i] ^= 0x20;
        assert_eq!(stream(&img).0, Err(SceneError::BadMagic), "byte {i}");
        assert_eq!(SceneHeader::parse(&img[..64]), Err(SceneError::BadMagic));
    }
}

#[test]
fn scene_bad_version() {
    for v in [0u16, 1, 3, 0x0100, 0x0200, 0xFFFF] {
        let spec = ImageSpec { version: v, ..ImageSpec::tiny() };
        assert_eq!(err_of(&spec), Err(SceneError::BadVersion), "version {v}");
    }
}

/// Readers accept exactly version 2 (§5.8): an image of the pre-merge version-1 layout is
/// rejected at its header, before anything reaches a sink.
#[test]
fn scene_version_1_image_rejected() {
    assert_eq!(frame::crc32(&PRE_MERGE_V1_IMAGE[64..]), 0xE50A_901B, "the image as pinned before the merge");
    assert_eq!(SceneHeader::parse(&PRE_MERGE_V1_IMAGE[..64]), Err(SceneError::BadVersion));
    for chunk in [1, 7, 164] {
        let (r, sink, s) = stream_in_chunks(&PRE_MERGE_V1_IMAGE, chunk);
        assert_eq!(r, Err(SceneError::BadVersion), "chunk {chunk}");
        assert!(sink.events.is_empty() && !s.is_done());
    }
    // Its PE image, loaded on its own, is untagged and rejected too.
    assert_eq!(PeImage::parse(&PRE_MERGE_V1_PE_WORDS).err(), Some(SceneError::BadPeBlock));
}

#[test]
fn scene_bad_header_fields() {
    let t = ImageSpec::tiny;
    let cases = [
        ImageSpec { header_len: 63, ..t() },
        ImageSpec { header_len: 65, ..t() },
        ImageSpec { dims: [0, 1, 1], ..t() },
        ImageSpec { dims: [2, 0, 1], ..t() },
        ImageSpec { dims: [2, 1, 0], ..t() },
        ImageSpec { pe_count: 0, ..t() },
        ImageSpec { pe_count: 256, ..t() },
        ImageSpec { bounds_max: [0.0, 1.0, 1.0], ..t() },
        ImageSpec { bounds_min: [0.0, 2.0, 0.0], ..t() },
        ImageSpec { total_len_override: Some(63), ..t() },
        ImageSpec { dims: [4096, 4096, 2], ..t() },
        ImageSpec { dims: [65535, 65535, 65535], ..t() },
    ];
    for (i, spec) in cases.iter().enumerate() {
        assert_eq!(err_of(spec), Err(SceneError::BadHeader), "case {i}");
    }
    // Flags other than POINTS (bit 0, §5.10) and the reserved bytes 62..64 are ignored (and
    // outside the body CRC); POINTS announces a section this image lacks.
    assert_eq!(err_of(&ImageSpec { flags: 0xFFFE, reserved: 0xBEEF, ..t() }), Ok(()));
    let (r, _, s) = stream(&ImageSpec { flags: 0x0001, ..t() }.build());
    assert_eq!((r, s.is_done(), s.finish()), (Ok(()), false, Err(SceneError::Truncated)));
}

#[test]
fn scene_non_finite_values() {
    let t = ImageSpec::tiny;
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(err_of(&ImageSpec { bounds_min: [v, 0.0, 0.0], ..t() }), Err(SceneError::NonFinite));
        assert_eq!(err_of(&ImageSpec { bounds_max: [2.0, 1.0, v], ..t() }), Err(SceneError::NonFinite));
        assert_eq!(err_of(&ImageSpec { materials: vec![[0.8, v, 0.8, 0.0]], ..t() }), Err(SceneError::NonFinite));
        assert_eq!(err_of(&ImageSpec { materials: vec![[0.8, 0.8, 0.8, v]], ..t() }), Err(SceneError::NonFinite));
        // Every float of the material model (offsets 8..80), object (16..64), lighting (4..60).
        for k in 0..18 {
            let mut floats = DEFAULT_MODEL_FLOATS;
            floats[k] = v;
            let spec = ImageSpec { models: vec![model_bytes([2, 0, 0, 0, 0, 1, 8, 0], floats, 0)], ..t() };
            assert_eq!(err_of(&spec), Err(SceneError::NonFinite), "model float {k}");
        }
        for k in 0..12 {
            let mut affine = HALF_SCALE;
            affine[k] = v;
            let mut spec = ImageSpec::sphere();
            spec.objects[0] = object_bytes(1, 0, 0, 1, affine);
            assert_eq!(err_of(&spec), Err(SceneError::NonFinite), "object float {k}");
        }
        for k in 0..14 {
            let mut spec = t();
            spec.lighting[4 + 4 * k..8 + 4 * k].copy_from_slice(&v.to_le_bytes());
            assert_eq!(err_of(&spec), Err(SceneError::NonFinite), "lighting float {k}");
        }
    }
}

/// Enum and range rules of the material model, object and lighting records (§5.7).
#[test]
fn scene_bad_records() {
    let t = ImageSpec::tiny;
    let with_model = |byte: usize, v: u8| {
        let mut m = matte_model();
        m[byte] = v;
        ImageSpec { models: vec![m], ..t() }
    };
    for (byte, v) in [(0, 3), (1, 3), (2, 4), (3, 6), (4, 3), (5, 2), (6, 0), (6, 13), (0, 0xFF)] {
        assert_eq!(err_of(&with_model(byte, v)), Err(SceneError::BadRecord), "model byte {byte} = {v}");
    }
    // η > 0, exponent ≥ 0, σ² ≥ 0, κ ≥ 0 (floats 8, 4, 3, 9).
    for (k, v) in [(8, 0.0), (8, -1.5), (4, -1.0), (3, -0.1), (9, -0.5)] {
        let mut floats = DEFAULT_MODEL_FLOATS;
        floats[k] = v;
        let spec = ImageSpec { models: vec![model_bytes([2, 0, 0, 0, 0, 1, 8, 0], floats, 0)], ..t() };
        assert_eq!(err_of(&spec), Err(SceneError::BadRecord), "model float {k} = {v}");
    }
    for kind in [7u8, 0x80, 0xFF] {
        let mut spec = ImageSpec::sphere();
        spec.objects[0][0] = kind;
        assert_eq!(err_of(&spec), Err(SceneError::BadRecord), "object kind {kind}");
    }
    for (byte, v) in [(0usize, 2u8), (1, 0), (1, 9), (2, 2)] {
        let mut spec = t();
        spec.lighting[byte] = v;
        assert_eq!(err_of(&spec), Err(SceneError::BadRecord), "lighting byte {byte} = {v}");
    }
    // cos_inner < cos_outer.
    let mut spec = t();
    spec.lighting[28..32].copy_from_slice(&0.9f32.to_le_bytes());
    spec.lighting[32..36].copy_from_slice(&0.8f32.to_le_bytes());
    assert_eq!(err_of(&spec), Err(SceneError::BadRecord));
    // A mesh scene with depth 8, no light and a spotlight cone is in range.
    let mut spec = t();
    spec.lighting[..3].copy_from_slice(&[0, 8, 1]);
    spec.lighting[28..36].copy_from_slice(&[0.8f32.to_le_bytes(), 0.9f32.to_le_bytes()].concat());
    assert_eq!(err_of(&spec), Ok(()));
}

#[test]
fn scene_bad_body_crc() {
    // Bytes the stream does not interpret: voxel-map padding, reserved bytes of the material
    // model (7, 84..96), lighting (3, 60..80) and PE block head (2..4), the PE image words
    // (checked by the loader, not the stream); and the CRC field itself.
    let model_reserved = [91usize].into_iter().chain(168..180);
    let lighting_reserved = [183usize].into_iter().chain(240..260);
    let touched: Vec<usize> =
        (66..68).chain(model_reserved).chain(lighting_reserved).chain(262..264).chain(268..348).chain(56..60).collect();
    for i in touched {
        let mut img = TINY_IMAGE;
        img[i] ^= 0x01;
        let (r, _, s) = stream(&img);
        assert_eq!(r, Err(SceneError::BadCrc), "byte {i}");
        assert!(!s.is_done());
    }
    // Object reserved bytes (1, 12..16) of the sphere scene.
    let image = ImageSpec::sphere().build();
    for i in [181usize, 192, 193, 194, 195] {
        let mut img = image.clone();
        img[i] ^= 0x01;
        assert_eq!(stream(&img).0, Err(SceneError::BadCrc), "sphere byte {i}");
    }
}

/// True when the (coalesced) calls of a truncated stream are a prefix of the full stream's,
/// the last voxel-map piece possibly shorter.
fn is_prefix(partial: &[Event], full: &[Event]) -> bool {
    let (p, f) = (coalesce(partial), coalesce(full));
    let Some((last, init)) = p.split_last() else { return true };
    p.len() <= f.len()
        && init == &f[..init.len()]
        && match (last, &f[init.len()]) {
            (Event::VoxelMap(a, x), Event::VoxelMap(b, y)) => a == b && y.starts_with(x),
            (l, r) => l == r,
        }
}

/// Cuts `image` at and next to each (offset, coalesced sink calls seen there), and at every
/// other offset: never done, never an error, the calls a prefix of the whole image's.
fn check_truncations(image: &[u8], cuts: &[(usize, usize)]) {
    let (_, full, _) = stream(image);
    for &(cut, calls) in cuts {
        for near in [cut.saturating_sub(1), cut, cut + 1, cut + 2] {
            for chunk in [1usize, 7, 200] {
                let (r, sink, s) = stream_in_chunks(&image[..near], chunk);
                assert_eq!(r, Ok(()), "cut {near}");
                assert!(!s.is_done(), "cut {near}");
                assert_eq!(s.offset() as usize, near);
                assert_eq!(s.finish(), Err(SceneError::Truncated), "cut {near}");
                assert!(is_prefix(&sink.events, &full.events), "cut {near} chunk {chunk}: {:?}", sink.events);
                if near == cut {
                    assert_eq!(coalesce(&sink.events).len(), calls, "cut {near}");
                }
            }
        }
    }
    for near in 0..image.len() {
        let (r, sink, s) = stream_in_chunks(&image[..near], 5);
        assert_eq!(r, Ok(()), "cut {near}");
        assert!(!s.is_done() && is_prefix(&sink.events, &full.events), "cut {near}");
    }
    let (r, _, s) = stream(image);
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    assert_eq!(s.finish(), Ok(()));
}

#[test]
fn scene_truncated_at_every_section_boundary() {
    // Coalesced sink calls seen at each section end: header, map, colour, model, lighting,
    // pe_begin (the tiny image has no objects: its object section ends where it starts).
    let [header, map, colours, models, lighting, block_head, _] = TINY_BOUNDARIES;
    check_truncations(
        &TINY_IMAGE,
        &[(0, 0), (1, 0), (63, 0), (header, 1), (map, 2), (colours, 3), (models, 4), (lighting, 5), (block_head, 6)],
    );
    // The sphere image has an object record: ends 64, 68, 84, 180, 244 (object), 324, 332.
    let sphere = ImageSpec::sphere().build();
    check_truncations(&sphere, &[(64, 1), (68, 2), (84, 3), (180, 4), (244, 5), (324, 6), (332, 7)]);
}

#[test]
fn scene_total_len_disagrees_with_sections() {
    for total in [344u32, 347, 349, 352, 1000] {
        let spec = ImageSpec { total_len_override: Some(total), ..ImageSpec::tiny() };
        assert_eq!(err_of(&spec), Err(SceneError::BadHeader), "total_len {total}");
    }
}

/// Header counts that disagree with the records that follow shift every later section: the
/// stream fails (or waits for bytes that never come), never succeeds.
#[test]
fn scene_counts_disagree_with_records() {
    let t = ImageSpec::tiny;
    let cases = [
        ImageSpec { object_count_override: Some(1), ..t() },
        ImageSpec { material_count_override: Some(2), ..t() },
        ImageSpec { material_count_override: Some(0), ..t() },
        ImageSpec { models: vec![], ..t() },
        ImageSpec { object_count_override: Some(0), ..ImageSpec::sphere() },
    ];
    for (i, spec) in cases.iter().enumerate() {
        let (r, _, s) = stream(&spec.build());
        assert!(r.is_err() || !s.is_done(), "case {i}: {r:?}");
    }
}

#[test]
fn scene_trailing_bytes() {
    let mut img = TINY_IMAGE.to_vec();
    img.push(0);
    let (r, _, mut s) = stream(&img);
    assert_eq!(r, Err(SceneError::TrailingBytes));
    // Once failed, the stream stays failed.
    assert_eq!(s.feed(&[1], &mut RecordingSink::default()), Err(SceneError::Rejected));
    assert_eq!(s.finish(), Err(SceneError::Rejected));
    // Trailing bytes in a later chunk.
    let mut sink = RecordingSink::default();
    let mut s = SceneStream::new();
    assert_eq!(s.feed(&TINY_IMAGE, &mut sink), Ok(()));
    assert!(s.is_done());
    assert_eq!(s.feed(&[0], &mut sink), Err(SceneError::TrailingBytes));
    assert!(!s.is_done());
}

#[test]
fn scene_voxel_map_names_missing_pe() {
    for owner in [1u8, 2, 0x7F, 0xFE] {
        let spec = ImageSpec { voxel_map: vec![owner, 0xFF], ..ImageSpec::tiny() };
        assert_eq!(err_of(&spec), Err(SceneError::BadVoxelMap), "owner {owner}");
    }
    let spec = ImageSpec { voxel_map: vec![0, 0, 2, 0xFF, 0, 1, 0xFF, 0xFF, 1], ..ImageSpec::two_pe() };
    assert_eq!(err_of(&spec), Err(SceneError::BadVoxelMap));
    // Padding bytes are not owners.
    let spec = ImageSpec { pad: 0x42, ..ImageSpec::tiny() };
    assert_eq!(err_of(&spec), Ok(()));
}

#[test]
fn scene_pe_blocks_out_of_order() {
    let mut spec = ImageSpec::two_pe();
    spec.pe_blocks.swap(0, 1);
    assert_eq!(err_of(&spec), Err(SceneError::BadPeBlock));
    let mut spec = ImageSpec::two_pe();
    spec.pe_blocks[1].0 = 0; // PE 0 twice
    assert_eq!(err_of(&spec), Err(SceneError::BadPeBlock));
    let mut spec = ImageSpec::tiny();
    spec.pe_blocks[0].0 = 1; // PE id not below pe_count
    assert_eq!(err_of(&spec), Err(SceneError::BadPeBlock));
    // Fewer blocks than pe_count: the stream waits for the missing block.
    let mut spec = ImageSpec::two_pe();
    spec.pe_blocks.pop();
    let (r, _, s) = stream(&spec.build());
    assert_eq!(r, Ok(()));
    assert!(!s.is_done());
    // Reserved field is ignored.
    let mut spec = ImageSpec::tiny();
    spec.pe_blocks[0].1 = 0xBEEF;
    assert_eq!(err_of(&spec), Ok(()));
}

#[test]
fn scene_pe_block_larger_than_pe_memory() {
    assert_eq!(err_of(&ImageSpec { pe_mem_words: 19, ..ImageSpec::tiny() }), Err(SceneError::PeMemoryOverflow));
    assert_eq!(err_of(&ImageSpec { pe_mem_words: 20, ..ImageSpec::tiny() }), Ok(()));
    let spec = ImageSpec { words_override: Some((0, u32::MAX)), ..ImageSpec::tiny() };
    assert_eq!(err_of(&spec), Err(SceneError::PeMemoryOverflow));
}

#[test]
fn scene_sink_refusal_aborts_the_stream() {
    // Calls: 0 header, 1 voxel map, 2 colour, 3 model, 4 lighting, 5 pe_begin, 6..26 words,
    // 26 pe_end.
    for at in [0usize, 1, 2, 3, 4, 5, 6, 10, 26] {
        let mut sink = RecordingSink { fail_at: Some((at, SceneError::GridTooLarge)), ..Default::default() };
        let mut s = SceneStream::new();
        assert_eq!(s.feed(&TINY_IMAGE, &mut sink), Err(SceneError::GridTooLarge), "fail at call {at}");
        assert_eq!(sink.events.len(), at);
        assert_eq!(s.feed(&[], &mut sink), Err(SceneError::Rejected));
        assert!(!s.is_done());
    }
    // The object call of the sphere scene (call 4).
    let mut sink = RecordingSink { fail_at: Some((4, SceneError::Rejected)), ..Default::default() };
    assert_eq!(SceneStream::new().feed(&ImageSpec::sphere().build(), &mut sink), Err(SceneError::Rejected));
    assert!(matches!(sink.events.last(), Some(Event::MaterialModel(0, _))));
}

#[test]
fn scene_empty_pe_and_no_materials() {
    let mut spec = ImageSpec::tiny();
    spec.materials.clear();
    spec.models.clear();
    spec.pe_blocks[0].2.clear();
    spec.voxel_map = vec![0xFF, 0xFF];
    let image = spec.build();
    assert_eq!(image.len(), 64 + 4 + 80 + 8);
    let (r, sink, s) = stream(&image);
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    assert_eq!(
        sink.events[1..],
        [
            Event::VoxelMap(0, vec![0xFF, 0xFF]),
            Event::Lighting(gridrt_shared::scene::LightingRecord::DEFAULT),
            Event::PeBegin(0, 0),
            Event::PeEnd
        ]
    );
}

/// The PE image is always tagged (§5.4): an untagged (pre-merge) image, another tag or a
/// header cut short is `BadPeBlock`, in the loader and inside a scene image.
#[test]
fn pe_image_untagged_rejected() {
    assert_eq!(PeImage::parse(&PRE_MERGE_V1_PE_WORDS).err(), Some(SceneError::BadPeBlock));
    for w in [&[0u32, 0, 0][..], &[0, 0, 0, 0, 0], &[0xFFFF_0001, 0, 0, 0, 0], &[0xFFFF_0003, 0, 0, 0, 0]] {
        assert_eq!(PeImage::parse(w).err(), Some(SceneError::BadPeBlock), "{w:x?}");
    }
    for n in 1..5 {
        assert_eq!(PeImage::parse(&TINY_PE_WORDS[..n]).err(), Some(SceneError::BadPeBlock), "{n} words");
    }
    // A tagged image with no voxels is well-formed (but an empty PE is normally 0 words).
    assert!(PeImage::parse(&[0xFFFF_0002, 0, 0, 0, 0]).is_ok());
    // The stream passes PE words through; the sink that loads them parses and rejects them.
    let spec = ImageSpec { pe_blocks: vec![(0, 0, PRE_MERGE_V1_PE_WORDS.to_vec())], ..ImageSpec::tiny() };
    let (r, sink, s) = stream(&spec.build());
    assert_eq!(r, Ok(()));
    assert!(s.is_done());
    let words: Vec<u32> =
        sink.events.iter().filter_map(|e| if let Event::PeWord(w) = e { Some(*w) } else { None }).collect();
    assert_eq!(PeImage::parse(&words).err(), Some(SceneError::BadPeBlock));
}

#[test]
fn pe_image_malformed() {
    let good = TINY_PE_WORDS;
    assert!(PeImage::parse(&good).is_ok());
    let with = |i: usize, v: u32| {
        let mut w = good.to_vec();
        w[i] = v;
        w
    };
    // Counts (T 1, V 2, R 3, P 4) that disagree with the length.
    for (i, v) in
        [(1, 2), (1, 0), (2, 2), (2, 0), (3, 2), (3, 0), (4, 1)].into_iter().chain((1..5).map(|i| (i, u32::MAX)))
    {
        assert_eq!(PeImage::parse(&with(i, v)).err(), Some(SceneError::BadPeBlock), "word {i} = {v}");
    }
    let mut longer = good.to_vec();
    longer.push(0);
    assert_eq!(PeImage::parse(&longer).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&good[..19]).err(), Some(SceneError::BadPeBlock));
    // Ref out of range (≥ T + P), voxel ref range outside the ref table.
    assert_eq!(PeImage::parse(&with(8, 1)).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&with(6, 1)).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&with(7, 2)).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&with(6, u32::MAX)).err(), Some(SceneError::BadPeBlock));
    assert!(PeImage::parse(&with(7, 0)).is_ok(), "a voxel with no refs is well-formed");
    // Non-finite coordinates, in every vertex slot.
    for slot in 9..18 {
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(PeImage::parse(&with(slot, v.to_bits())).err(), Some(SceneError::NonFinite), "slot {slot}");
        }
    }
    // Primitives: a ref past T + P, a count mismatch, unknown kinds, non-finite transforms.
    let sphere = ImageSpec::sphere().pe_blocks[0].2.clone();
    assert!(PeImage::parse(&sphere).is_ok());
    let with = |i: usize, v: u32| {
        let mut w = sphere.clone();
        w[i] = v;
        w
    };
    assert_eq!(PeImage::parse(&with(8, 1)).err(), Some(SceneError::BadPeBlock));
    assert_eq!(PeImage::parse(&sphere[..sphere.len() - 1]).err(), Some(SceneError::BadPeBlock));
    for kind in [0u32, 6, 9, u32::MAX] {
        assert_eq!(PeImage::parse(&with(9, kind)).err(), Some(SceneError::BadPeBlock), "kind {kind}");
    }
    for slot in 12..24 {
        assert_eq!(PeImage::parse(&with(slot, f32::NAN.to_bits())).err(), Some(SceneError::NonFinite), "slot {slot}");
    }
}

/// SPEC.md §5.1 requires nx·ny·nz ≤ 2^24 (voxel ids are 24-bit on FSL); the header parser
/// accepted any dims.
#[test]
fn regression_grid_larger_than_24_bit_voxel_ids_accepted() {
    let mut h = SceneHeader::parse(&TINY_IMAGE[..64]).unwrap();
    h.dims = [4096, 4096, 2];
    assert_eq!(SceneHeader::parse(&h.to_bytes()), Err(SceneError::BadHeader));
    h.dims = [4096, 4096, 1];
    assert!(SceneHeader::parse(&h.to_bytes()).is_ok(), "exactly 2^24 voxels is allowed");
}

/// `SceneHeader::voxel_count` multiplied three u16 in u32: 65535³ overflowed, which panicked
/// in debug builds (and wrapped in release) as soon as the stream entered the voxel map.
#[test]
fn regression_voxel_count_overflow_panics() {
    let mut h = SceneHeader::parse(&TINY_IMAGE[..64]).unwrap();
    h.dims = [65535, 65535, 65535];
    let mut s = SceneStream::new();
    let mut sink = RecordingSink::default();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let r = s.feed(&h.to_bytes(), &mut sink);
        r.and_then(|()| s.feed(&[0xFF; 16], &mut sink))
    }));
    assert_eq!(r.ok(), Some(Err(SceneError::BadHeader)), "must be rejected, not panic or accepted");
}

/// SPEC.md §5.4 requires the voxel table sorted by strictly increasing voxel id.
#[test]
fn regression_pe_image_unsorted_voxel_table_accepted() {
    let t = ([[0.1, 0.1, 0.5], [0.9, 0.1, 0.5], [0.1, 0.9, 0.5]], 0, 0);
    let unsorted = pe_image(&[t], &[(4, vec![0]), (1, vec![0])]);
    assert_eq!(PeImage::parse(&unsorted).err(), Some(SceneError::BadPeBlock));
    let duplicate = pe_image(&[t], &[(1, vec![0]), (1, vec![0])]);
    assert_eq!(PeImage::parse(&duplicate).err(), Some(SceneError::BadPeBlock));
}

/// `PeImage::voxel_entry(i)` for i ≥ V read ref/triangle words as a voxel entry.
#[test]
fn regression_pe_image_voxel_entry_past_table() {
    let img = PeImage::parse(&TINY_PE_WORDS).unwrap();
    assert_eq!(img.voxel_entry(1), None);
}
