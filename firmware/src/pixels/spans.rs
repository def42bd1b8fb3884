//! The span encoder: [`SpanEncoder`] packs a frame's pixels into `PixelSpan` messages of one
//! row segment each (plus `PrimId32` spans when asked) and keeps the running CRC-32 of the
//! image; the span limits.

use embedded_io::Write;
use gridrt_shared::frame::{Crc32Digest, MAX_PAYLOAD};
use gridrt_shared::msg::{Msg, MsgError, PixelEncoding};
use gridrt_shared::pixel::{self, RleEncoder, RLE_MAX_FINISH_BYTES, RLE_MAX_PUSH_BYTES};

use super::tx::{FrameTx, TxError};

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
    /// One more pixel surely fits while `len < room_end` (from `data_limit` and the encoding).
    room_end: usize,
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
            room_end: 0,
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
        self.set_data_limit(0);
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
        let need = match self.encoding.fixed_bytes_per_pixel() {
            Some(bpp) => bpp,
            None => RLE_MAX_PUSH_BYTES + RLE_MAX_FINISH_BYTES,
        };
        // `len + need <= data_limit`, as one comparison per pixel.
        self.room_end = self.data_limit.saturating_add(1).saturating_sub(need);
    }

    /// Adds pixel (x, y). A pixel that does not continue the pending span (other row, gap), a
    /// full span or a full data buffer flushes the pending span first. Inline: a call cost the
    /// render loop about 25 instructions per traced pixel (its saves and arguments), for
    /// 1.4 KiB of code at its six call sites.
    #[inline(always)]
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
        if !(continues && self.count < self.span_len && self.len < self.room_end) {
            self.restart(x, y, tx, out)?;
        }
        let at = self.len;
        let written = match self.encoding {
            PixelEncoding::Rgb565 => {
                let v = pixel::rgb565_pack(rgb);
                if let Some(dst) = self.data.get_mut(at..).and_then(|d| d.get_mut(..2)) {
                    dst.copy_from_slice(&v.to_le_bytes());
                }
                self.crc.update_rgb(pixel::rgb565_unpack(v));
                2
            }
            PixelEncoding::Rle => {
                self.crc.update_rgb(rgb);
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
        // Both stay below their buffers' sizes (`room_end`, `span_len`).
        self.len = self.len.saturating_add(written);
        if self.prim_ids {
            if let Some(dst) = self.ids.chunks_exact_mut(4).nth(self.count) {
                dst.copy_from_slice(&prim.to_le_bytes());
            }
        }
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Sends the pending span, if any, and starts the next at (x, y).
    #[inline(never)]
    fn restart<W: Write + ?Sized>(&mut self, x: u16, y: u16, tx: &mut FrameTx, out: &mut W) -> Result<(), TxError> {
        self.flush(tx, out)?;
        self.y = y;
        self.x0 = x;
        Ok(())
    }

    /// Adds `n` pixels of colour `rgb` and primitive `prim` from (x, y) rightwards: the pixels
    /// of `n` [`push`](Self::push)es, and for `Rle` without primitive ids at the cost of
    /// one per span (the run is encoded at once and its CRC taken 16 pixels per step);
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
            self.crc.update_rgb_run(rgb, k);
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
