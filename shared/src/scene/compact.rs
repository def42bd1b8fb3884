//! The compact scene stream (SPEC.md §5.12): a scene image coded as word operations — literal
//! words, runs, small deltas against recent words, and a FIFO cache of triangle vertices —
//! decoded as it arrives into exactly the bytes of the image, which then go through
//! [`SceneStream`](super::SceneStream) as if sent raw.
//!
//! ```text
//! header (16 B: "GRTZ", version u16, cache_log2 u8, reserved u8, image_len u32, image_crc u32)
//! ‖ ops until image_len bytes have been produced
//! ```
//!
//! [`Unpacker`] takes the bytes of an upload whatever they are: a stream that does not start
//! with [`COMPACT_MAGIC`] is passed through untouched (a raw image, §5), so the device needs
//! no flag to tell them apart. Its state is fixed: a 32-word history, a partial op of at most
//! [`MAX_OP_LEN`] bytes and a vertex cache of `C` entries (3 words each).

use super::layout::SceneError;
use crate::frame::Crc32Digest;

/// First bytes of a compact stream: `GRTZ`.
pub const COMPACT_MAGIC: [u8; 4] = *b"GRTZ";
/// The compact stream version this build reads.
pub const COMPACT_VERSION: u16 = 1;
/// Bytes of the compact stream header.
pub const COMPACT_HEADER_LEN: usize = 16;
/// Largest `cache_log2` of the format (VREF carries a 13-bit index).
pub const MAX_CACHE_LOG2: u8 = 13;
/// Words of history an op may look back (DELTA reaches `H[32]`).
pub const HISTORY_WORDS: usize = 32;
/// Longest op in bytes: `LIT` of 32 words.
pub const MAX_OP_LEN: usize = 1 + 4 * 32;

/// Op kinds, the top three bits of an op byte (SPEC.md §5.12).
pub mod compact_op {
    /// `p + 1` literal words follow (4 bytes LE each).
    pub const LIT: u8 = 0;
    /// `p + 1` copies of the last word.
    pub const RUN: u8 = 1;
    /// One word: the last word + `p + 1`.
    pub const INC: u8 = 2;
    /// One word: the word `p + 1` back + a zigzag varint.
    pub const DELTA: u8 = 3;
    /// Two words: the word 11 back + `p`, then the word 11 back (a triangle record's prim id and
    /// material after the previous record's).
    pub const TAIL: u8 = 4;
    /// Three words: vertex-cache entry `p << 8 | next byte`.
    pub const VREF: u8 = 5;
    /// Three words, each the word 3 back + a zigzag varint; then cached (`p` must be 0).
    pub const VNEW: u8 = 6;
}

/// Zigzag-decodes `v` (0, −1, 1, −2, … ↔ 0, 1, 2, 3, …).
pub const fn unzigzag(v: u32) -> u32 {
    (v >> 1) ^ (0u32.wrapping_sub(v & 1))
}

/// Zigzag-encodes the wrapping difference `d` (the inverse of [`unzigzag`]).
pub const fn zigzag(d: u32) -> u32 {
    (d << 1) ^ (((d as i32) >> 31) as u32)
}

/// The header of a compact stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CompactHeader {
    /// Vertex-cache entries = `1 << cache_log2`.
    pub cache_log2: u8,
    /// Length of the decoded image in bytes (a multiple of 4).
    pub image_len: u32,
    /// CRC-32 (§2.2) of the decoded image.
    pub image_crc: u32,
}

impl CompactHeader {
    /// The 16 header bytes.
    pub fn to_bytes(&self) -> [u8; COMPACT_HEADER_LEN] {
        let mut b = [0u8; COMPACT_HEADER_LEN];
        let fields: [&[u8]; 5] = [
            &COMPACT_MAGIC,
            &COMPACT_VERSION.to_le_bytes(),
            &[self.cache_log2, 0],
            &self.image_len.to_le_bytes(),
            &self.image_crc.to_le_bytes(),
        ];
        let mut i = 0usize;
        for f in fields {
            for &x in f {
                if let Some(slot) = b.get_mut(i) {
                    *slot = x;
                }
                i = i.saturating_add(1);
            }
        }
        b
    }

    /// Parses and checks the 16 header bytes for a device whose cache holds `capacity`
    /// entries: `BadMagic`, `BadVersion`, or `BadCompact` (cache too large, reserved byte,
    /// image length not a positive multiple of 4).
    pub fn parse(b: &[u8; COMPACT_HEADER_LEN], capacity: usize) -> Result<Self, SceneError> {
        let [m0, m1, m2, m3, v0, v1, log2, reserved, l0, l1, l2, l3, c0, c1, c2, c3] = *b;
        if [m0, m1, m2, m3] != COMPACT_MAGIC {
            return Err(SceneError::BadMagic);
        }
        if u16::from_le_bytes([v0, v1]) != COMPACT_VERSION {
            return Err(SceneError::BadVersion);
        }
        let image_len = u32::from_le_bytes([l0, l1, l2, l3]);
        let fits = log2 <= MAX_CACHE_LOG2 && (1usize << log2) <= capacity;
        if !fits || reserved != 0 || image_len == 0 || image_len % 4 != 0 {
            return Err(SceneError::BadCompact);
        }
        Ok(Self { cache_log2: log2, image_len, image_crc: u32::from_le_bytes([c0, c1, c2, c3]) })
    }
}

/// Where [`Unpacker::feed`] puts image bytes: `(bytes, decoded from a compact stream)`.
pub type Sink<'a> = dyn FnMut(&[u8], bool) -> Result<(), SceneError> + 'a;

/// What the unpacker has seen of the stream so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Fewer than 4 bytes: raw image or compact stream, not known yet.
    Unknown,
    /// A raw scene image: bytes pass through.
    Raw,
    /// Reading the 16-byte compact header.
    Header,
    /// Decoding ops.
    Ops(CompactHeader),
}

/// Streaming decoder of an upload: raw images pass through, compact streams are decoded.
/// `C` is the vertex-cache capacity in entries (0: every compact stream is refused).
///
/// Every byte is handled in bounded work (an op is at most [`MAX_OP_LEN`] bytes and emits at
/// most 32 words); nothing panics on any input.
pub struct Unpacker<const C: usize> {
    mode: Mode,
    /// The partial op (or the header, or the first bytes before the mode is known).
    pending: [u8; MAX_OP_LEN],
    pending_len: usize,
    history: [u32; HISTORY_WORDS],
    /// Index in `history` of the next word to write (the last word is one before it).
    hpos: usize,
    cache: [[u32; 3]; C],
    /// Next cache slot to fill, and slots filled so far.
    cache_next: usize,
    cache_filled: usize,
    /// Words produced so far.
    words: u32,
    digest: Crc32Digest,
    /// Decoded words waiting to be handed out (flushed per op).
    out: [u8; 4 * 32],
    out_len: usize,
}

impl<const C: usize> Default for Unpacker<C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const C: usize> Unpacker<C> {
    /// An unpacker at the start of an upload.
    pub fn new() -> Self {
        Self {
            mode: Mode::Unknown,
            pending: [0; MAX_OP_LEN],
            pending_len: 0,
            history: [0; HISTORY_WORDS],
            hpos: 0,
            cache: [[0; 3]; C],
            cache_next: 0,
            cache_filled: 0,
            words: 0,
            digest: Crc32Digest::default(),
            out: [0; 4 * 32],
            out_len: 0,
        }
    }

    /// True when the upload is a compact stream (known after its first 4 bytes).
    pub fn is_compact(&self) -> bool {
        matches!(self.mode, Mode::Header | Mode::Ops(_))
    }

    /// The compact header, once read.
    pub fn header(&self) -> Option<CompactHeader> {
        match self.mode {
            Mode::Ops(h) => Some(h),
            _ => None,
        }
    }

    /// Takes the next bytes of the upload and hands the image bytes they give to `sink`, in
    /// order, with `true` when they were decoded from a compact stream (then the image's
    /// length is the compact header's `image_len`, not the upload's). A sink error is returned
    /// as is; the unpacker must not be fed after an error.
    pub fn feed(&mut self, data: &[u8], sink: &mut Sink<'_>) -> Result<(), SceneError> {
        let mut rest = data;
        while let Some((&b, tail)) = rest.split_first() {
            match self.mode {
                Mode::Raw => return sink(rest, false),
                _ => self.push(b)?,
            }
            rest = tail;
            self.step(sink)?;
        }
        Ok(())
    }

    /// After the last byte: a raw image passes (its own checks follow); a compact stream must
    /// have produced exactly `image_len` bytes (`Truncated`, no partial op) whose CRC-32 is
    /// `image_crc` (`BadCrc`).
    pub fn finish(&self) -> Result<(), SceneError> {
        match self.mode {
            Mode::Raw => Ok(()),
            Mode::Unknown if self.pending_len == 0 => Ok(()),
            Mode::Unknown | Mode::Header => Err(SceneError::Truncated),
            Mode::Ops(h) => {
                if self.pending_len != 0 || u64::from(self.words).saturating_mul(4) != u64::from(h.image_len) {
                    Err(SceneError::Truncated)
                } else if self.digest.value() != h.image_crc {
                    Err(SceneError::BadCrc)
                } else {
                    Ok(())
                }
            }
        }
    }

    fn push(&mut self, b: u8) -> Result<(), SceneError> {
        let slot = self.pending.get_mut(self.pending_len).ok_or(SceneError::BadCompact)?;
        *slot = b;
        self.pending_len = self.pending_len.saturating_add(1);
        Ok(())
    }

    /// Acts on the pending bytes if they are complete (mode decision, header, one op).
    fn step(&mut self, sink: &mut Sink<'_>) -> Result<(), SceneError> {
        match self.mode {
            Mode::Raw => Ok(()),
            Mode::Unknown => {
                let head = self.pending.get(..self.pending_len).unwrap_or(&[]);
                if !COMPACT_MAGIC.starts_with(head) {
                    // A raw image: what was held goes through first.
                    self.mode = Mode::Raw;
                    let held = self.pending;
                    let n = self.pending_len;
                    self.pending_len = 0;
                    return sink(held.get(..n).unwrap_or(&[]), false);
                }
                if self.pending_len == COMPACT_MAGIC.len() {
                    self.mode = Mode::Header;
                }
                Ok(())
            }
            Mode::Header => {
                if self.pending_len < COMPACT_HEADER_LEN {
                    return Ok(());
                }
                let mut b = [0u8; COMPACT_HEADER_LEN];
                b.copy_from_slice(self.pending.get(..COMPACT_HEADER_LEN).ok_or(SceneError::BadCompact)?);
                self.mode = Mode::Ops(CompactHeader::parse(&b, C)?);
                self.pending_len = 0;
                Ok(())
            }
            Mode::Ops(h) => {
                let Some(len) = op_len(self.pending.get(..self.pending_len).unwrap_or(&[]))? else {
                    return Ok(());
                };
                if len != self.pending_len {
                    return Err(SceneError::BadCompact);
                }
                self.pending_len = 0;
                self.run_op(h)?;
                let n = self.out_len;
                self.out_len = 0;
                let out = self.out;
                let bytes = out.get(..n).unwrap_or(&[]);
                self.digest.update(bytes);
                sink(bytes, true)
            }
        }
    }

    /// The word `back` words before the next one (1 = the last word).
    fn h(&self, back: usize) -> u32 {
        let i = self.hpos.wrapping_sub(back) % HISTORY_WORDS;
        self.history.get(i).copied().unwrap_or(0)
    }

    fn emit(&mut self, h: &CompactHeader, w: u32) -> Result<(), SceneError> {
        if u64::from(self.words).saturating_add(1).saturating_mul(4) > u64::from(h.image_len) {
            return Err(SceneError::BadCompact);
        }
        let o = self.out.get_mut(self.out_len..self.out_len.saturating_add(4)).ok_or(SceneError::BadCompact)?;
        o.copy_from_slice(&w.to_le_bytes());
        self.out_len = self.out_len.saturating_add(4);
        if let Some(slot) = self.history.get_mut(self.hpos % HISTORY_WORDS) {
            *slot = w;
        }
        self.hpos = self.hpos.wrapping_add(1) % HISTORY_WORDS;
        self.words = self.words.saturating_add(1);
        Ok(())
    }

    /// Executes the complete op in `pending` (its length already checked by `op_len`).
    fn run_op(&mut self, h: CompactHeader) -> Result<(), SceneError> {
        let op = self.pending;
        let (&b, args) = op.split_first().ok_or(SceneError::BadCompact)?;
        let p = b & 31;
        let n = usize::from(p).saturating_add(1);
        match b >> 5 {
            compact_op::LIT => {
                for c in args.chunks_exact(4).take(n) {
                    let mut w = [0u8; 4];
                    w.copy_from_slice(c);
                    self.emit(&h, u32::from_le_bytes(w))?;
                }
            }
            compact_op::RUN => {
                for _ in 0..n {
                    let w = self.h(1);
                    self.emit(&h, w)?;
                }
            }
            compact_op::INC => {
                let w = self.h(1).wrapping_add(u32::from(p)).wrapping_add(1);
                self.emit(&h, w)?;
            }
            compact_op::DELTA => {
                let (v, _) = varint(args)?.ok_or(SceneError::BadCompact)?;
                let w = self.h(n).wrapping_add(unzigzag(v));
                self.emit(&h, w)?;
            }
            compact_op::TAIL => {
                let w = self.h(11).wrapping_add(u32::from(p));
                self.emit(&h, w)?;
                let w = self.h(11);
                self.emit(&h, w)?;
            }
            compact_op::VREF => {
                let index = usize::from(p) << 8 | usize::from(*args.first().ok_or(SceneError::BadCompact)?);
                if index >= self.cache_filled {
                    return Err(SceneError::BadCompact);
                }
                let v = *self.cache.get(index).ok_or(SceneError::BadCompact)?;
                for w in v {
                    self.emit(&h, w)?;
                }
            }
            compact_op::VNEW => {
                let mut v = [0u32; 3];
                let mut rest = args;
                for slot in &mut v {
                    let (d, used) = varint(rest)?.ok_or(SceneError::BadCompact)?;
                    rest = rest.get(used..).unwrap_or(&[]);
                    *slot = self.h(3).wrapping_add(unzigzag(d));
                    self.emit(&h, *slot)?;
                }
                let size = 1usize << h.cache_log2;
                let entry = self.cache.get_mut(self.cache_next).ok_or(SceneError::BadCompact)?;
                *entry = v;
                self.cache_next = self.cache_next.saturating_add(1) & size.wrapping_sub(1);
                self.cache_filled = self.cache_filled.saturating_add(1).min(size);
            }
            _ => return Err(SceneError::BadCompact),
        }
        Ok(())
    }
}

/// A LEB128 `u32` at the start of `b`: `Ok(None)` when `b` ends inside it, `(value, bytes)`
/// otherwise; more than 5 bytes or bits past 32 are `BadCompact`.
fn varint(b: &[u8]) -> Result<Option<(u32, usize)>, SceneError> {
    let mut v = 0u32;
    for (i, &x) in b.iter().enumerate().take(5) {
        if i == 4 && x > 0x0F {
            return Err(SceneError::BadCompact);
        }
        v |= u32::from(x & 0x7F).checked_shl(7u32.saturating_mul(i as u32)).unwrap_or(0);
        if x & 0x80 == 0 {
            return Ok(Some((v, i.saturating_add(1))));
        }
    }
    if b.len() >= 5 {
        Err(SceneError::BadCompact)
    } else {
        Ok(None)
    }
}

/// The length of the op starting `b`, once `b` holds all of it (`None`: not yet); a reserved
/// kind or a `VNEW` with `p` ≠ 0 is `BadCompact`.
fn op_len(b: &[u8]) -> Result<Option<usize>, SceneError> {
    let Some((&op, args)) = b.split_first() else { return Ok(None) };
    let p = usize::from(op & 31);
    let need = match op >> 5 {
        compact_op::LIT => p.saturating_add(1).saturating_mul(4).saturating_add(1),
        compact_op::RUN | compact_op::INC | compact_op::TAIL => 1,
        compact_op::VREF => 2,
        compact_op::DELTA => match varint(args)? {
            Some((_, n)) => n.saturating_add(1),
            None => return Ok(None),
        },
        compact_op::VNEW if p == 0 => {
            let mut used = 0usize;
            for _ in 0..3 {
                match varint(args.get(used..).unwrap_or(&[]))? {
                    Some((_, n)) => used = used.saturating_add(n),
                    None => return Ok(None),
                }
            }
            used.saturating_add(1)
        }
        _ => return Err(SceneError::BadCompact),
    };
    Ok((b.len() >= need).then_some(need))
}
