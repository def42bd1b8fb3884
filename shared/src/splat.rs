//! Seed 001's splat codewords (Maršík 2008 §6.3; SPEC.md §6): the 64-bit words the code
//! generator (the firmware, in the DSP's role) sends to the splat stage (the FPGA's role).
//!
//! Bit numbering follows the thesis: bit 0 is the most significant bit of the `u64` (the first
//! bit sent). In `u64` terms:
//!
//! | thesis bits | `u64` bits | field |
//! |---|---|---|
//! | 0 | 63 | MODE: 0 symmetric, 1 interpolated |
//! | 1–24 | 62..39 | SCANS: 4 × (start:3, length:3), sent row 0 first |
//! | 25–31 | 38..32 | DIFFUSE term, 0..=127 |
//! | 32–38 | 31..25 | SPECULAR term, 0..=127 |
//! | 39–45 | 24..18 | MATERIAL index, 0..=127 |
//! | 46–54 | 17..9 | X: box centre column + 4 guard columns, relative to the tile |
//! | 55–63 | 8..0 | Z: depth, 0 nearest |
//!
//! A word whose first eight bits are `0xFF` is a command ([`Command`]); a splat word never is,
//! because the row code (7, 7) that would make it one is never written (the empty row is
//! [`RowCode::EMPTY`] = (7, 1)).

// Link-facing: every index and every sum on received values is checked (ARCHITECTURE.md).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// One row of an 8×8 box: pixels `start ..= start + length` (so `length` is the pixel count
/// minus one). `start + length > 7` is an empty row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RowCode {
    /// First pixel, 0..=7.
    pub start: u8,
    /// Pixels after the first, 0..=7.
    pub length: u8,
}

impl RowCode {
    /// The empty row as the encoder writes it: (7, 1). Never (7, 7), which could make the
    /// word's first byte `0xFF`, a command.
    pub const EMPTY: Self = Self { start: 7, length: 1 };

    /// The row covering pixels `first ..= last` (clamped to the box), or [`Self::EMPTY`].
    pub const fn span(first: i32, last: i32) -> Self {
        let (a, b) = (if first < 0 { 0 } else { first }, if last > 7 { 7 } else { last });
        if a > b || a > 7 || b < 0 {
            Self::EMPTY
        } else {
            Self { start: a as u8, length: b.wrapping_sub(a) as u8 }
        }
    }

    /// Covered pixels `(first, last)`, `None` for an empty row.
    pub const fn pixels(self) -> Option<(u8, u8)> {
        let (s, l) = (self.start & 7, self.length & 7);
        let end = s.wrapping_add(l);
        if end > 7 {
            None
        } else {
            Some((s, end))
        }
    }

    /// The 6-bit code `start << 3 | length`.
    const fn bits(self) -> u64 {
        (((self.start & 7) as u64) << 3) | (self.length & 7) as u64
    }
}

/// How the 4 transmitted rows become 8 (point splatting).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Splats of at most 8×8 pixels centred on the box: rows 0..=3 are sent, row 7 − j is row
    /// j mirrored about the box centre.
    Symmetric,
    /// One 8×8 tile of a larger splat: rows 0, 2, 5 and 7 are sent, rows 1, 3, 4 and 6 are
    /// interpolated (start and end, rounded half up; empty when a neighbour is empty).
    Interpolated,
}

/// Rows sent in [`Mode::Interpolated`].
pub const INTERPOLATED_ROWS: [usize; 4] = [0, 2, 5, 7];

/// A splat codeword's fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplatWord {
    /// Row reconstruction.
    pub mode: Mode,
    /// The four transmitted rows.
    pub scans: [RowCode; 4],
    /// Diffuse term, 0..=127 (127 = 1).
    pub diffuse: u8,
    /// Specular term, 0..=127.
    pub specular: u8,
    /// Material index, 0..=127.
    pub material: u8,
    /// Box centre column + 4, relative to the tile's first column: the box covers tile
    /// columns `x − 8 ..= x − 1`. 0..=511.
    pub x: u16,
    /// Depth, 0..=511, 0 nearest.
    pub z: u16,
}

/// Largest value of a 7-bit field.
pub const MAX_TERM: u8 = 127;
/// Largest X or Z (9 bits).
pub const MAX_XZ: u16 = 511;
/// Largest material index (7 bits).
pub const MAX_MATERIAL: u8 = 127;

impl SplatWord {
    /// The 64-bit codeword. Fields wider than their bit count are masked; a row code of
    /// (7, 7) is written as [`RowCode::EMPTY`].
    pub fn pack(&self) -> u64 {
        let scans = self.scans.iter().fold(0u64, |acc, r| {
            let r = if r.pixels().is_none() { RowCode::EMPTY } else { *r };
            (acc << 6) | r.bits()
        });
        let mode = match self.mode {
            Mode::Symmetric => 0u64,
            Mode::Interpolated => 1u64,
        };
        (mode << 63)
            | (scans << 39)
            | (((self.diffuse & 0x7F) as u64) << 32)
            | (((self.specular & 0x7F) as u64) << 25)
            | (((self.material & 0x7F) as u64) << 18)
            | (((self.x & 0x1FF) as u64) << 9)
            | (self.z & 0x1FF) as u64
    }

    /// The fields of a word that is not a command (callers check [`is_command`] first; a
    /// command word decodes to garbage fields here, never to an error).
    pub fn unpack(word: u64) -> Self {
        let row = |shift: u32| {
            let code = (word >> shift) & 0x3F;
            RowCode { start: (code >> 3) as u8, length: (code & 7) as u8 }
        };
        let scans = [row(57), row(51), row(45), row(39)];
        Self {
            mode: if word >> 63 == 0 { Mode::Symmetric } else { Mode::Interpolated },
            scans,
            diffuse: ((word >> 32) & 0x7F) as u8,
            specular: ((word >> 25) & 0x7F) as u8,
            material: ((word >> 18) & 0x7F) as u8,
            x: ((word >> 9) & 0x1FF) as u16,
            z: (word & 0x1FF) as u16,
        }
    }

    /// The eight rows of the box as covered `(first, last)` pixels, `None` = empty.
    pub fn rows(&self) -> [Option<(u8, u8)>; 8] {
        let p = self.scans.map(RowCode::pixels);
        let [r0, r1, r2, r3] = p;
        match self.mode {
            Mode::Symmetric => {
                let m = |r: Option<(u8, u8)>| r.map(|(a, b)| (7u8.saturating_sub(b), 7u8.saturating_sub(a)));
                [r0, r1, r2, r3, m(r3), m(r2), m(r1), m(r0)]
            }
            Mode::Interpolated => {
                // Sent: rows 0, 2, 5, 7 (= r0, r1, r2, r3).
                [r0, lerp(r0, r1, 1, 2), r1, lerp(r1, r2, 1, 3), lerp(r1, r2, 2, 3), r2, lerp(r2, r3, 1, 2), r3]
            }
        }
    }
}

/// Row `k/n` of the way from `a` to `b`: start and end interpolated and rounded half up,
/// `round((a·(n−k) + b·k) / n)` = `(2·(a·(n−k) + b·k) + n) / (2n)` in integers; empty when
/// either neighbour is empty.
fn lerp(a: Option<(u8, u8)>, b: Option<(u8, u8)>, k: u16, n: u16) -> Option<(u8, u8)> {
    let ((a0, a1), (b0, b1)) = (a?, b?);
    // Values ≤ 7, k < n ≤ 3: every intermediate is < 64.
    let f = |x: u8, y: u8| -> u8 {
        let num = (x as u16).wrapping_mul(n.wrapping_sub(k)).wrapping_add((y as u16).wrapping_mul(k));
        num.wrapping_mul(2).wrapping_add(n).checked_div(n.wrapping_mul(2)).unwrap_or(0) as u8
    };
    Some((f(a0, b0), f(a1, b1)))
}

/// True for a command word (first eight bits `0xFF`).
pub const fn is_command(word: u64) -> bool {
    word >> 56 == 0xFF
}

/// Command words (first eight bits `0xFF`, 2-bit opcode in `u64` bits 55..54, parameter in
/// the low bits, every other bit 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// Opcode 0: the following words fill the material table, three words per material
    /// ([`MaterialTerm`] k_a, k_d, k_s), from index 0.
    StartLoad,
    /// Opcode 1: closes the material block.
    EndLoad,
    /// Opcode 2: moves the active stripe down by N lines (bits 15..0); this unit writes
    /// nothing more to the N lines that leave it.
    Shift(u16),
    /// Opcode 3: loads the ambient register (bits 6..0, 0..=127).
    Ambient(u8),
}

/// Why a word is not a valid command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CodewordError {
    /// The first eight bits are not `0xFF`.
    NotCommand,
    /// A bit outside the opcode's parameter is set.
    ReservedBits,
}

impl Command {
    /// The 64-bit word.
    pub const fn pack(self) -> u64 {
        let (op, param) = match self {
            Self::StartLoad => (0u64, 0u64),
            Self::EndLoad => (1, 0),
            Self::Shift(n) => (2, n as u64),
            Self::Ambient(a) => (3, (a & 0x7F) as u64),
        };
        (0xFFu64 << 56) | (op << 54) | param
    }

    /// Decodes a command word; parameter bits the opcode does not use must be 0.
    pub const fn unpack(word: u64) -> Result<Self, CodewordError> {
        if !is_command(word) {
            return Err(CodewordError::NotCommand);
        }
        let param = word & 0x003F_FFFF_FFFF_FFFF;
        let (cmd, mask) = match (word >> 54) & 3 {
            0 => (Self::StartLoad, 0u64),
            1 => (Self::EndLoad, 0),
            2 => (Self::Shift((param & 0xFFFF) as u16), 0xFFFF),
            _ => (Self::Ambient((param & 0x7F) as u8), 0x7F),
        };
        if param & !mask != 0 {
            return Err(CodewordError::ReservedBits);
        }
        Ok(cmd)
    }
}

/// One material-table word: a term's RGB multipliers, u16 each, in 1/256 of an 8-bit colour
/// level per unit of a 7-bit term: channel c = min(255, (k_a·A + k_d·D + k_s·S + 128) >> 8).
/// Bits 63..48 are 0 (so no load word is ever a command).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MaterialTerm(pub [u16; 3]);

impl MaterialTerm {
    /// The 64-bit word: R in bits 47..32, G in 31..16, B in 15..0.
    pub const fn pack(self) -> u64 {
        ((self.0[0] as u64) << 32) | ((self.0[1] as u64) << 16) | self.0[2] as u64
    }

    /// Decodes a load word; bits 63..48 must be 0.
    pub const fn unpack(word: u64) -> Result<Self, CodewordError> {
        if word >> 48 != 0 {
            return Err(CodewordError::ReservedBits);
        }
        Ok(Self([(word >> 32) as u16, (word >> 16) as u16, word as u16]))
    }

    /// The multiplier of a colour coefficient `c` (colour per unit term, 1.0 = full scale):
    /// `round(c · 255 · 256 / 127)`, saturating.
    pub fn from_coefficient(c: [f32; 3]) -> Self {
        Self(c.map(|v| {
            let k = v * (255.0 * 256.0 / 127.0) + 0.5;
            if k.is_nan() || k <= 0.0 {
                0
            } else if k >= 65535.0 {
                u16::MAX
            } else {
                k as u16
            }
        }))
    }
}

/// The colour the stage computes from a material's three terms and the 7-bit A, D, S.
pub fn shade(terms: &[MaterialTerm; 3], ambient: u8, diffuse: u8, specular: u8) -> [u8; 3] {
    let [ka, kd, ks] = terms;
    let mut rgb = [0u8; 3];
    for (c, out) in rgb.iter_mut().enumerate() {
        let k = |t: &MaterialTerm, v: u8| (t.0.get(c).copied().unwrap_or(0) as u32).wrapping_mul((v & 0x7F) as u32);
        // Each product < 2^23: the sum cannot overflow.
        let sum = k(ka, ambient).wrapping_add(k(kd, diffuse)).wrapping_add(k(ks, specular)).wrapping_add(128);
        *out = (sum >> 8).min(255) as u8;
    }
    rgb
}

/// The extra word after each splat codeword in per-pixel depth mode: a 16-bit depth at the
/// box centre and its slopes, in 1/16 depth units per pixel. Bits 63..56 and 7..0 are 0.
/// A pixel `(c, r)` of the box (0..=7 each) gets
/// `clamp(z + ((dzdx·(2c − 7) + dzdy·(2r − 7)) >> 5), 0, 65534)` (arithmetic shift).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DepthWord {
    /// Depth at the box centre, 0 nearest, 0..=65534.
    pub z: u16,
    /// Depth change per pixel to the right, 1/16 units.
    pub dzdx: i16,
    /// Depth change per pixel down, 1/16 units.
    pub dzdy: i16,
}

impl DepthWord {
    /// The 64-bit word: z in bits 55..40, dz/dx in 39..24, dz/dy in 23..8.
    pub const fn pack(self) -> u64 {
        ((self.z as u64) << 40) | (((self.dzdx as u16) as u64) << 24) | (((self.dzdy as u16) as u64) << 8)
    }

    /// Decodes a depth word; the reserved bits must be 0.
    pub const fn unpack(word: u64) -> Result<Self, CodewordError> {
        if word >> 56 != 0 || word & 0xFF != 0 {
            return Err(CodewordError::ReservedBits);
        }
        Ok(Self { z: (word >> 40) as u16, dzdx: (word >> 24) as u16 as i16, dzdy: (word >> 8) as u16 as i16 })
    }

    /// Depth of box pixel `(c, r)`.
    pub fn at(self, c: u8, r: u8) -> u16 {
        let (c, r) = (c.min(7) as i32, r.min(7) as i32);
        // |2c − 7| ≤ 7 and |dz| ≤ 2^15: every product and the sum fit an i32.
        let dx = (self.dzdx as i32).wrapping_mul(c.wrapping_mul(2).wrapping_sub(7));
        let dy = (self.dzdy as i32).wrapping_mul(r.wrapping_mul(2).wrapping_sub(7));
        let z = (self.z as i32).wrapping_add(dx.wrapping_add(dy) >> 5);
        z.clamp(0, MAX_PIXEL_DEPTH as i32) as u16
    }
}

/// Largest per-pixel depth; `u16::MAX` is the background's.
pub const MAX_PIXEL_DEPTH: u16 = 65534;
