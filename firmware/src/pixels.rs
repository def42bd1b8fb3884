//! Outbound frames: the UART frame encoder with the device's sequence number, and the pixel
//! span packer with the running image CRC.
//!
//! Wire format: `shared::frame` (COBS + CRC-32 frames) carrying `shared::msg` payloads.
//! A frame's pixels leave as `PixelSpan` messages of one row segment each, in row-major order,
//! so the CRC-32 of the whole RGB888 image (sent in `FrameEnd`) can be computed on the fly
//! without holding the image.
//!
//! Output goes to any [`embedded_io::Write`] (the UART drivers of `crate::bsp`, a test
//! buffer, a channel). A write error has no one to be reported to: [`FrameTx`] counts it
//! ([`FrameTx::write_errors`]) and returns [`TxError::Write`], and the caller stops what it
//! was sending (the device stops the frame, see `crate::device`).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use embedded_io::{Error as _, ErrorKind, Write};
use gridrt_shared::frame::{encode_frame, Crc32Digest, FrameError, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{Msg, MsgError, PixelEncoding};
use gridrt_shared::pixel::{self, RleEncoder, RLE_MAX_FINISH_BYTES, RLE_MAX_PUSH_BYTES};

/// Most bytes a run of at most [`MAX_RLE_SPAN_PIXELS`] pixels adds to an `Rle` span: its
/// first pixel, one full RUN_LONG (a span is shorter than `RUN_LONG_MAX` pixels, so at most
/// one), and the span's end.
const RLE_MAX_RUN_BYTES: usize = RLE_MAX_PUSH_BYTES + 2 + RLE_MAX_FINISH_BYTES;

/// Bytes of a `PixelSpan` payload before the pixel data.
pub const SPAN_HEADER_LEN: usize = 10;

/// Pixels per colour span when only colour is sent (1 546-byte payload).
pub const MAX_SPAN_PIXELS: usize = 512;

/// Pixels per span when `render_flags::PRIM_IDS` is set: a 512-pixel `PrimId32` span would
/// need 10 + 2 048 bytes > `MAX_PAYLOAD`, so both spans of a pair hold at most 509 pixels.
pub const MAX_SPAN_PIXELS_WITH_IDS: usize = (MAX_PAYLOAD - SPAN_HEADER_LEN) / 4;

const _: () = assert!(SPAN_HEADER_LEN + 3 * MAX_SPAN_PIXELS <= MAX_PAYLOAD);
const _: () = assert!(SPAN_HEADER_LEN + 4 * MAX_SPAN_PIXELS_WITH_IDS <= MAX_PAYLOAD);
const _: () = assert!(MAX_SPAN_PIXELS_WITH_IDS <= MAX_SPAN_PIXELS);

/// Why a message could not be sent: a firmware bug (never outside data), or the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TxError {
    /// The payload did not fit.
    Msg(MsgError),
    /// The frame did not fit.
    Frame(FrameError),
    /// The output failed (counted in [`FrameTx::write_errors`]); part of the frame may
    /// have gone out.
    Write(ErrorKind),
}

/// Frame encoder: owns the outbound sequence number and the payload/wire buffers.
pub struct FrameTx {
    seq: u16,
    write_errors: u32,
    payload: [u8; MAX_PAYLOAD],
    wire: [u8; MAX_ENCODED],
}

impl Default for FrameTx {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameTx {
    /// Encoder whose first frame has sequence number 0.
    pub const fn new() -> Self {
        Self { seq: 0, write_errors: 0, payload: [0; MAX_PAYLOAD], wire: [0; MAX_ENCODED] }
    }

    /// Sequence number of the next frame.
    pub fn next_seq(&self) -> u16 {
        self.seq
    }

    /// Writes that failed so far (saturating): each failed [`send`](Self::send) or
    /// [`delimiter`](Self::delimiter) counts once.
    pub fn write_errors(&self) -> u32 {
        self.write_errors
    }

    /// Encodes `msg` as one frame and writes it with `write_all` (blocking until the output
    /// took every byte); the sequence number advances (wrapping) only when the frame was
    /// written.
    pub fn send<W: Write + ?Sized>(&mut self, msg: &Msg<'_>, out: &mut W) -> Result<(), TxError> {
        let n = msg.encode(&mut self.payload).map_err(TxError::Msg)?;
        let payload = self.payload.get(..n).ok_or(TxError::Msg(MsgError::EncodeBufferTooSmall))?;
        let len = encode_frame(msg.kind() as u8, self.seq, payload, &mut self.wire).map_err(TxError::Frame)?;
        let wire = self.wire.get(..len).ok_or(TxError::Frame(FrameError::EncodeBufferTooSmall))?;
        Self::write(&mut self.write_errors, wire, out)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// Writes a lone frame delimiter (`0x00`: the receiver drops whatever partial frame it
    /// holds), blocking like [`send`](Self::send).
    pub fn delimiter<W: Write + ?Sized>(&mut self, out: &mut W) -> Result<(), TxError> {
        Self::write(&mut self.write_errors, &[0], out)
    }

    fn write<W: Write + ?Sized>(errors: &mut u32, bytes: &[u8], out: &mut W) -> Result<(), TxError> {
        out.write_all(bytes).map_err(|e| {
            *errors = errors.saturating_add(1);
            TxError::Write(e.kind())
        })
    }
}

/// Bytes of pixel data a `PixelSpan` can carry.
pub const MAX_SPAN_DATA: usize = MAX_PAYLOAD - SPAN_HEADER_LEN;

/// Pixels per `Rle` span when only colour is sent: a whole row of the largest image.
pub const MAX_RLE_SPAN_PIXELS: usize = 4096;

const _: () = assert!(3 * MAX_SPAN_PIXELS <= MAX_SPAN_DATA);

/// Packs pixels into row-segment spans (plus `PrimId32` spans when asked) in the requested
/// encoding (SPEC.md §3.7.1) and keeps the running CRC-32 of the pixels as the host decodes
/// them (RGB888; for `Rgb565` the bit-replicated expansion). Pixels must be pushed in
/// row-major order.
///
/// Memory is fixed: one span of encoded data ([`MAX_SPAN_DATA`] bytes), one span of
/// primitive ids, and the 4-byte `Rle` encoder state. A span ends at a row end, a gap, the
/// pixel limit, or when the next pixel might not fit the data buffer.
pub struct SpanEncoder {
    frame: u16,
    prim_ids: bool,
    encoding: PixelEncoding,
    span_len: usize,
    /// Most data bytes per span.
    data_limit: usize,
    y: u16,
    x0: u16,
    count: usize,
    data: [u8; MAX_SPAN_DATA],
    len: usize,
    rle: RleEncoder,
    ids: [u8; 4 * MAX_SPAN_PIXELS_WITH_IDS],
    crc: Crc32Digest,
    spans: u32,
    silent: bool,
}

impl Default for SpanEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl SpanEncoder {
    /// An idle encoder (call [`begin`](Self::begin) per frame).
    pub fn new() -> Self {
        Self {
            frame: 0,
            prim_ids: false,
            encoding: PixelEncoding::Rgb888,
            span_len: MAX_SPAN_PIXELS,
            data_limit: MAX_SPAN_DATA,
            y: 0,
            x0: 0,
            count: 0,
            data: [0; MAX_SPAN_DATA],
            len: 0,
            rle: RleEncoder::new(),
            ids: [0; 4 * MAX_SPAN_PIXELS_WITH_IDS],
            crc: Crc32Digest::default(),
            spans: 0,
            silent: false,
        }
    }

    /// Starts frame `frame` in `Rgb888` with the default span length; with `prim_ids` every
    /// colour span is followed by a `PrimId32` span of the same pixels.
    pub fn begin(&mut self, frame: u16, prim_ids: bool) {
        self.begin_with(frame, prim_ids, PixelEncoding::Rgb888, 0);
    }

    /// Starts frame (or region) `frame` in `encoding` with at most `max_span` pixels per span
    /// (0 = the default: [`MAX_SPAN_PIXELS`], [`MAX_RLE_SPAN_PIXELS`] for `Rle`,
    /// [`MAX_SPAN_PIXELS_WITH_IDS`] with `prim_ids`). `encoding` must be a colour encoding
    /// (`PrimId32` is sent as `Rgb888`).
    pub fn begin_with(&mut self, frame: u16, prim_ids: bool, encoding: PixelEncoding, max_span: u16) {
        let encoding = if encoding.is_colour() { encoding } else { PixelEncoding::Rgb888 };
        let default = match (prim_ids, encoding) {
            (true, _) => MAX_SPAN_PIXELS_WITH_IDS,
            (false, PixelEncoding::Rle) => MAX_RLE_SPAN_PIXELS,
            (false, _) => MAX_SPAN_PIXELS,
        };
        self.frame = frame;
        self.prim_ids = prim_ids;
        self.encoding = encoding;
        self.span_len = if max_span == 0 { default } else { default.min(max_span as usize) };
        self.data_limit = MAX_SPAN_DATA;
        self.count = 0;
        self.len = 0;
        self.rle = RleEncoder::new();
        self.crc = Crc32Digest::default();
        self.spans = 0;
        self.silent = false;
    }

    /// With `silent` the encoder keeps the CRC but sends no spans (`RenderRegion` option
    /// `CRC_ONLY`). Call after `begin_with`.
    pub fn set_silent(&mut self, silent: bool) {
        self.silent = silent;
    }

    /// Ends each span before its data would pass `max_bytes` (0 = the buffer's size; a span
    /// holds at least one pixel): `RenderRegion` option `SPAN_BYTES`. Call after `begin_with`.
    pub fn set_data_limit(&mut self, max_bytes: u16) {
        self.data_limit = if max_bytes == 0 { MAX_SPAN_DATA } else { MAX_SPAN_DATA.min(max_bytes as usize) };
    }

    /// True when one more pixel surely fits the data buffer and the data limit.
    fn has_room(&self) -> bool {
        let need = match self.encoding.fixed_bytes_per_pixel() {
            Some(bpp) => bpp,
            None => RLE_MAX_PUSH_BYTES + RLE_MAX_FINISH_BYTES,
        };
        self.len.saturating_add(need) <= self.data_limit
    }

    /// Adds pixel (x, y). A pixel that does not continue the pending span (other row, gap), a
    /// full span or a full data buffer flushes the pending span first.
    #[inline]
    pub fn push<W: Write + ?Sized>(
        &mut self,
        x: u16,
        y: u16,
        rgb: [u8; 3],
        prim: u32,
        tx: &mut FrameTx,
        out: &mut W,
    ) -> Result<(), TxError> {
        let continues = self.count > 0 && y == self.y && x as usize == (self.x0 as usize).saturating_add(self.count);
        if self.count > 0 && (!continues || self.count >= self.span_len || !self.has_room()) {
            self.flush(tx, out)?;
        }
        if self.count == 0 {
            self.y = y;
            self.x0 = x;
        }
        let at = self.len;
        let written = match self.encoding {
            PixelEncoding::Rgb565 => {
                let v = pixel::rgb565_pack(rgb);
                if let Some(dst) = self.data.get_mut(at..).and_then(|d| d.get_mut(..2)) {
                    dst.copy_from_slice(&v.to_le_bytes());
                }
                self.crc.update(&pixel::rgb565_unpack(v));
                2
            }
            PixelEncoding::Rle => {
                self.crc.update(&rgb);
                let dst = self.data.get_mut(at..).unwrap_or(&mut []);
                self.rle.push(rgb, dst).map_err(|_| TxError::Msg(MsgError::EncodeBufferTooSmall))?
            }
            _ => {
                // Rgb888: the CRC is taken over the whole span at flush time.
                if let Some(dst) = self.data.get_mut(at..).and_then(|d| d.get_mut(..3)) {
                    dst.copy_from_slice(&rgb);
                }
                3
            }
        };
        // Both stay below their buffers' sizes (`has_room`, `span_len`).
        self.len = self.len.saturating_add(written);
        if self.prim_ids {
            if let Some(dst) = self.ids.chunks_exact_mut(4).nth(self.count) {
                dst.copy_from_slice(&prim.to_le_bytes());
            }
        }
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Adds `n` pixels of colour `rgb` and primitive `prim` from (x, y) rightwards: the pixels
    /// of `n` [`push`](Self::push)es, and for `Rle` without primitive ids at the cost of
    /// one per span (the run is encoded at once and the CRC taken over a repeated pattern);
    /// the spans may be cut elsewhere than per pixel, never longer.
    #[allow(clippy::too_many_arguments)] // `push`'s arguments and the run length
    pub fn push_run<W: Write + ?Sized>(
        &mut self,
        x: u16,
        y: u16,
        n: u16,
        rgb: [u8; 3],
        prim: u32,
        tx: &mut FrameTx,
        out: &mut W,
    ) -> Result<(), TxError> {
        if self.encoding != PixelEncoding::Rle || self.prim_ids {
            for x in (x..).take(n as usize) {
                self.push(x, y, rgb, prim, tx, out)?;
            }
            return Ok(());
        }
        let mut pattern = [0u8; 3 * 16];
        for c in pattern.chunks_exact_mut(3) {
            c.copy_from_slice(&rgb);
        }
        let (mut x, mut left) = (x as usize, n as usize);
        // Bounded: each round takes at least one pixel (a flushed span is empty).
        while left > 0 {
            let continues = self.count > 0 && y == self.y && x == (self.x0 as usize).saturating_add(self.count);
            let room = self.len.saturating_add(RLE_MAX_RUN_BYTES) <= MAX_SPAN_DATA;
            if self.count > 0 && (!continues || self.count >= self.span_len || !room) {
                self.flush(tx, out)?;
            }
            if self.count == 0 {
                self.y = y;
                self.x0 = x as u16;
            }
            let k = left.min(self.span_len.saturating_sub(self.count)).max(1);
            let dst = self.data.get_mut(self.len..).unwrap_or(&mut []);
            let written =
                self.rle.push_run(rgb, k as u32, dst).map_err(|_| TxError::Msg(MsgError::EncodeBufferTooSmall))?;
            self.len = self.len.saturating_add(written);
            let mut crc_left = k;
            while crc_left > 0 {
                let c = crc_left.min(16);
                self.crc.update(pattern.get(..c.saturating_mul(3)).unwrap_or(&[]));
                crc_left = crc_left.saturating_sub(c);
            }
            self.count = self.count.saturating_add(k);
            x = x.saturating_add(k);
            left = left.saturating_sub(k);
        }
        Ok(())
    }

    /// Sends the pending span (and its `PrimId32` span), if any.
    pub fn flush<W: Write + ?Sized>(&mut self, tx: &mut FrameTx, out: &mut W) -> Result<(), TxError> {
        let n = core::mem::take(&mut self.count);
        if n == 0 {
            return Ok(());
        }
        if self.encoding == PixelEncoding::Rle {
            let dst = self.data.get_mut(self.len..).unwrap_or(&mut []);
            let tail = self.rle.finish(dst).map_err(|_| TxError::Msg(MsgError::EncodeBufferTooSmall))?;
            self.len = self.len.saturating_add(tail);
        }
        let len = core::mem::take(&mut self.len);
        let data = self.data.get(..len).unwrap_or(&[]);
        if self.encoding == PixelEncoding::Rgb888 {
            self.crc.update(data);
        }
        if self.silent {
            return Ok(());
        }
        let (frame, y, x0, count) = (self.frame, self.y, self.x0, n as u16);
        tx.send(&Msg::PixelSpan { frame, y, x0, count, encoding: self.encoding, data }, out)?;
        self.spans = self.spans.saturating_add(1);
        if self.prim_ids {
            let ids = self.ids.get(..n.saturating_mul(4)).unwrap_or(&[]);
            tx.send(&Msg::PixelSpan { frame, y, x0, count, encoding: PixelEncoding::PrimId32, data: ids }, out)?;
            self.spans = self.spans.saturating_add(1);
        }
        Ok(())
    }

    /// Spans sent so far in this frame (colour and prim-id spans).
    pub fn spans(&self) -> u32 {
        self.spans
    }

    /// Ends the frame: returns (spans sent, CRC-32 of the decoded RGB888 pixels). Call after
    /// the last [`flush`](Self::flush).
    pub fn finish(&mut self) -> (u32, u32) {
        (self.spans, core::mem::take(&mut self.crc).finalize())
    }
}

/// Frame helpers shared by the tests of every module that writes frames.
#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
pub(crate) mod tests {
    use super::*;
    use gridrt_shared::frame::{crc32, FeedResult, FrameAccumulator};

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
                let Msg::PixelSpan { frame, y, x0, count, encoding, data } = Msg::decode(*kind, payload).unwrap()
                else {
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
                        let n =
                            (if rng.gen_bool(0.5) { rng.gen_range(1..4) } else { rng.gen_range(1..400) }).min(w - x);
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
}
