//! Golden-byte and corruption tests of the link additions (SPEC.md §3.7.1 pixel encodings,
//! §3.12 regions): literal bytes computed independently (Python `struct`, `zlib.crc32` and a
//! hand-written COBS encoder), never copied from this crate's output.

mod common;

use common::*;
use gridrt_shared::frame::{self, crc32, FeedResult, FrameAccumulator};
use gridrt_shared::msg::{self, feature, Msg, MsgError, PixelEncoding, Region};
use gridrt_shared::pixel::{self, PixelError, RleEncoder};

/// The §3.7.1 `Rle` worked example: 108 pixels in 14 bytes.
const RLE_EXAMPLE: [u8; 14] = [0xFE, 0x0A, 0x14, 0x1E, 0x04, 0x7D, 0xAA, 0x82, 0xFE, 0x00, 0x00, 0x00, 0xC0, 0x62];

fn rle_example_pixels() -> Vec<[u8; 3]> {
    let mut px = vec![[10, 20, 30]; 6];
    px.push([11, 21, 29]);
    px.push([21, 31, 33]);
    px.extend(std::iter::repeat_n([0, 0, 0], 100));
    px
}

// ---------------------------------------------------------------- §3.7.1 encodings

#[test]
fn encoding_values_and_features() {
    assert_eq!(PixelEncoding::Rgb565 as u8, 1);
    assert_eq!(PixelEncoding::Rle as u8, 2);
    assert_eq!(PixelEncoding::Rgb565.fixed_bytes_per_pixel(), Some(2));
    assert_eq!(PixelEncoding::Rle.fixed_bytes_per_pixel(), None);
    assert_eq!(PixelEncoding::Rle.bytes_per_pixel(), 0);
    assert!(!PixelEncoding::PrimId32.is_colour() && PixelEncoding::Rle.is_colour());
    assert_eq!((feature::RENDER_REGION, feature::RGB565, feature::RLE), (0x100, 0x200, 0x400));
    assert_eq!(PixelEncoding::Rle.feature_bit(), feature::RLE);
    assert_eq!(PixelEncoding::Rgb888.feature_bit(), 0);
}

#[test]
fn msg_pixel_span_rgb565_worked_example() {
    assert_eq!(pixel::rgb565_pack([0xFF, 0x00, 0x80]), 0xF810);
    assert_eq!(pixel::rgb565_pack([0x10, 0x20, 0x30]), 0x1106);
    assert_eq!(pixel::rgb565_unpack(0xF810), [255, 0, 132]);
    assert_eq!(pixel::rgb565_unpack(0x1106), [16, 32, 49]);
    check_msg(
        Msg::PixelSpan {
            frame: 1,
            y: 2,
            x0: 3,
            count: 2,
            encoding: PixelEncoding::Rgb565,
            data: &[0x10, 0xF8, 0x06, 0x11],
        },
        19,
        &[0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x02, 0x00, 0x01, 0x00, 0x10, 0xF8, 0x06, 0x11],
        &[
            0x04, 0x21, 0x01, 0x13, 0x02, 0x0E, 0x02, 0x01, 0x02, 0x02, 0x02, 0x03, 0x02, 0x02, 0x02, 0x01, 0x09, 0x10,
            0xF8, 0x06, 0x11, 0xF8, 0xE5, 0x55, 0x87, 0x00,
        ],
    );
}

#[test]
fn msg_pixel_span_rle_worked_example() {
    let px = rle_example_pixels();
    assert_eq!(px.len(), 108);
    let mut buf = [0u8; 64];
    assert_eq!(pixel::rle_encode(&px, &mut buf), Ok(14));
    assert_eq!(buf[..14], RLE_EXAMPLE);
    let mut out = vec![0u8; 3 * 108];
    pixel::rle_decode(108, &RLE_EXAMPLE, &mut out).unwrap();
    assert_eq!(out, px.iter().flatten().copied().collect::<Vec<_>>());
    assert_eq!(crc32(&out), 0x25D9_016D, "CRC of the decoded span (what RegionEnd covers)");
    check_msg(
        Msg::PixelSpan { frame: 1, y: 2, x0: 0, count: 108, encoding: PixelEncoding::Rle, data: &RLE_EXAMPLE },
        20,
        &[
            0x01, 0x00, 0x02, 0x00, 0x00, 0x00, 0x6C, 0x00, 0x02, 0x00, 0xFE, 0x0A, 0x14, 0x1E, 0x04, 0x7D, 0xAA, 0x82,
            0xFE, 0x00, 0x00, 0x00, 0xC0, 0x62,
        ],
        &[
            0x04, 0x21, 0x01, 0x14, 0x02, 0x18, 0x02, 0x01, 0x02, 0x02, 0x01, 0x01, 0x02, 0x6C, 0x02, 0x02, 0x0A, 0xFE,
            0x0A, 0x14, 0x1E, 0x04, 0x7D, 0xAA, 0x82, 0xFE, 0x01, 0x01, 0x07, 0xC0, 0x62, 0x18, 0x6A, 0x34, 0x8F, 0x00,
        ],
    );
}

/// The op table of §3.7.1, one row each.
#[test]
fn rle_op_table() {
    let dec = |count: usize, data: &[u8]| {
        let mut out = vec![0u8; 3 * count];
        pixel::rle_decode(count, data, &mut out).map(|()| out)
    };
    assert_eq!(dec(3, &[0x02]), Ok(vec![0; 9]), "RUN 3 of the initial black");
    assert_eq!(dec(64, &[0x3F]).map(|v| v.len()), Ok(192));
    assert_eq!(dec(1, &[0x40]), Ok(vec![254, 254, 254]), "DIFF -2,-2,-2 wraps");
    assert_eq!(dec(1, &[0x7F]), Ok(vec![1, 1, 1]));
    assert_eq!(dec(1, &[0x80, 0x00]), Ok(vec![216, 224, 216]), "LUMA dg -32, dr-dg -8, db-dg -8");
    assert_eq!(dec(1, &[0xBF, 0xFF]), Ok(vec![38, 31, 38]), "LUMA dg 31, +7, +7");
    assert_eq!(dec(8192, &[0xDF, 0xFF]).map(|v| v.len()), Ok(3 * 8192));
    assert_eq!(dec(1, &[0xC0, 0x00]), Ok(vec![0, 0, 0]), "RUN_LONG 1");
    assert_eq!(dec(1, &[0xFE, 1, 2, 3]), Ok(vec![1, 2, 3]));
    for tag in (0xE0..=0xFFu8).filter(|&t| t != 0xFE) {
        assert_eq!(dec(1, &[tag, 0, 0, 0]), Err(PixelError::DecodeBadOpcode), "tag {tag:#04x}");
    }
}

// ---------------------------------------------------------------- §3.12 regions

#[test]
fn msg_render_region_worked_example() {
    assert_eq!(msg::RENDER_REGION_LEN, 84);
    let m = Msg::RenderRegion {
        region: Region { x0: 0, y0: 16, cols: 320, rows: 16 },
        max_span: 64,
        options: 0,
        request: example_request(PixelEncoding::Rle),
    };
    check_msg(
        m,
        17,
        &[
            0x00, 0x00, 0x10, 0x00, 0x40, 0x01, 0x10, 0x00, 0x40, 0x00, 0x00, 0x00, 0x01, 0x00, 0x40, 0x01, 0xF0, 0x00,
            0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xA0, 0x40, 0x00, 0x00, 0x00, 0x00,
            0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3F, 0x00, 0x00,
            0x00, 0x00, 0x00, 0x00, 0x34, 0x42, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x80, 0x40, 0x00, 0x00, 0x40, 0x40,
            0x00, 0x00, 0x80, 0x3F, 0x9A, 0x99, 0x19, 0x3E, 0x02, 0x00, 0x00, 0x00,
        ],
        &[
            0x04, 0x24, 0x01, 0x11, 0x02, 0x54, 0x01, 0x01, 0x02, 0x10, 0x04, 0x40, 0x01, 0x10, 0x02, 0x40, 0x01, 0x01,
            0x02, 0x01, 0x04, 0x40, 0x01, 0xF0, 0x02, 0x03, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x03, 0xA0, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x03, 0x80, 0x3F, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x34, 0x42, 0x01, 0x01, 0x02, 0x40, 0x01,
            0x03, 0x80, 0x40, 0x01, 0x03, 0x40, 0x40, 0x01, 0x08, 0x80, 0x3F, 0x9A, 0x99, 0x19, 0x3E, 0x02, 0x01, 0x01,
            0x05, 0xB4, 0x1F, 0x36, 0x52, 0x00,
        ],
    );
}

/// §3.12.2 option `SPAN_BYTES` (bit 2): a re-request of row 5, columns 0..320, with spans of at
/// most 311 data bytes and no Stats — the first 12 payload bytes; the request follows as in
/// the worked example above.
#[test]
fn msg_render_region_span_bytes() {
    assert_eq!(msg::region_options::SPAN_BYTES, 1 << 2);
    let m = Msg::RenderRegion {
        region: Region { x0: 0, y0: 5, cols: 320, rows: 1 },
        max_span: 311,
        options: msg::region_options::NO_STATS | msg::region_options::SPAN_BYTES,
        request: example_request(PixelEncoding::Rle),
    };
    let payload = encode_payload(&m);
    assert_eq!(payload[..12], [0x00, 0x00, 0x05, 0x00, 0x40, 0x01, 0x01, 0x00, 0x37, 0x01, 0x06, 0x00]);
    assert_eq!(Msg::decode(msg::MsgType::RenderRegion as u8, &payload), Ok(m));
    // Reserved option bits are ignored, not refused (§3.12.2), so a device that does not know
    // `SPAN_BYTES` still answers (taking `max_span` as pixels).
    let mut later = payload.clone();
    later[10] = 0xFE;
    later[11] = 0xFF;
    assert!(matches!(
        Msg::decode(msg::MsgType::RenderRegion as u8, &later),
        Ok(Msg::RenderRegion { options: 0xFFFE, max_span: 311, .. })
    ));
}

#[test]
fn msg_region_end_worked_example() {
    assert_eq!(msg::REGION_END_LEN, 20);
    check_msg(
        Msg::RegionEnd { frame: 1, region: Region { x0: 0, y0: 16, cols: 320, rows: 16 }, spans: 20, crc: 0xCAFE_F00D },
        18,
        &[
            0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x40, 0x01, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00, 0x0D, 0xF0,
            0xFE, 0xCA,
        ],
        &[
            0x04, 0x25, 0x01, 0x12, 0x02, 0x14, 0x02, 0x01, 0x01, 0x01, 0x01, 0x01, 0x02, 0x10, 0x04, 0x40, 0x01, 0x10,
            0x02, 0x14, 0x01, 0x01, 0x09, 0x0D, 0xF0, 0xFE, 0xCA, 0x04, 0x59, 0x7A, 0x80, 0x00,
        ],
    );
}

#[test]
fn region_geometry() {
    let r = Region { x0: 10, y0: 20, cols: 30, rows: 40 };
    assert_eq!(r.pixels(), 1200);
    assert!(r.fits(40, 60));
    assert!(!r.fits(39, 60) && !r.fits(40, 59));
    assert!(!Region { cols: 0, ..r }.fits(100, 100));
    assert!(!Region { x0: u16::MAX, cols: 2, ..r }.fits(u16::MAX, 100), "no u16 overflow");
    assert_eq!(Region::full(64, 48), Region { x0: 0, y0: 0, cols: 64, rows: 48 });
}

// ---------------------------------------------------------------- corruption

#[test]
fn region_messages_check_exact_lengths() {
    let rr = encode_payload(&Msg::RenderRegion {
        region: Region::full(4, 4),
        max_span: 0,
        options: 1,
        request: example_request(PixelEncoding::Rle),
    });
    let re = encode_payload(&Msg::RegionEnd { frame: 1, region: Region::full(4, 4), spans: 1, crc: 2 });
    for (kind, p) in [(0x24u8, &rr), (0x25, &re)] {
        for n in 0..p.len() {
            assert_eq!(Msg::decode(kind, &p[..n]), Err(MsgError::DecodeTruncated), "{kind:#04x} cut at {n}");
        }
        let mut long = p.clone();
        long.push(0);
        assert_eq!(Msg::decode(kind, &long), Err(MsgError::DecodeTrailingBytes), "{kind:#04x}");
    }
    // The embedded request's encoding byte is checked like RenderRequest's.
    let mut bad = rr.clone();
    bad[12 + 68] = 3;
    assert_eq!(Msg::decode(0x24, &bad), Err(MsgError::DecodeBadField));
}

#[test]
fn rle_span_that_does_not_decode_to_count_is_rejected() {
    let span = |count: u16, data: &[u8]| {
        let mut p = vec![1, 0, 0, 0, 0, 0];
        p.extend_from_slice(&count.to_le_bytes());
        p.extend_from_slice(&[2, 0]);
        p.extend_from_slice(data);
        Msg::decode(0x21, &p).map(|_| ())
    };
    assert!(span(108, &RLE_EXAMPLE).is_ok());
    assert_eq!(span(107, &RLE_EXAMPLE), Err(MsgError::DecodeBadField), "run overflows the span");
    assert_eq!(span(109, &RLE_EXAMPLE), Err(MsgError::DecodeBadField), "data ends early");
    assert_eq!(span(108, &RLE_EXAMPLE[..13]), Err(MsgError::DecodeBadField), "op cut");
    let mut trailing = RLE_EXAMPLE.to_vec();
    trailing.push(0x00);
    assert_eq!(span(108, &trailing), Err(MsgError::DecodeBadField), "byte after the last pixel");
    assert_eq!(span(0, &[]), Ok(()), "an empty span is empty data");
    // The encoder refuses what the decoder rejects.
    let m = Msg::PixelSpan { frame: 1, y: 0, x0: 0, count: 107, encoding: PixelEncoding::Rle, data: &RLE_EXAMPLE };
    assert_eq!(m.encode(&mut [0u8; 64]), Err(MsgError::EncodeBadField));
}

#[test]
fn rle_every_single_bit_flip_is_corrected_caught_or_harmless() {
    // A flip of a COBS data byte is corrected (§2.5: the frame is short) and the span arrives
    // as sent; a flip of a code byte or the delimiter breaks the frame, which is rejected.
    // Any damage that COBS and the frame CRC let through would have to also decode to exactly
    // `count` pixels; the pixel layer on its own never panics and never writes outside the span.
    let payload = encode_payload(&Msg::PixelSpan {
        frame: 1,
        y: 2,
        x0: 0,
        count: 108,
        encoding: PixelEncoding::Rle,
        data: &RLE_EXAMPLE,
    });
    let w = wire(0x21, 20, &payload);
    for bit in 0..(w.len() - 1) * 8 {
        let mut c = w.clone();
        c[bit / 8] ^= 1 << (bit % 8);
        let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
        let out = feed_all(&mut acc, &c, 5);
        let sent = Outcome::Frame { kind: 0x21, seq: 20, payload: payload.clone() };
        assert!(out.iter().all(|o| !matches!(o, Outcome::Frame { .. }) || *o == sent), "bit {bit}: {out:?}");
        let mut data = RLE_EXAMPLE;
        if bit / 8 < data.len() {
            data[bit / 8] ^= 1 << (bit % 8);
            let mut img = vec![0u8; 3 * 108];
            let _ = pixel::rle_decode(108, &data, &mut img);
        }
    }
}

#[test]
fn sequence_numbers_are_in_every_frame_and_checked_by_crc() {
    // §2.1: seq is covered by the CRC; a receiver sees gaps (frames lost) by subtraction.
    let mut stream = Vec::new();
    for seq in [65534u16, 65535, 0, 2] {
        stream.extend_from_slice(&wire(
            0x25,
            seq,
            &encode_payload(&Msg::RegionEnd { frame: 1, region: Region::full(1, 1), spans: 0, crc: 0 }),
        ));
    }
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    let seqs: Vec<u16> = feed_all(&mut acc, &stream, 9)
        .into_iter()
        .map(|o| match o {
            Outcome::Frame { seq, .. } => seq,
            o => panic!("{o:?}"),
        })
        .collect();
    assert_eq!(seqs, [65534, 65535, 0, 2]);
    let gaps: Vec<u16> = seqs.windows(2).map(|w| w[1].wrapping_sub(w[0]).wrapping_sub(1)).collect();
    assert_eq!(gaps, [0, 0, 1], "one frame lost between 0 and 2, none at the wrap");
}

#[test]
fn encoder_push_bound_holds_for_adversarial_sequences() {
    // Alternating far-apart pixels after a long run: every push needs the full 6 bytes.
    let mut e = RleEncoder::new();
    let mut buf = [0u8; pixel::RLE_MAX_PUSH_BYTES];
    for _ in 0..100 {
        assert_eq!(e.push([0, 0, 0], &mut buf), Ok(0));
    }
    assert_eq!(e.push([200, 1, 99], &mut buf), Ok(6));
    assert_eq!(e.push([200, 1, 99], &mut buf[..0]), Ok(0));
    // RUN 1 + RGB needs 5 bytes: with 4 the push fails and changes nothing.
    let before = e;
    assert_eq!(e.push([0, 100, 0], &mut buf[..4]), Err(PixelError::BufferTooSmall));
    assert_eq!(e, before);
    assert_eq!(e.push([0, 100, 0], &mut buf[..5]), Ok(5));
    assert_eq!(buf[..5], [0x00, 0xFE, 0, 100, 0]);
}

#[test]
fn accumulator_never_returns_a_corrupt_span() {
    // A burst of garbage with embedded zeros in front of and inside a stream of spans.
    let mut rng = 0x1234_5678u32;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        rng
    };
    let good = wire(
        0x21,
        20,
        &encode_payload(&Msg::PixelSpan {
            frame: 1,
            y: 2,
            x0: 0,
            count: 108,
            encoding: PixelEncoding::Rle,
            data: &RLE_EXAMPLE,
        }),
    );
    let mut stream = Vec::new();
    for i in 0..200 {
        if i % 3 == 0 {
            for _ in 0..(next() % 40) {
                stream.push(next() as u8);
            }
        }
        stream.extend_from_slice(&good);
    }
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    let mut input: &[u8] = &stream;
    let mut frames = 0;
    loop {
        match acc.feed(input) {
            FeedResult::Consumed => break,
            FeedResult::Overflow { rest } | FeedResult::BadFrame { rest, .. } => input = rest,
            FeedResult::Frame { frame, rest } => {
                assert_eq!(Msg::decode(frame.kind, frame.payload).map(|_| ()), Ok(()));
                assert_eq!(frame.payload[10..], RLE_EXAMPLE);
                frames += 1;
                input = rest;
            }
        }
    }
    assert!(frames >= 100, "{frames}");
}

// ---------------------------------------------------------------- §3.14 windowed transfers

/// §3.14 worked example: the §5.9 image (348 bytes) in chunks of 100 bytes; the frame of
/// chunk 100..200 (seq 11) is corrupted on the way. The device's `ReceiveWindow` gives the
/// Sacks of the SPEC's transcript; the one after seq 13 has the literal bytes shown there.
#[test]
fn windowed_upload_worked_example() {
    use gridrt_shared::msg::{SceneStatus, MAX_SACK_RANGES};
    use gridrt_shared::window::{Arrival, ReceiveWindow};
    let mut w = ReceiveWindow::new(TINY_IMAGE.len() as u32, 4096);
    let probe = w.sack(9, TINY_IMAGE_CRC);
    assert_eq!((probe.next_offset, probe.heard, probe.window, probe.ranges.len()), (0, 9, 4096, 0));
    check_msg(
        Msg::SceneData { offset: 0, data: &[] },
        9,
        &[0, 0, 0, 0],
        &[0x04, 0x13, 0x01, 0x09, 0x02, 0x04, 0x01, 0x01, 0x01, 0x01, 0x05, 0xE3, 0x1F, 0xB6, 0xBC, 0x00],
    );
    assert_eq!(w.arrive(0, 100), Arrival::Advanced { from: 0, to: 100 });
    assert_eq!(w.sack(10, TINY_IMAGE_CRC).next_offset, 100);
    // seq 11 never arrives intact (the device reports Error{BadFrame}).
    assert_eq!(w.arrive(200, 100), Arrival::Held);
    assert_eq!(w.sack(12, TINY_IMAGE_CRC).ranges.as_slice(), [(100, 200)]);
    assert_eq!(w.arrive(300, 48), Arrival::Held);
    let s = w.sack(13, TINY_IMAGE_CRC);
    assert!(s.ranges.len() <= MAX_SACK_RANGES);
    check_msg(
        Msg::SceneSack { status: SceneStatus::Receiving, sack: s },
        4,
        &[
            0x64, 0x00, 0x00, 0x00, 0x00, 0x01, 0x0D, 0x00, 0x00, 0x10, 0x00, 0x00, 0xA2, 0x82, 0x96, 0x2A, 0x64, 0x00,
            0xF8, 0x00,
        ],
        &[
            0x04, 0x14, 0x01, 0x04, 0x02, 0x14, 0x02, 0x64, 0x01, 0x01, 0x01, 0x03, 0x01, 0x0D, 0x01, 0x02, 0x10, 0x01,
            0x06, 0xA2, 0x82, 0x96, 0x2A, 0x64, 0x02, 0xF8, 0x05, 0x88, 0x02, 0x61, 0x08, 0x00,
        ],
    );
    // The host sees heard = 13 ≥ 11 and 100..200 not held: lost; sent again as seq 14.
    assert_eq!(w.arrive(100, 100), Arrival::Advanced { from: 100, to: 348 });
    assert!(w.complete());
}
