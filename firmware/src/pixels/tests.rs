//! Frame helpers shared by the tests of every module that writes frames, and the tests of
//! the frame encoder and of the span encoder.

use super::*;
use embedded_io::{ErrorKind, Write};
use gridrt_shared::frame::{crc32, encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{Msg, PixelEncoding};
use gridrt_shared::pixel;

/// Output that takes `room` bytes, then fails.
struct Full {
    room: usize,
    got: Vec<u8>,
}
impl embedded_io::ErrorType for Full {
    type Error = ErrorKind;
}
impl Write for Full {
    fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        let n = buf.len().min(self.room);
        if n == 0 && !buf.is_empty() {
            return Err(ErrorKind::WriteZero);
        }
        self.room -= n;
        self.got.extend_from_slice(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> Result<(), ErrorKind> {
        Ok(())
    }
}

/// Decodes every frame on the wire as (seq, kind, payload); panics on a bad frame.
pub(crate) fn frames(wire: &[u8]) -> Vec<(u16, u8, Vec<u8>)> {
    let mut acc = FrameAccumulator::<{ MAX_ENCODED }>::new();
    let mut input = wire;
    let mut out = Vec::new();
    loop {
        match acc.feed(input) {
            FeedResult::Frame { frame, rest } => {
                out.push((frame.seq, frame.kind, frame.payload.to_vec()));
                input = rest;
            }
            FeedResult::Consumed => return out,
            other => panic!("bad frame on the wire: {other:?}"),
        }
    }
}

/// `msg` as one frame with sequence number `seq`, as a host would send it.
pub(crate) fn frame_of(msg: &Msg<'_>, seq: u16) -> Vec<u8> {
    let mut payload = [0u8; MAX_PAYLOAD];
    let n = msg.encode(&mut payload).unwrap();
    let mut out = [0u8; MAX_ENCODED];
    let len = encode_frame(msg.kind() as u8, seq, &payload[..n], &mut out).unwrap();
    out[..len].to_vec()
}

#[test]
fn sequence_numbers_count_up_per_frame_and_wrap() {
    let mut tx = FrameTx::new();
    let mut w = Vec::new();
    tx.seq = u16::MAX;
    tx.send(&Msg::Hello { protocol: 1 }, &mut w).unwrap();
    tx.send(&Msg::Hello { protocol: 1 }, &mut w).unwrap();
    let seqs: Vec<_> = frames(&w).iter().map(|f| f.0).collect();
    assert_eq!(seqs, [u16::MAX, 0]);
}

#[test]
fn long_rows_split_into_max_size_spans_and_crc_covers_the_image() {
    for prim_ids in [false, true] {
        let (w, h) = (1100u16, 2u16);
        let mut tx = FrameTx::new();
        let mut enc = SpanEncoder::new();
        let mut wire = Vec::new();
        enc.begin(7, prim_ids);
        let mut image = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let rgb = [x as u8, y as u8, (x >> 8) as u8];
                image.extend_from_slice(&rgb);
                enc.push(x, y, rgb, x as u32 * 10 + y as u32, &mut tx, &mut wire).unwrap();
            }
            enc.flush(&mut tx, &mut wire).unwrap();
        }
        let (spans, crc) = enc.finish();
        assert_eq!(crc, crc32(&image));
        let frames = frames(&wire);
        assert_eq!(frames.len() as u32, spans);
        let per_row = if prim_ids { 3 * 2 } else { 3 };
        assert_eq!(spans, per_row * h as u32);
        let mut got = Vec::new();
        let mut next_x = 0;
        for (_, kind, payload) in &frames {
            let Msg::PixelSpan { frame, y, x0, count, encoding, data } = Msg::decode(*kind, payload).unwrap() else {
                panic!()
            };
            assert_eq!(frame, 7);
            let cap = if prim_ids { MAX_SPAN_PIXELS_WITH_IDS } else { MAX_SPAN_PIXELS };
            assert!(count as usize <= cap);
            match encoding {
                PixelEncoding::Rgb888 => {
                    assert_eq!(x0, next_x % w);
                    next_x = (x0 + count) % w;
                    got.extend_from_slice(data);
                }
                PixelEncoding::PrimId32 => {
                    for (i, c) in data.chunks(4).enumerate() {
                        let id = u32::from_le_bytes(c.try_into().unwrap());
                        assert_eq!(id, (x0 as u32 + i as u32) * 10 + y as u32);
                    }
                }
                _ => panic!(),
            }
        }
        assert_eq!(got, image);
    }
}

/// Decodes the colour spans of `wire` into an image of `w`×`h` RGB888 pixels.
fn decode_image(wire: &[u8], w: usize, h: usize) -> Vec<u8> {
    let mut img = vec![0u8; 3 * w * h];
    for (_, kind, payload) in frames(wire) {
        let Msg::PixelSpan { y, x0, count, encoding, data, .. } = Msg::decode(kind, &payload).unwrap() else {
            panic!()
        };
        let at = 3 * (y as usize * w + x0 as usize);
        let dst = &mut img[at..at + 3 * count as usize];
        match encoding {
            PixelEncoding::Rgb888 => dst.copy_from_slice(data),
            PixelEncoding::Rgb565 => {
                for (d, c) in dst.chunks_mut(3).zip(data.chunks(2)) {
                    d.copy_from_slice(&pixel::rgb565_unpack(u16::from_le_bytes([c[0], c[1]])));
                }
            }
            PixelEncoding::Rle => pixel::rle_decode(count as usize, data, dst).unwrap(),
            PixelEncoding::PrimId32 => {}
            _ => panic!(),
        }
    }
    img
}

/// Runs pushed at once give the image and the CRC of their pixels pushed one by one, in
/// every encoding, with and without primitive ids, with spans of every length limit.
#[test]
fn runs_give_the_pixels_and_crc_of_single_pushes() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5EA1_0001);
    let (w, h) = (700u16, 5u16);
    for encoding in [PixelEncoding::Rgb888, PixelEncoding::Rgb565, PixelEncoding::Rle] {
        for (prim_ids, max_span) in [(false, 0), (true, 0), (false, 37), (false, 1)] {
            let (mut a, mut b) = (SpanEncoder::new(), SpanEncoder::new());
            let (mut ta, mut tb) = (FrameTx::new(), FrameTx::new());
            let (mut wa, mut wb) = (Vec::new(), Vec::new());
            a.begin_with(3, prim_ids, encoding, max_span);
            b.begin_with(3, prim_ids, encoding, max_span);
            for y in 0..h {
                let mut x = 0u16;
                while x < w {
                    let n = (if rng.gen_bool(0.5) { rng.gen_range(1..4) } else { rng.gen_range(1..400) }).min(w - x);
                    let rgb = if rng.gen_bool(0.5) { [20, 20, 31] } else { rng.gen() };
                    for i in 0..n {
                        a.push(x + i, y, rgb, 9, &mut ta, &mut wa).unwrap();
                    }
                    b.push_run(x, y, n, rgb, 9, &mut tb, &mut wb).unwrap();
                    x += n;
                }
                a.flush(&mut ta, &mut wa).unwrap();
                b.flush(&mut tb, &mut wb).unwrap();
            }
            let (ca, cb) = (a.finish().1, b.finish().1);
            assert_eq!(ca, cb, "{encoding:?} {prim_ids} {max_span}");
            assert_eq!(decode_image(&wa, w as usize, h as usize), decode_image(&wb, w as usize, h as usize));
            if encoding != PixelEncoding::Rle || prim_ids {
                assert_eq!(wa, wb, "the same spans");
            } else {
                assert!(wb.len() <= wa.len(), "runs take no more bytes: {} vs {}", wb.len(), wa.len());
            }
        }
    }
}

#[test]
fn gap_or_row_change_flushes_pending_span() {
    let mut tx = FrameTx::new();
    let mut enc = SpanEncoder::new();
    let mut wire = Vec::new();
    enc.begin(1, false);
    enc.push(0, 0, [1; 3], 0, &mut tx, &mut wire).unwrap();
    enc.push(1, 0, [1; 3], 0, &mut tx, &mut wire).unwrap();
    enc.push(0, 1, [2; 3], 0, &mut tx, &mut wire).unwrap();
    enc.push(5, 1, [3; 3], 0, &mut tx, &mut wire).unwrap();
    enc.flush(&mut tx, &mut wire).unwrap();
    enc.flush(&mut tx, &mut wire).unwrap(); // nothing pending: no frame
    assert_eq!(enc.finish().0, 3);
    assert_eq!(frames(&wire).len(), 3);
}

#[test]
fn a_failed_write_is_counted_and_returned_and_keeps_the_sequence_number() {
    let mut tx = FrameTx::new();
    let mut out = Full { room: 5, got: Vec::new() };
    let hello = Msg::Hello { protocol: 1 };
    assert_eq!(tx.send(&hello, &mut out), Err(TxError::Write(ErrorKind::WriteZero)));
    assert_eq!(tx.delimiter(&mut out), Err(TxError::Write(ErrorKind::WriteZero)));
    assert_eq!((tx.write_errors(), tx.next_seq(), out.got.len()), (2, 0, 5));
    let mut wire = Vec::new();
    tx.send(&hello, &mut wire).unwrap();
    tx.delimiter(&mut wire).unwrap();
    assert_eq!(wire.last(), Some(&0));
    assert_eq!((tx.write_errors(), tx.next_seq(), frames(&wire)[0].0), (2, 1, 0));
}
