//! Pixel encodings of a `PixelSpan` (SPEC.md §3.7.1): raw RGB888, RGB565, and `Rle`, a
//! lossless run-length + delta byte code that a firmware encodes pixel by pixel in 4 bytes of
//! state and a decoder checks without allocating.
//!
//! | encoding | bytes per pixel | lossless | decoded image (what `FrameEnd`/`RegionEnd` CRCs cover) |
//! |---|---|---|---|
//! | `Rgb888` (0) | 3 | yes | the bytes as sent |
//! | `Rgb565` (1) | 2 | no | each pixel expanded by bit replication ([`rgb565_unpack`]) |
//! | `Rle` (2) | 1/64 … 4 | yes | the decoded bytes |
//!
//! `Rle` op codes (one tag byte, then 0–3 operand bytes; "prev" is the previous pixel of the
//! span, `(0, 0, 0)` before the first; arithmetic wraps modulo 256). The DIFF, LUMA and RGB ops
//! are those of QOI ("The Quite OK Image Format", D. Szablewski, 2021, qoiformat.org); the
//! index and alpha ops are dropped and a 13-bit run is added for long background runs:
//!
//! | tag byte | op | operands | pixel(s) produced |
//! |---|---|---|---|
//! | `00rrrrrr` | RUN | — | prev, `r + 1` times (1..=64) |
//! | `01rrggbb` | DIFF | — | prev + (r − 2, g − 2, b − 2), each delta in −2..=1 |
//! | `10gggggg` | LUMA | `rrrrbbbb` | dg = g − 32 (−32..=31); prev + (dg + r − 8, dg, dg + b − 8) |
//! | `110nnnnn` | RUN_LONG | `nnnnnnnn` | prev, `n + 1` times, n = 13 bits, high bits in the tag (1..=8192) |
//! | `11111110` | RGB | `r g b` | (r, g, b) |
//! | `111xxxxx` other | reserved | | [`PixelError::DecodeBadOpcode`] |
//!
//! A span's data decodes to exactly `count` pixels and ends with the op that produced the last
//! one; anything else is an error (never a guess, never a panic).

// Link-facing: every index and every sum on received values is checked (ARCHITECTURE.md).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// Longest `Rle` RUN count.
pub const RUN_MAX: u16 = 64;
/// Longest `Rle` RUN_LONG count.
pub const RUN_LONG_MAX: u16 = 8192;
/// Most bytes one [`RleEncoder::push`] can write: a pending RUN_LONG (2) and an RGB literal (4).
pub const RLE_MAX_PUSH_BYTES: usize = 6;
/// Most bytes [`RleEncoder::finish`] can write (a pending RUN_LONG).
pub const RLE_MAX_FINISH_BYTES: usize = 2;

const OP_RUN: u8 = 0x00;
const OP_DIFF: u8 = 0x40;
const OP_LUMA: u8 = 0x80;
const OP_RUN_LONG: u8 = 0xC0;
const OP_RGB: u8 = 0xFE;

/// Why encoded pixels were rejected.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelError {
    /// The data ended inside an op or before `count` pixels.
    DecodeTruncated,
    /// A reserved tag byte.
    DecodeBadOpcode,
    /// A run produces more pixels than the span has.
    DecodeRunOverflow,
    /// Bytes follow the op that produced the last pixel, or a fixed-size span has the wrong length.
    DecodeTrailingBytes,
    /// The encoding carries no colour (e.g. `PrimId32`).
    DecodeNotColour,
    /// The output buffer is too small.
    BufferTooSmall,
}

impl core::fmt::Display for PixelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::DecodeTruncated => "pixel data ends early",
            Self::DecodeBadOpcode => "reserved op code in pixel data",
            Self::DecodeRunOverflow => "run longer than the span",
            Self::DecodeTrailingBytes => "bytes after the last pixel",
            Self::DecodeNotColour => "encoding carries no colour",
            Self::BufferTooSmall => "output buffer too small",
        })
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for PixelError {}

/// Packs RGB888 into RGB565 (`r5 << 11 | g6 << 5 | b5`, truncating the low bits).
pub const fn rgb565_pack(p: [u8; 3]) -> u16 {
    ((p[0] as u16 >> 3) << 11) | ((p[1] as u16 >> 2) << 5) | (p[2] as u16 >> 3)
}

/// Expands RGB565 to RGB888 by bit replication (`r8 = r5 << 3 | r5 >> 2`, `g8 = g6 << 2 | g6 >> 4`),
/// so 0 → 0 and full scale → 255.
pub const fn rgb565_unpack(v: u16) -> [u8; 3] {
    let r = ((v >> 11) & 0x1F) as u8;
    let g = ((v >> 5) & 0x3F) as u8;
    let b = (v & 0x1F) as u8;
    [(r << 3) | (r >> 2), (g << 2) | (g >> 4), (b << 3) | (b >> 2)]
}

/// The RGB888 pixel an RGB565 round trip gives (what the host reconstructs).
pub const fn rgb565_quantise(p: [u8; 3]) -> [u8; 3] {
    rgb565_unpack(rgb565_pack(p))
}

/// Streaming `Rle` encoder for one span: 4 bytes of state, no buffer of its own.
///
/// Call [`push`](Self::push) per pixel with room for [`RLE_MAX_PUSH_BYTES`] bytes and
/// [`finish`](Self::finish) at the end of the span with room for [`RLE_MAX_FINISH_BYTES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RleEncoder {
    prev: [u8; 3],
    run: u16,
}

impl Default for RleEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl RleEncoder {
    /// Encoder at the start of a span (prev = black, no run).
    pub const fn new() -> Self {
        Self { prev: [0; 3], run: 0 }
    }

    /// Adds one pixel; returns the bytes written to `out` (0 while a run grows). On
    /// [`PixelError::BufferTooSmall`] nothing was written and the state is unchanged.
    #[inline]
    pub fn push(&mut self, p: [u8; 3], out: &mut [u8]) -> Result<usize, PixelError> {
        if p == self.prev && self.run < RUN_LONG_MAX {
            self.run = self.run.saturating_add(1);
            return Ok(0);
        }
        self.push_ops(p, out)
    }

    /// [`push`](Self::push) when the pixel ends the pending run: the run's op, then the
    /// pixel's (none when it starts the next run), each built in a register and stored
    /// bytewise (no staging buffer to copy).
    fn push_ops(&mut self, p: [u8; 3], out: &mut [u8]) -> Result<usize, PixelError> {
        let (run, run_len) = run_op(self.run);
        let same = p == self.prev;
        let (op, op_len) = if same { (0, 0) } else { change_op(self.prev, p) };
        let n = run_len.saturating_add(op_len);
        let (a, b) = out.get_mut(..n).ok_or(PixelError::BufferTooSmall)?.split_at_mut(run_len);
        put_le(a, run);
        put_le(b, op);
        // A full RUN_LONG was written and the pixel starts the next run, or the pixel changed.
        self.run = u16::from(same);
        self.prev = p;
        Ok(n)
    }

    /// Adds `n` pixels of colour `p`: the same bytes as `n` calls of [`push`](Self::push), at
    /// the cost of one. Writes at most `RLE_MAX_PUSH_BYTES + 2·⌈n / RUN_LONG_MAX⌉` bytes. On
    /// [`PixelError::BufferTooSmall`] the state is unchanged (bytes of `out` may have been
    /// overwritten).
    pub fn push_run(&mut self, p: [u8; 3], n: u32, out: &mut [u8]) -> Result<usize, PixelError> {
        if n == 0 {
            return Ok(0);
        }
        let mut next = *self;
        let mut len = next.push(p, out)?;
        // The other n − 1 pixels repeat `prev`: the run grows, and a full RUN_LONG is
        // written when the next pixel would overflow it (as `push` does).
        let mut left = n.saturating_sub(1);
        while left > 0 {
            if next.run < RUN_LONG_MAX {
                let k = left.min(u32::from(RUN_LONG_MAX.saturating_sub(next.run)));
                next.run = next.run.saturating_add(k as u16);
                left = left.saturating_sub(k);
            } else {
                let tail = out.get_mut(len..).ok_or(PixelError::BufferTooSmall)?;
                len = len.saturating_add(next.flush_run(tail)?);
                next.run = 1;
                left = left.saturating_sub(1);
            }
        }
        *self = next;
        Ok(len)
    }

    /// Ends the span: writes a pending run; returns the bytes written. The encoder is reset
    /// (on [`PixelError::BufferTooSmall`] it is unchanged).
    pub fn finish(&mut self, out: &mut [u8]) -> Result<usize, PixelError> {
        let n = self.flush_run(out)?;
        *self = Self::new();
        Ok(n)
    }

    /// Writes the pending run's op and clears the run (unchanged on an error).
    fn flush_run(&mut self, out: &mut [u8]) -> Result<usize, PixelError> {
        let (w, n) = run_op(self.run);
        put_le(out.get_mut(..n).ok_or(PixelError::BufferTooSmall)?, w);
        self.run = 0;
        Ok(n)
    }
}

/// The op of a run of `run` pixels (RUN or RUN_LONG; none for 0) as little-endian bytes, and
/// its length.
fn run_op(run: u16) -> (u32, usize) {
    // run ≥ 1 past the first test, so `run - 1` cannot wrap.
    let n = run.saturating_sub(1);
    if run == 0 {
        (0, 0)
    } else if run <= RUN_MAX {
        (u32::from(OP_RUN | n as u8), 1)
    } else {
        (u32::from_le_bytes([OP_RUN_LONG | (n >> 8) as u8, n as u8, 0, 0]), 2)
    }
}

/// The shortest of DIFF, LUMA, RGB for `p` after `prev`, as little-endian bytes, and its length.
fn change_op(prev: [u8; 3], p: [u8; 3]) -> (u32, usize) {
    let ([r, g, b], [pr, pg, pb]) = (p, prev);
    let (dr, dg, db) = (r.wrapping_sub(pr) as i8, g.wrapping_sub(pg) as i8, b.wrapping_sub(pb) as i8);
    // The biases below are added only to differences already range-checked, so the wrapping
    // adds never wrap.
    if (-2..=1).contains(&dr) && (-2..=1).contains(&dg) && (-2..=1).contains(&db) {
        let bias = |d: i8| d.wrapping_add(2) as u8;
        return (u32::from(OP_DIFF | (bias(dr) << 4) | (bias(dg) << 2) | bias(db)), 1);
    }
    let (dr_dg, db_dg) = (dr.wrapping_sub(dg), db.wrapping_sub(dg));
    if (-32..=31).contains(&dg) && (-8..=7).contains(&dr_dg) && (-8..=7).contains(&db_dg) {
        let (g8, rb) = (dg.wrapping_add(32) as u8, ((dr_dg.wrapping_add(8) as u8) << 4) | db_dg.wrapping_add(8) as u8);
        return (u32::from_le_bytes([OP_LUMA | g8, rb, 0, 0]), 2);
    }
    (u32::from_le_bytes([OP_RGB, r, g, b]), 4)
}

/// Stores the low `dst.len()` (≤ 4) bytes of `w`, little-endian: one store per byte for
/// the lengths an op has (a loop over the bytes staged `w` in memory, ~7 instructions a byte).
#[inline(always)]
fn put_le(dst: &mut [u8], w: u32) {
    let [b0, b1, b2, b3] = w.to_le_bytes();
    match dst {
        [d0] => *d0 = b0,
        [d0, d1] => (*d0, *d1) = (b0, b1),
        [d0, d1, d2, d3] => (*d0, *d1, *d2, *d3) = (b0, b1, b2, b3),
        _ => {
            for (d, b) in dst.iter_mut().zip([b0, b1, b2, b3]) {
                *d = b;
            }
        }
    }
}

/// Decodes `Rle` data of `count` pixels, calling `emit(pixel, repeat)` for each op.
fn rle_walk(count: usize, data: &[u8], mut emit: impl FnMut([u8; 3], usize)) -> Result<(), PixelError> {
    let mut prev = [0u8; 3];
    let mut done = 0usize;
    let mut i = 0usize;
    let byte = |at: usize| data.get(at).copied().ok_or(PixelError::DecodeTruncated);
    // Every op consumes at least one byte, so the loop is bounded by the data length; `i` and
    // `done` never exceed `data.len()` and `count`, so their sums cannot overflow.
    while done < count {
        let tag = byte(i)?;
        let [pr, pg, pb] = prev;
        let (px, n, used) = match tag {
            t if t & 0xC0 == OP_RUN => (prev, ((t & 0x3F) as usize).wrapping_add(1), 1),
            t if t & 0xC0 == OP_DIFF => {
                let f = |s: u8| ((t >> s) & 3).wrapping_sub(2);
                ([pr.wrapping_add(f(4)), pg.wrapping_add(f(2)), pb.wrapping_add(f(0))], 1, 1)
            }
            t if t & 0xC0 == OP_LUMA => {
                let b = byte(i.saturating_add(1))?;
                let dg = (t & 0x3F).wrapping_sub(32);
                let dr = dg.wrapping_add((b >> 4).wrapping_sub(8));
                let db = dg.wrapping_add((b & 0x0F).wrapping_sub(8));
                ([pr.wrapping_add(dr), pg.wrapping_add(dg), pb.wrapping_add(db)], 1, 2)
            }
            t if t & 0xE0 == OP_RUN_LONG => {
                let b = byte(i.saturating_add(1))?;
                (prev, ((((t & 0x1F) as usize) << 8) | b as usize).wrapping_add(1), 2)
            }
            OP_RGB => {
                let at = i.saturating_add(1);
                ([byte(at)?, byte(at.saturating_add(1))?, byte(at.saturating_add(2))?], 1, 4)
            }
            _ => return Err(PixelError::DecodeBadOpcode),
        };
        if n > count.saturating_sub(done) {
            return Err(PixelError::DecodeRunOverflow);
        }
        emit(px, n);
        prev = px;
        done = done.saturating_add(n);
        i = i.saturating_add(used);
    }
    if i != data.len() {
        return Err(PixelError::DecodeTrailingBytes);
    }
    Ok(())
}

/// Checks that `Rle` `data` decodes to exactly `count` pixels (used by `Msg::decode`).
pub fn rle_validate(count: usize, data: &[u8]) -> Result<(), PixelError> {
    rle_walk(count, data, |_, _| {})
}

/// Decodes `Rle` data of `count` pixels into `out` (RGB888, `3·count` bytes).
pub fn rle_decode(count: usize, data: &[u8], out: &mut [u8]) -> Result<(), PixelError> {
    let out =
        out.get_mut(..count.checked_mul(3).ok_or(PixelError::BufferTooSmall)?).ok_or(PixelError::BufferTooSmall)?;
    let mut pixels = out.chunks_exact_mut(3);
    rle_walk(count, data, |px, n| {
        // rle_walk never emits more than `count` pixels in total.
        for dst in pixels.by_ref().take(n) {
            dst.copy_from_slice(&px);
        }
    })
}

/// Encodes a whole span with `Rle` into `out`; returns the bytes written.
pub fn rle_encode(pixels: &[[u8; 3]], out: &mut [u8]) -> Result<usize, PixelError> {
    let mut e = RleEncoder::new();
    let mut n = 0usize;
    // Each push writes into the rest of `out`, so `n` stays ≤ out.len().
    for &p in pixels {
        n = n.saturating_add(e.push(p, out.get_mut(n..).ok_or(PixelError::BufferTooSmall)?)?);
    }
    n = n.saturating_add(e.finish(out.get_mut(n..).ok_or(PixelError::BufferTooSmall)?)?);
    Ok(n)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    fn round_trip(px: &[[u8; 3]]) -> Vec<u8> {
        let mut buf = vec![0u8; 4 * px.len() + 8];
        let n = rle_encode(px, &mut buf).unwrap();
        buf.truncate(n);
        let mut out = vec![0u8; 3 * px.len()];
        rle_decode(px.len(), &buf, &mut out).unwrap();
        assert_eq!(out, px.iter().flatten().copied().collect::<Vec<_>>());
        buf
    }

    #[test]
    fn ops_are_chosen_shortest_first() {
        assert_eq!(round_trip(&[[0, 0, 0]]), [0x00]);
        assert_eq!(round_trip(&[[1, 0, 255]]), [0x40 | (3 << 4) | (2 << 2) | 1]);
        assert_eq!(round_trip(&[[10, 12, 9]]), [0x80 | 44, 0x65]);
        assert_eq!(round_trip(&[[200, 0, 0]]), [0xFE, 200, 0, 0]);
        assert_eq!(round_trip(&[[0; 3]; 64]), [0x3F]);
        assert_eq!(round_trip(&[[0; 3]; 65]), [0xC0, 64]);
        assert_eq!(round_trip(&[[0; 3]; 8192]), [0xDF, 0xFF]);
        assert_eq!(round_trip(&[[0; 3]; 8193]), [0xDF, 0xFF, 0x00]);
    }

    #[test]
    fn rgb565_expansion_is_exact_at_the_ends() {
        assert_eq!(rgb565_quantise([0, 0, 0]), [0, 0, 0]);
        assert_eq!(rgb565_quantise([255, 255, 255]), [255, 255, 255]);
        assert_eq!(rgb565_pack([0xFF, 0x00, 0x80]), 0xF810);
        for v in 0..=u16::MAX {
            assert_eq!(rgb565_pack(rgb565_unpack(v)), v);
        }
    }

    proptest::proptest! {
        #[test]
        fn rle_round_trips_and_respects_push_bound(px in proptest::collection::vec(
            proptest::prop_oneof![proptest::strategy::Just([7u8, 7, 7]), proptest::prelude::any::<[u8; 3]>()], 0..600)) {
            let mut e = RleEncoder::new();
            let mut buf = vec![0u8; 6 * px.len() + 2];
            let mut n = 0;
            for &p in &px {
                let w = e.push(p, &mut buf[n..n + RLE_MAX_PUSH_BYTES]).unwrap();
                n += w;
            }
            n += e.finish(&mut buf[n..n + RLE_MAX_FINISH_BYTES]).unwrap();
            let mut out = vec![0u8; 3 * px.len()];
            rle_decode(px.len(), &buf[..n], &mut out).unwrap();
            proptest::prop_assert_eq!(out, px.iter().flatten().copied().collect::<Vec<_>>());
        }

        /// A run pushed at once writes the bytes of its pixels pushed one by one.
        #[test]
        fn rle_run_equals_its_pixels(
            before in proptest::collection::vec(proptest::prop_oneof![proptest::strategy::Just([7u8, 7, 7]), proptest::prelude::any::<[u8; 3]>()], 0..40),
            p in proptest::prop_oneof![proptest::strategy::Just([7u8, 7, 7]), proptest::prelude::any::<[u8; 3]>()],
            n in proptest::prop_oneof![0u32..200, 8100u32..8300, 16_380u32..16_390],
        ) {
            let (mut a, mut b) = (RleEncoder::new(), RleEncoder::new());
            let (mut wa, mut wb) = (Vec::new(), Vec::new());
            let mut buf = [0u8; 64];
            for &q in &before {
                let k = a.push(q, &mut buf).unwrap();
                wa.extend_from_slice(&buf[..k]);
                b = a;
            }
            wb.clone_from(&wa);
            for _ in 0..n {
                let k = a.push(p, &mut buf).unwrap();
                wa.extend_from_slice(&buf[..k]);
            }
            let k = b.push_run(p, n, &mut buf).unwrap();
            proptest::prop_assert!(k <= RLE_MAX_PUSH_BYTES + 2 * n.div_ceil(RUN_LONG_MAX as u32) as usize);
            wb.extend_from_slice(&buf[..k]);
            proptest::prop_assert_eq!(a, b);
            proptest::prop_assert_eq!(wa, wb);
        }

        #[test]
        fn rle_decoder_never_panics(count in 0usize..300, data in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300)) {
            let mut out = vec![0u8; 3 * count];
            let a = rle_decode(count, &data, &mut out);
            proptest::prop_assert_eq!(a, rle_validate(count, &data));
        }
    }
}
