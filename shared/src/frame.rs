//! UART frames: COBS-delimited, versioned, sequence-numbered and CRC-32 checked.
//!
//! A frame on the wire is `COBS(header ‖ payload ‖ crc32) ‖ 0x00` (SPEC.md §2):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | message type |
//! | 1 | 1 | protocol version ([`crate::PROTOCOL_VERSION`]) |
//! | 2 | 2 | sequence number, LE |
//! | 4 | 2 | payload length, LE, ≤ [`MAX_PAYLOAD`] |
//! | 6 | len | payload |
//! | 6+len | 4 | CRC-32/ISO-HDLC of bytes `0..6+len`, LE |
//!
//! Reassembly uses [`FrameAccumulator`], a fixed-capacity buffer that resynchronises at the
//! next `0x00` after noise and reports every outcome through [`FeedResult`].

// Link-facing: every index and every sum on received values is checked (ARCHITECTURE.md).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use core::ops::ControlFlow;

use crate::bytes::Reader;
pub use crate::crc::{crc32, Crc32Digest};
use crate::PROTOCOL_VERSION;

/// Largest payload a frame may carry.
pub const MAX_PAYLOAD: usize = 2048;
/// Header bytes before the payload.
pub const HEADER_LEN: usize = 6;
/// CRC bytes after the payload.
pub const CRC_LEN: usize = 4;
/// Largest frame before COBS encoding.
pub const MAX_RAW: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;
/// Largest frame on the wire, COBS overhead and the `0x00` delimiter included.
pub const MAX_ENCODED: usize = MAX_RAW + MAX_RAW / 254 + 2;

/// CRC-32 of a whole valid raw frame (`body ‖ crc_le`), whatever the body.
pub const CRC_OF_VALID_RAW: u32 = 0x2144_DF1C;
/// Longest raw frame whose single flipped bit the accumulator corrects: a body of at most
/// 2974 bits, where CRC-32/ISO-HDLC has Hamming distance 5, so a frame with one flipped bit
/// is one bit from exactly one valid frame and frames with two or three flipped bits are
/// never "corrected" (SPEC.md §2.5).
pub const CORRECTABLE_RAW: usize = 2974 / 8 + CRC_LEN;

/// Everything that can go wrong while encoding or decoding a frame.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The payload is longer than [`MAX_PAYLOAD`].
    EncodePayloadTooLarge,
    /// The output buffer cannot hold the encoded frame.
    EncodeBufferTooSmall,
    /// The bytes between two delimiters are not valid COBS.
    DecodeBadCobs,
    /// The frame is shorter than a header plus CRC.
    DecodeTruncated,
    /// The header's length field disagrees with the bytes received.
    DecodeBadLength,
    /// The CRC does not match: the frame was corrupted on the line.
    DecodeBadCrc,
    /// The peer speaks another protocol version.
    DecodeBadVersion,
    /// More bytes arrived before a delimiter than the accumulator can hold.
    DecodeOversize,
}

impl FrameError {
    /// Error number used in `Error.detail` (SPEC.md §3.9): declaration order, from 1.
    pub const fn code(self) -> u32 {
        match self {
            Self::EncodePayloadTooLarge => 1,
            Self::EncodeBufferTooSmall => 2,
            Self::DecodeBadCobs => 3,
            Self::DecodeTruncated => 4,
            Self::DecodeBadLength => 5,
            Self::DecodeBadCrc => 6,
            Self::DecodeBadVersion => 7,
            Self::DecodeOversize => 8,
        }
    }
}

impl FrameError {
    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::EncodePayloadTooLarge => "payload larger than MAX_PAYLOAD",
            Self::EncodeBufferTooSmall => "output buffer too small for the encoded frame",
            Self::DecodeBadCobs => "invalid COBS encoding",
            Self::DecodeTruncated => "frame shorter than header and CRC",
            Self::DecodeBadLength => "length field disagrees with frame size",
            Self::DecodeBadCrc => "CRC mismatch",
            Self::DecodeBadVersion => "unsupported protocol version",
            Self::DecodeOversize => "frame larger than the receive buffer",
        }
    }
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for FrameError {}

/// A decoded, CRC-verified frame borrowed from the accumulator's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    /// Message type byte (see [`crate::msg::MsgType`]).
    pub kind: u8,
    /// Sender's sequence number.
    pub seq: u16,
    /// Payload bytes.
    pub payload: &'a [u8],
}

/// Encodes one frame into `out` and returns the number of bytes written, delimiter included.
///
/// Header, payload and CRC go through the COBS encoder as they are, without a raw copy of
/// the frame; the bytes are those of `cobs::encode` of the raw frame.
pub fn encode_frame(kind: u8, seq: u16, payload: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    if payload.len() > MAX_PAYLOAD {
        return Err(FrameError::EncodePayloadTooLarge);
    }
    // ≤ MAX_RAW: no overflow.
    let raw_len = HEADER_LEN.saturating_add(payload.len()).saturating_add(CRC_LEN);
    if out.len() <= cobs::max_encoding_length(raw_len) {
        return Err(FrameError::EncodeBufferTooSmall);
    }
    let ([s0, s1], [l0, l1]) = (seq.to_le_bytes(), (payload.len() as u16).to_le_bytes());
    let header = [kind, PROTOCOL_VERSION, s0, s1, l0, l1];
    let mut crc = Crc32Digest::default();
    crc.update(&header);
    crc.update(payload);
    let mut enc = CobsWriter::new(out);
    enc.push(&header);
    enc.push(payload);
    enc.push(&crc.finalize().to_le_bytes());
    let n = enc.finish().ok_or(FrameError::EncodeBufferTooSmall)?;
    *out.get_mut(n).ok_or(FrameError::EncodeBufferTooSmall)? = 0;
    Ok(n.saturating_add(1))
}

/// A COBS encoder over data pushed in pieces, writing straight into its output: the bytes of
/// `cobs::encode` of the concatenated pieces (a final block of 254 non-zero bytes gets no
/// empty block after it) for any non-empty data.
struct CobsWriter<'a> {
    out: &'a mut [u8],
    /// Where the current block's code byte goes.
    code_at: usize,
    /// The current block's code: 1 + its non-zero bytes.
    code: u8,
    /// Where the next data byte goes.
    at: usize,
    /// The last byte closed a full block.
    closed: bool,
    /// A write fell outside `out`.
    overflow: bool,
}

impl<'a> CobsWriter<'a> {
    fn new(out: &'a mut [u8]) -> Self {
        Self { out, code_at: 0, code: 1, at: 1, closed: false, overflow: false }
    }

    #[inline(always)]
    fn set(&mut self, at: usize, b: u8) {
        match self.out.get_mut(at) {
            Some(slot) => *slot = b,
            None => self.overflow = true,
        }
    }

    /// Starts the next block after the byte at `at - 1`.
    #[inline(always)]
    fn close(&mut self) {
        self.set(self.code_at, self.code);
        self.code_at = self.at;
        // `at` stays ≤ out.len() + 1 (every write is checked), far from `usize::MAX`.
        self.at = self.at.saturating_add(1);
        self.code = 1;
    }

    fn push(&mut self, data: &[u8]) {
        for &b in data {
            if b == 0 {
                self.close();
                self.closed = false;
            } else {
                self.set(self.at, b);
                self.at = self.at.saturating_add(1);
                self.code = self.code.saturating_add(1);
                if self.code == 0xFF {
                    self.close();
                    self.closed = true;
                }
            }
        }
    }

    /// The encoded length, `None` when it did not fit.
    fn finish(mut self) -> Option<usize> {
        if self.closed && self.code == 1 {
            // The data ended with a full block: no empty block after it.
            self.at = self.code_at;
        } else {
            self.set(self.code_at, self.code);
        }
        (!self.overflow).then_some(self.at)
    }
}

/// Corrects one flipped bit of a COBS-decoded frame of at most [`CORRECTABLE_RAW`] bytes
/// whose CRC does not match: finds the bit whose flip makes the frame's CRC syndrome vanish
/// and flips it back. Returns true when it corrected a bit; false (and `raw` unchanged) when
/// the CRC matches, the frame is longer, or no single bit explains the syndrome.
pub fn correct_single_bit(raw: &mut [u8]) -> bool {
    /// CRC-32/ISO-HDLC polynomial, reflected.
    const POLY: u32 = 0xEDB8_8320;
    if raw.len() > CORRECTABLE_RAW {
        return false;
    }
    // The CRC is affine in the frame, so the syndrome is the CRC (zero init and xorout) of
    // the error pattern alone: for a single bit at processing position p of L bits, the
    // polynomial shifted through the L − 1 − p zero bits after it.
    let syndrome = crc32(raw) ^ CRC_OF_VALID_RAW;
    if syndrome == 0 {
        return false;
    }
    let bits = raw.len().saturating_mul(8);
    let mut s = POLY;
    for after in 0..bits {
        if s == syndrome {
            // Reflected CRC: bit 0 of each byte goes first.
            let p = bits.saturating_sub(1).saturating_sub(after);
            if let Some(byte) = raw.get_mut(p / 8) {
                *byte ^= 1 << (p % 8);
                return true;
            }
            return false;
        }
        s = if s & 1 == 1 { (s >> 1) ^ POLY } else { s >> 1 };
    }
    false
}

/// Validates a COBS-decoded frame (header, length, CRC, version).
pub fn parse_raw(raw: &[u8]) -> Result<Frame<'_>, FrameError> {
    let body_len = raw.len().checked_sub(CRC_LEN).filter(|&n| n >= HEADER_LEN).ok_or(FrameError::DecodeTruncated)?;
    let (body, crc_bytes) = raw.split_at(body_len);
    let mut r = Reader::new(body);
    let t = |_| FrameError::DecodeTruncated;
    let [kind, version] = r.array::<2>().map_err(t)?;
    let seq = r.u16().map_err(t)?;
    let len = r.u16().map_err(t)? as usize;
    let payload = r.rest();
    if len > MAX_PAYLOAD || len != payload.len() {
        return Err(FrameError::DecodeBadLength);
    }
    let crc = Reader::new(crc_bytes).u32().map_err(t)?;
    if crc32(body) != crc {
        return Err(FrameError::DecodeBadCrc);
    }
    if version != PROTOCOL_VERSION {
        return Err(FrameError::DecodeBadVersion);
    }
    Ok(Frame { kind, seq, payload })
}

/// Outcome of [`FrameAccumulator::feed`]. Each variant hands back the unconsumed input.
#[derive(Debug, PartialEq, Eq)]
pub enum FeedResult<'buf, 'input> {
    /// All input was consumed; no frame is complete yet.
    Consumed,
    /// A delimiter ended a frame that did not fit the buffer; it was dropped.
    Overflow {
        /// Input after that delimiter.
        rest: &'input [u8],
    },
    /// A delimiter ended bytes that are not a valid frame (noise, corruption).
    BadFrame {
        /// Why the frame was rejected.
        error: FrameError,
        /// Input after that delimiter.
        rest: &'input [u8],
    },
    /// A valid frame.
    Frame {
        /// The frame, borrowed from the accumulator until the next `feed`.
        frame: Frame<'buf>,
        /// Input after the frame's delimiter.
        rest: &'input [u8],
    },
}

/// A frame or a rejected one, as [`FrameAccumulator::feed_all`] hands them out.
#[derive(Debug, PartialEq, Eq)]
pub enum Received<'buf> {
    /// A valid frame, borrowed from the accumulator.
    Frame(Frame<'buf>),
    /// Bytes up to a delimiter that are not a valid frame; one that did not fit the buffer
    /// is [`FrameError::DecodeOversize`].
    Bad(FrameError),
}

/// Fixed-capacity reassembly buffer for a COBS byte stream.
///
/// Bytes are buffered up to the next `0x00`. Empty frames (repeated delimiters) are skipped
/// silently; they are how a sender flushes a receiver that may hold noise.
///
/// # Example
///
/// Bytes go in as they arrive; a frame comes out at its delimiter. A corrupted byte makes its
/// frame an error, and the accumulator takes up again at the next frame.
///
/// ```
/// use gridrt_shared::frame::{encode_frame, FeedResult, FrameAccumulator, FrameError, MAX_ENCODED};
///
/// // Hello (type 0x01), sequence number 7, payload `01 00 00 00`, on the wire:
/// let mut buf = [0u8; MAX_ENCODED];
/// let n = encode_frame(0x01, 7, &[0x01, 0x00, 0x00, 0x00], &mut buf)?;
/// let wire = &buf[..n];
/// assert_eq!(wire, [0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00]);
///
/// let mut acc = FrameAccumulator::<MAX_ENCODED>::new();
/// assert_eq!(acc.feed(&wire[..6]), FeedResult::Consumed); // no delimiter yet
/// let FeedResult::Frame { frame, rest } = acc.feed(&wire[6..]) else { return Err(FrameError::DecodeBadCrc) };
/// assert_eq!((frame.kind, frame.seq, frame.payload), (0x01, 7, &[0x01, 0x00, 0x00, 0x00][..]));
/// assert!(rest.is_empty());
///
/// // A corrupted CRC byte (eight bits: one flipped bit would be corrected), then the frame again.
/// let mut noisy = wire.to_vec();
/// noisy[11] ^= 0xFF;
/// noisy.extend_from_slice(wire);
/// let FeedResult::BadFrame { error, rest } = acc.feed(&noisy) else { return Err(FrameError::DecodeBadCrc) };
/// assert_eq!((error, rest), (FrameError::DecodeBadCrc, wire));
/// // Resynchronised at the delimiter: the next frame comes through.
/// assert!(matches!(acc.feed(rest), FeedResult::Frame { frame, .. } if frame.seq == 7));
/// # Ok::<(), FrameError>(())
/// ```
#[derive(Debug)]
pub struct FrameAccumulator<const N: usize = MAX_ENCODED> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
    corrected: u32,
}

impl<const N: usize> Default for FrameAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameAccumulator<N> {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self { buf: [0; N], len: 0, overflowed: false, corrected: 0 }
    }

    /// Frames accepted after correcting one flipped bit, since the accumulator was made
    /// (wrapping).
    pub fn corrected(&self) -> u32 {
        self.corrected
    }

    /// Drops any partial frame, e.g. after a link reset.
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }

    /// True when bytes of an unfinished frame are buffered.
    pub fn has_partial(&self) -> bool {
        self.len > 0 || self.overflowed
    }

    /// Feeds bytes and returns at the first complete frame, error, or end of input.
    pub fn feed<'me, 'input>(&'me mut self, input: &'input [u8]) -> FeedResult<'me, 'input> {
        let mut input = input;
        // Each round ends at a delimiter, so there are at most as many rounds as bytes.
        for _ in 0..=input.len() {
            // The bytes up to the next delimiter go into the buffer in one copy (a byte loop
            // cost the soft-core 20 instructions a byte).
            let Some(end) = input.iter().position(|&b| b == 0) else {
                self.append(input);
                return FeedResult::Consumed;
            };
            self.append(input.get(..end).unwrap_or(&[]));
            let rest = input.get(end.saturating_add(1)..).unwrap_or(&[]);
            if self.overflowed {
                self.reset();
                return FeedResult::Overflow { rest };
            }
            if self.len == 0 {
                input = rest;
                continue;
            }
            let len = core::mem::replace(&mut self.len, 0);
            let Some(encoded) = self.buf.get_mut(..len) else {
                return FeedResult::BadFrame { error: FrameError::DecodeOversize, rest };
            };
            let Ok(n) = cobs::decode_in_place(encoded) else {
                return FeedResult::BadFrame { error: FrameError::DecodeBadCobs, rest };
            };
            let raw = encoded.get_mut(..n).unwrap_or(&mut []);
            // A flipped bit of the length field fails check 3 before the CRC: both may be one
            // flipped bit the CRC can locate (SPEC.md §2.5).
            let first = parse_raw(raw).err();
            let corrected = matches!(first, Some(FrameError::DecodeBadCrc | FrameError::DecodeBadLength))
                && correct_single_bit(raw);
            if corrected {
                self.corrected = self.corrected.wrapping_add(1);
            }
            return match parse_raw(raw) {
                Ok(frame) => FeedResult::Frame { frame, rest },
                Err(error) => {
                    FeedResult::BadFrame { error: if corrected { error } else { first.unwrap_or(error) }, rest }
                }
            };
        }
        FeedResult::Consumed
    }

    /// Buffers `bytes` (no delimiter among them); past the capacity the frame is marked
    /// overflowed and dropped at its delimiter.
    fn append(&mut self, bytes: &[u8]) {
        if self.overflowed {
            return;
        }
        let end = self.len.checked_add(bytes.len());
        match end.and_then(|e| Some((e, self.buf.get_mut(self.len..e)?))) {
            Some((e, slot)) => {
                slot.copy_from_slice(bytes);
                self.len = e;
            }
            None => self.overflowed = true,
        }
    }

    /// Feeds all of `input`, handing every frame and every rejected frame to `on`, in order.
    /// Returns `on`'s value when it breaks (the rest of `input` is dropped), `None` when the
    /// input is used up (a partial frame waits for the next call).
    pub fn feed_all<B>(&mut self, input: &[u8], mut on: impl FnMut(Received<'_>) -> ControlFlow<B>) -> Option<B> {
        let mut input = input;
        // Each round consumes at least one byte (up to a delimiter), so this bound is never hit.
        for _ in 0..=input.len() {
            let (received, rest) = match self.feed(input) {
                FeedResult::Consumed => return None,
                FeedResult::Overflow { rest } => (Received::Bad(FrameError::DecodeOversize), rest),
                FeedResult::BadFrame { error, rest } => (Received::Bad(error), rest),
                FeedResult::Frame { frame, rest } => (Received::Frame(frame), rest),
            };
            if let ControlFlow::Break(b) = on(received) {
                return Some(b);
            }
            if rest.is_empty() {
                return None;
            }
            input = rest;
        }
        None
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    fn encode(kind: u8, seq: u16, payload: &[u8]) -> std::vec::Vec<u8> {
        let mut out = [0u8; MAX_ENCODED];
        let n = encode_frame(kind, seq, payload, &mut out).unwrap();
        out[..n].to_vec()
    }

    /// SPEC.md §2.3 worked example: a Hello frame (type 0x01, seq 7, payload 01 00 00 00).
    #[test]
    fn golden_hello_frame_bytes() {
        let wire = encode(0x01, 7, &[0x01, 0x00, 0x00, 0x00]);
        let raw_crc = crc32(&[0x01, 0x01, 0x07, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00]);
        assert_eq!(raw_crc, 0x32DB_3B61, "CRC of the worked example");
        assert_eq!(
            wire,
            [0x04, 0x01, 0x01, 0x07, 0x02, 0x04, 0x02, 0x01, 0x01, 0x01, 0x05, 0x61, 0x3B, 0xDB, 0x32, 0x00]
        );
    }

    #[test]
    fn accumulator_returns_frame_and_rest() {
        let mut wire = encode(0x21, 1, b"abc");
        wire.extend_from_slice(&encode(0x22, 2, b""));
        let mut acc = FrameAccumulator::<64>::new();
        let rest = match acc.feed(&wire) {
            FeedResult::Frame { frame, rest } => {
                assert_eq!((frame.kind, frame.seq, frame.payload), (0x21, 1, &b"abc"[..]));
                rest
            }
            other => panic!("{other:?}"),
        };
        match acc.feed(rest) {
            FeedResult::Frame { frame, rest } => {
                assert_eq!((frame.kind, frame.seq, frame.payload.len(), rest.len()), (0x22, 2, 0, 0));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn feed_all_hands_out_frames_and_rejects_in_order_and_stops_where_told() {
        // An oversize run, a good frame, noise, a good frame, a partial frame.
        let mut wire = vec![0x55u8; 100];
        wire.push(0);
        wire.extend_from_slice(&encode(0x21, 1, b"abc"));
        wire.extend_from_slice(&[0x07, 0x07, 0]);
        wire.extend_from_slice(&encode(0x22, 2, b""));
        let partial = encode(0x23, 3, b"xy");
        wire.extend_from_slice(&partial[..4]);
        let mut acc = FrameAccumulator::<32>::new();
        let mut seen = Vec::new();
        let r: Option<()> = acc.feed_all(&wire, |r| {
            seen.push(match r {
                Received::Frame(f) => Ok((f.kind, f.seq, f.payload.to_vec())),
                Received::Bad(e) => Err(e),
            });
            ControlFlow::Continue(())
        });
        assert_eq!(r, None);
        assert_eq!(
            seen,
            [
                Err(FrameError::DecodeOversize),
                Ok((0x21, 1, b"abc".to_vec())),
                Err(FrameError::DecodeBadCobs),
                Ok((0x22, 2, vec![])),
            ]
        );
        // The partial frame waits; its rest completes it.
        assert!(acc.has_partial());
        let got = acc.feed_all(&partial[4..], |r| match r {
            Received::Frame(f) => ControlFlow::Break(f.seq),
            Received::Bad(e) => panic!("{e:?}"),
        });
        assert_eq!(got, Some(3));
        // A break drops the rest of the input.
        let mut two = encode(0x21, 4, b"");
        two.extend_from_slice(&encode(0x21, 5, b""));
        let first = acc.feed_all(&two, |r| match r {
            Received::Frame(f) => ControlFlow::Break(f.seq),
            Received::Bad(e) => panic!("{e:?}"),
        });
        assert_eq!((first, acc.has_partial()), (Some(4), false));
    }

    #[test]
    fn decoder_rejects_bad_crc() {
        let mut wire = encode(0x01, 7, &[1, 0, 0, 0]);
        wire[3] ^= 0x11; // flip two bits of the sequence number
        let mut acc = FrameAccumulator::<64>::new();
        assert!(matches!(acc.feed(&wire), FeedResult::BadFrame { error: FrameError::DecodeBadCrc, .. }));
        assert_eq!(acc.corrected(), 0);
    }

    /// A raw frame of exactly [`CORRECTABLE_RAW`] bytes, payload from a seeded generator.
    fn longest_correctable_raw() -> Vec<u8> {
        let payload: Vec<u8> = (0..CORRECTABLE_RAW - HEADER_LEN - CRC_LEN).map(|i| (i * 37 + 11) as u8).collect();
        let mut raw = vec![0x13, 1, 9, 0];
        raw.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        raw.extend_from_slice(&payload);
        let crc = crc32(&raw);
        raw.extend_from_slice(&crc.to_le_bytes());
        raw
    }

    #[test]
    fn every_single_flipped_bit_of_a_correctable_frame_is_corrected() {
        let good = longest_correctable_raw();
        assert_eq!(good.len(), CORRECTABLE_RAW);
        assert_eq!(crc32(&good), CRC_OF_VALID_RAW);
        for bit in 0..good.len() * 8 {
            let mut raw = good.clone();
            raw[bit / 8] ^= 1 << (bit % 8);
            assert!(correct_single_bit(&mut raw), "bit {bit}");
            assert_eq!(raw, good, "bit {bit}");
        }
        let mut raw = good.clone();
        assert!(!correct_single_bit(&mut raw), "a valid frame is left alone");
    }

    #[test]
    fn two_or_three_flipped_bits_are_never_miscorrected() {
        use rand::{Rng, SeedableRng};
        let good = longest_correctable_raw();
        let bits = good.len() * 8;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for trial in 0..4000 {
            let mut raw = good.clone();
            let mut flipped = Vec::new();
            while flipped.len() < 2 + trial % 2 {
                let b = rng.gen_range(0..bits);
                if !flipped.contains(&b) {
                    flipped.push(b);
                    raw[b / 8] ^= 1 << (b % 8);
                }
            }
            let before = raw.clone();
            assert!(!correct_single_bit(&mut raw), "bits {flipped:?}");
            assert_eq!(raw, before);
        }
    }

    #[test]
    fn longer_frames_are_not_corrected() {
        let mut good = longest_correctable_raw();
        good.truncate(good.len() - CRC_LEN);
        good.push(0x55);
        good[4] += 1;
        let crc = crc32(&good);
        good.extend_from_slice(&crc.to_le_bytes());
        let mut raw = good.clone();
        raw[20] ^= 0x04;
        assert!(!correct_single_bit(&mut raw));
        assert_eq!(parse_raw(&raw), Err(FrameError::DecodeBadCrc));
    }

    /// SPEC.md §2.5 worked example: the §2.3 Hello frame with bit 4 of wire byte 3 (the
    /// sequence number's low byte) flipped arrives as seq 7 all the same, as does one with a
    /// flipped bit of the length field.
    #[test]
    fn accumulator_corrects_one_flipped_bit_of_sequence_or_length() {
        for (at, bit) in [(3, 0x10), (5, 0x02)] {
            let mut wire = encode(0x01, 7, &[1, 0, 0, 0]);
            wire[at] ^= bit;
            let mut acc = FrameAccumulator::<64>::new();
            match acc.feed(&wire) {
                FeedResult::Frame { frame, .. } => {
                    assert_eq!((frame.kind, frame.seq, frame.payload), (0x01, 7, &[1u8, 0, 0, 0][..]))
                }
                other => panic!("{other:?}"),
            }
            assert_eq!(acc.corrected(), 1);
        }
    }

    #[test]
    fn decoder_rejects_truncated_frame() {
        let wire = encode(0x01, 7, &[1, 0, 0, 0]);
        let mut cut = wire[..6].to_vec();
        cut.push(0);
        let mut acc = FrameAccumulator::<64>::new();
        assert!(matches!(acc.feed(&cut), FeedResult::BadFrame { .. }));
    }

    #[test]
    fn decoder_rejects_oversize_frame_then_resynchronises() {
        let mut wire = vec![0x55u8; 100];
        wire.push(0);
        wire.extend_from_slice(&encode(0x02, 9, b"ok"));
        let mut acc = FrameAccumulator::<32>::new();
        let rest = match acc.feed(&wire) {
            FeedResult::Overflow { rest } => rest,
            other => panic!("{other:?}"),
        };
        assert!(matches!(acc.feed(rest), FeedResult::Frame { frame: Frame { kind: 0x02, seq: 9, .. }, .. }));
    }

    #[test]
    fn encoder_rejects_oversize_payload() {
        let mut out = [0u8; MAX_ENCODED];
        let big = [0u8; MAX_PAYLOAD + 1];
        assert_eq!(encode_frame(1, 0, &big, &mut out), Err(FrameError::EncodePayloadTooLarge));
        let mut small = [0u8; 8];
        assert_eq!(encode_frame(1, 0, &[1, 2, 3], &mut small), Err(FrameError::EncodeBufferTooSmall));
    }

    #[test]
    fn decoder_rejects_length_field_mismatch_and_wrong_version() {
        let mut raw = [0x01, 0x01, 0x07, 0x00, 0x05, 0x00, 1, 0, 0, 0, 0, 0, 0, 0];
        let crc = crc32(&raw[..10]);
        raw[10..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(parse_raw(&raw), Err(FrameError::DecodeBadLength));
        let mut raw = [0x01, 0x09, 0x07, 0x00, 0x04, 0x00, 1, 0, 0, 0, 0, 0, 0, 0];
        let crc = crc32(&raw[..10]);
        raw[10..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(parse_raw(&raw), Err(FrameError::DecodeBadVersion));
    }

    /// The COBS writer's bytes are `cobs::encode`'s, around every block boundary.
    #[test]
    fn cobs_writer_matches_the_cobs_crate() {
        let mut cases: Vec<Vec<u8>> = Vec::new();
        for n in [1, 2, 253, 254, 255, 256, 507, 508, 509, 600] {
            cases.push(vec![7; n]);
            let mut v = vec![7; n];
            v.push(0);
            cases.push(v.clone());
            v.insert(0, 0);
            cases.push(v);
        }
        cases.push(vec![0]);
        cases.push(vec![0, 0, 0]);
        for data in &cases {
            let mut want = vec![0u8; cobs::max_encoding_length(data.len())];
            let n = cobs::encode(data, &mut want);
            let mut got = vec![0u8; cobs::max_encoding_length(data.len()) + 1];
            for cut in [0, 1, data.len() / 2, data.len()] {
                let mut w = CobsWriter::new(&mut got);
                w.push(&data[..cut]);
                w.push(&data[cut..]);
                let m = w.finish().unwrap();
                assert_eq!(&got[..m], &want[..n], "len {} cut {cut}", data.len());
            }
            let mut small = vec![0u8; n - 1];
            let mut w = CobsWriter::new(&mut small);
            w.push(data);
            assert_eq!(w.finish(), None, "len {}", data.len());
        }
    }

    proptest::proptest! {
        /// A frame is `cobs::encode(header ‖ payload ‖ crc) ‖ 0`.
        #[test]
        fn frames_are_cobs_of_the_raw_frame(
            kind: u8, seq: u16,
            payload in proptest::collection::vec(proptest::prop_oneof![3 => 1u8..=255, 1 => proptest::strategy::Just(0u8)], 0..700),
        ) {
            let mut raw = vec![kind, PROTOCOL_VERSION];
            raw.extend_from_slice(&seq.to_le_bytes());
            raw.extend_from_slice(&(payload.len() as u16).to_le_bytes());
            raw.extend_from_slice(&payload);
            let crc = crc32(&raw);
            raw.extend_from_slice(&crc.to_le_bytes());
            let mut want = vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
            let n = cobs::encode(&raw, &mut want);
            want.truncate(n);
            want.push(0);
            proptest::prop_assert_eq!(encode(kind, seq, &payload), want);
        }

        /// Frames, noise and frames too long for the buffer come out the same however the
        /// bytes are split into `feed` calls.
        #[test]
        fn any_split_of_the_input_gives_the_same_frames_and_refusals(
            payloads in proptest::collection::vec(proptest::collection::vec(proptest::num::u8::ANY, 0..200), 1..5),
            noise in proptest::collection::vec(1u8..=255, 0..300),
            cuts in proptest::collection::vec(0usize..2000, 0..8),
        ) {
            let mut wire = Vec::new();
            for (i, p) in payloads.iter().enumerate() {
                wire.extend_from_slice(&encode(0x21, i as u16, p));
                if i == 1 {
                    wire.extend_from_slice(&noise);
                    wire.push(0);
                }
            }
            let run = |pieces: &[&[u8]]| {
                let mut acc = FrameAccumulator::<256>::new();
                let mut seen = Vec::new();
                for piece in pieces {
                    let mut input: &[u8] = piece;
                    loop {
                        let rest = match acc.feed(input) {
                            FeedResult::Frame { frame, rest } => { seen.push(Ok((frame.seq, frame.payload.to_vec()))); rest }
                            FeedResult::BadFrame { error, rest } => { seen.push(Err(error)); rest }
                            FeedResult::Overflow { rest } => { seen.push(Err(FrameError::DecodeOversize)); rest }
                            FeedResult::Consumed => break,
                        };
                        input = rest;
                    }
                }
                seen
            };
            let whole = run(&[&wire]);
            let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c % (wire.len() + 1)).collect();
            cuts.sort_unstable();
            let mut pieces = Vec::new();
            let mut at = 0;
            for c in cuts {
                pieces.push(&wire[at..c]);
                at = c;
            }
            pieces.push(&wire[at..]);
            let bytewise: Vec<&[u8]> = wire.chunks(1).collect();
            proptest::prop_assert_eq!(run(&pieces), whole.clone());
            proptest::prop_assert_eq!(run(&bytewise), whole.clone());
            // Every frame that fits came out, in order; a longer one was refused as oversize.
            // Encoded without its delimiter, within the 256-byte buffer.
            let fits = |i: usize, p: &[u8]| encode(0x21, i as u16, p).len() - 1 <= 256;
            let frames: Vec<_> = whole.iter().filter_map(|r| r.as_ref().ok().cloned()).collect();
            let want: Vec<_> = payloads.iter().enumerate().filter(|(i, p)| fits(*i, p)).map(|(i, p)| (i as u16, p.clone())).collect();
            proptest::prop_assert_eq!(frames, want);
        }

        #[test]
        fn any_payload_round_trips_through_noise(
            kind: u8, seq: u16,
            payload in proptest::collection::vec(proptest::num::u8::ANY, 0..300),
            noise in proptest::collection::vec(1u8..=255, 0..40),
        ) {
            let mut wire = noise.clone();
            wire.push(0);
            wire.extend_from_slice(&encode(kind, seq, &payload));
            let mut acc = FrameAccumulator::<1024>::new();
            let mut input: &[u8] = &wire;
            let mut got = None;
            for _ in 0..4 {
                match acc.feed(input) {
                    FeedResult::Frame { frame, .. } => { got = Some((frame.kind, frame.seq, frame.payload.to_vec())); break; }
                    FeedResult::BadFrame { rest, .. } | FeedResult::Overflow { rest } => input = rest,
                    FeedResult::Consumed => break,
                }
            }
            proptest::prop_assert_eq!(got, Some((kind, seq, payload)));
        }
    }
}
