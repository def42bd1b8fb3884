//! FSL word protocol between the soft-core and the ray-intersection co-processor (SPEC.md §4).
//!
//! An FSL channel carries 32-bit words plus one control bit. Every packet in either direction
//! ends with the only word whose control bit is set; the receiver uses that bit to resynchronise
//! after an error. The first word of each packet carries the opcode in bits 31..28.

// Link-facing: every index and every sum on received values is checked (ARCHITECTURE.md).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// One word on an FSL channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FslWord {
    /// The 32 data bits.
    pub data: u32,
    /// The control bit: set on the last word of a packet, clear otherwise.
    pub control: bool,
}

impl FslWord {
    /// A data word (control bit clear).
    pub const fn data(data: u32) -> Self {
        Self { data, control: false }
    }
    /// The last word of a packet (control bit set).
    pub const fn last(data: u32) -> Self {
        Self { data, control: true }
    }
}

/// Opcodes in bits 31..28 of a packet's first word.
pub mod op {
    /// Host → co-processor: load one PE's memory image.
    pub const LOAD_PE: u32 = 0x1;
    /// Host → co-processor: nearest-hit ray query.
    pub const RAY_CLOSEST: u32 = 0x2;
    /// Host → co-processor: any-hit (shadow) ray query; stops at the first accepted hit.
    pub const RAY_ANY: u32 = 0x3;
    /// Host → co-processor: clear every PE memory.
    pub const CLEAR: u32 = 0x4;
    /// Host → co-processor: the scene's grid box, which sets the fixed-point frame (7 words).
    pub const FRAME: u32 = 0x5;
    /// Co-processor → host: ray result (8 words).
    pub const RESULT: u32 = 0x8;
    /// Co-processor → host: acknowledgement of LOAD_PE / CLEAR / FRAME (1 word).
    pub const ACK: u32 = 0x9;
    /// Co-processor → host: protocol violation (1 word).
    pub const ERROR: u32 = 0xE;
}

/// Words of a ray request before the traversal list.
pub const RAY_HEADER_WORDS: usize = 8;
/// Words per traversal-list entry (voxel id, exit distance).
pub const ENTRY_WORDS: usize = 2;
/// Words of a ray result.
pub const RESULT_WORDS: usize = 8;
/// Words of a FRAME packet: header, box min xyz, box max xyz.
pub const FRAME_WORDS: usize = 7;
/// Largest list a request may carry: the RESULT word reports the winning position in 12 bits.
/// (The 3D-DDA bound nx+ny+nz with at most 255 cells per axis is 765.)
pub const MAX_LIST_ENTRIES: usize = 0x0FFF;

/// Extracts the opcode of a packet's first word.
pub const fn opcode(word: u32) -> u32 {
    word >> 28
}

/// Kind of ray query.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RayKind {
    /// Report the nearest accepted hit (camera and reflection rays).
    Closest,
    /// Report any accepted hit with `t < t_max` and stop (shadow rays).
    Any,
}

impl RayKind {
    /// The request opcode for this kind.
    pub const fn opcode(self) -> u32 {
        match self {
            Self::Closest => op::RAY_CLOSEST,
            Self::Any => op::RAY_ANY,
        }
    }
}

/// One traversal-list entry: a non-empty voxel and the ray distance at which it is left.
///
/// The co-processor accepts a hit found in this voxel only if `t <= t_exit` (with the
/// tolerance of SPEC.md §4.3); this fixes GridRT's cross-voxel flaw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ListEntry {
    /// Linear voxel index `ix + nx*(iy + ny*iz)`, below 2^24.
    pub voxel: u32,
    /// PE that owns the voxel (from the scene's voxel→PE map).
    pub pe: u8,
    /// Ray parameter where the ray leaves the voxel.
    pub t_exit: f32,
}

/// First word of a ray request: opcode, then the list length in bits 15..0.
pub const fn ray_header(kind: RayKind, entries: u16) -> u32 {
    (kind.opcode() << 28) | entries as u32
}

/// First word of a LOAD_PE packet: opcode, then the PE id in bits 7..0.
pub const fn load_header(pe: u8) -> u32 {
    (op::LOAD_PE << 28) | pe as u32
}

/// The ACK word answering a LOAD_PE (`acked` = [`op::LOAD_PE`], PE id) or a CLEAR
/// (`acked` = [`op::CLEAR`], PE 0).
pub const fn ack_word(acked: u32, pe: u8) -> u32 {
    (op::ACK << 28) | ((acked & 0xF) << 24) | pe as u32
}

/// The CLEAR packet (a single word).
pub const CLEAR_WORD: u32 = op::CLEAR << 28;

/// The FRAME packet (SPEC §4.6): header, then the grid box's minimum and maximum corners
/// (f32 bits); the control bit goes on the last word.
pub fn frame_packet(min: [f32; 3], max: [f32; 3]) -> [u32; FRAME_WORDS] {
    [
        op::FRAME << 28,
        min[0].to_bits(),
        min[1].to_bits(),
        min[2].to_bits(),
        max[0].to_bits(),
        max[1].to_bits(),
        max[2].to_bits(),
    ]
}

/// Writes the 8-word request header: header word, origin xyz, direction xyz, t_max.
///
/// The caller appends `entries` list entries with [`entry_words`]; the last word of the
/// packet must carry the control bit.
pub fn ray_request_head(
    kind: RayKind,
    origin: [f32; 3],
    dir: [f32; 3],
    t_max: f32,
    entries: u16,
) -> [u32; RAY_HEADER_WORDS] {
    [
        ray_header(kind, entries),
        origin[0].to_bits(),
        origin[1].to_bits(),
        origin[2].to_bits(),
        dir[0].to_bits(),
        dir[1].to_bits(),
        dir[2].to_bits(),
        t_max.to_bits(),
    ]
}

/// The two words of one list entry.
pub fn entry_words(e: ListEntry) -> [u32; ENTRY_WORDS] {
    [(e.voxel & VOXEL_MASK) | ((e.pe as u32) << 24), e.t_exit.to_bits()]
}

/// Decodes the two words of one list entry.
pub fn entry_from_words(w0: u32, w1: u32) -> ListEntry {
    ListEntry { voxel: w0 & VOXEL_MASK, pe: (w0 >> 24) as u8, t_exit: f32::from_bits(w1) }
}

/// Voxel ids occupy bits 23..0 of an entry's first word.
pub const VOXEL_MASK: u32 = 0x00FF_FFFF;

/// Result of one ray query, as returned in 8 words.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RayResult {
    /// True when a hit was accepted.
    pub hit: bool,
    /// PE that produced the winning hit (0 on a miss).
    pub pe: u8,
    /// Position of the winning voxel in the traversal list (0 on a miss).
    pub list_pos: u16,
    /// Ray parameter of the hit (`f32::INFINITY` on a miss).
    pub t: f32,
    /// Global primitive id of the hit (0 on a miss).
    pub prim: u32,
    /// Material index of the hit primitive.
    pub material: u16,
    /// Ray–primitive tests the co-processor performed for this query (saturating).
    pub tests: u16,
    /// Geometric normal of the hit primitive, not normalised, in scene space.
    pub normal: [f32; 3],
    /// Co-processor cycles this query took (saturating).
    pub cycles: u32,
}

impl RayResult {
    /// The miss result.
    pub const MISS: Self = Self {
        hit: false,
        pe: 0,
        list_pos: 0,
        t: f32::INFINITY,
        prim: 0,
        material: 0,
        tests: 0,
        normal: [0.0; 3],
        cycles: 0,
    };

    /// Encodes the result as its 8 words (word 7 carries the control bit on the link).
    pub fn to_words(&self) -> [u32; RESULT_WORDS] {
        [
            (op::RESULT << 28) | ((self.list_pos as u32 & 0xFFF) << 16) | ((self.pe as u32) << 8) | self.hit as u32,
            self.t.to_bits(),
            self.prim,
            (self.material as u32) | ((self.tests as u32) << 16),
            self.normal[0].to_bits(),
            self.normal[1].to_bits(),
            self.normal[2].to_bits(),
            self.cycles,
        ]
    }

    /// Decodes 8 result words; the first must carry the RESULT opcode.
    pub fn from_words(w: &[u32; RESULT_WORDS]) -> Result<Self, FslError> {
        if opcode(w[0]) != op::RESULT {
            return Err(FslError::UnknownOpcode);
        }
        Ok(Self {
            hit: w[0] & 1 == 1,
            pe: (w[0] >> 8) as u8,
            list_pos: ((w[0] >> 16) & 0xFFF) as u16,
            t: f32::from_bits(w[1]),
            prim: w[2],
            material: w[3] as u16,
            tests: (w[3] >> 16) as u16,
            normal: [f32::from_bits(w[4]), f32::from_bits(w[5]), f32::from_bits(w[6])],
            cycles: w[7],
        })
    }
}

/// Protocol violations the co-processor reports instead of guessing (SPEC.md §4.5).
///
/// On the link each is one ERROR word: opcode `0xE`, code in bits 27..16, detail in 15..0.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FslError {
    /// The first word of a packet has an opcode the model does not know.
    UnknownOpcode,
    /// A control bit arrived before the packet's declared end.
    PacketTooShort,
    /// The packet's declared last word arrived without its control bit.
    MissingControl,
    /// A PE id is not below the configured PE count.
    PeOutOfRange,
    /// A voxel id is not inside the loaded grid.
    VoxelOutOfRange,
    /// A listed voxel belongs to no loaded PE or holds no primitives.
    VoxelNotLoaded,
    /// The traversal list is longer than the model accepts.
    ListTooLong,
    /// A PE memory image exceeds the PE's memory.
    PeMemoryOverflow,
    /// A PE memory image is internally inconsistent.
    PeImageMalformed,
    /// A ray arrived before any scene was loaded.
    SceneNotLoaded,
    /// A ray origin, direction or distance is NaN or infinite, or the direction is zero.
    NonFiniteRay,
    /// A FRAME box has a non-finite corner or an axis with max < min.
    BadFrame,
    /// A LOAD_PE image holds primitives the co-processor's kernel does not test (analytic
    /// primitives with the fixed-point RTL kernel).
    Unsupported,
    /// An ERROR word from the co-processor carried an unknown code.
    UnknownError,
}

impl FslError {
    /// Wire code of this error.
    pub const fn code(self) -> u16 {
        match self {
            Self::UnknownOpcode => 1,
            Self::PacketTooShort => 2,
            Self::MissingControl => 3,
            Self::PeOutOfRange => 4,
            Self::VoxelOutOfRange => 5,
            Self::VoxelNotLoaded => 6,
            Self::ListTooLong => 7,
            Self::PeMemoryOverflow => 8,
            Self::PeImageMalformed => 9,
            Self::SceneNotLoaded => 10,
            Self::NonFiniteRay => 11,
            Self::BadFrame => 12,
            Self::Unsupported => 13,
            Self::UnknownError => 0xFFF,
        }
    }

    /// Error for a wire code.
    pub const fn from_code(code: u16) -> Self {
        match code {
            1 => Self::UnknownOpcode,
            2 => Self::PacketTooShort,
            3 => Self::MissingControl,
            4 => Self::PeOutOfRange,
            5 => Self::VoxelOutOfRange,
            6 => Self::VoxelNotLoaded,
            7 => Self::ListTooLong,
            8 => Self::PeMemoryOverflow,
            9 => Self::PeImageMalformed,
            10 => Self::SceneNotLoaded,
            11 => Self::NonFiniteRay,
            12 => Self::BadFrame,
            13 => Self::Unsupported,
            _ => Self::UnknownError,
        }
    }

    /// The ERROR word reporting this error with a 16-bit detail (PE id, word index, …).
    pub const fn to_word(self, detail: u16) -> u32 {
        (op::ERROR << 28) | ((self.code() as u32 & 0xFFF) << 16) | detail as u32
    }

    /// Decodes an ERROR word into the error and its detail.
    pub const fn from_word(word: u32) -> (Self, u16) {
        (Self::from_code(((word >> 16) & 0xFFF) as u16), word as u16)
    }
}

impl FslError {
    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::UnknownOpcode => "unknown opcode",
            Self::PacketTooShort => "control bit before the end of the packet",
            Self::MissingControl => "last word of the packet lacks the control bit",
            Self::PeOutOfRange => "PE id out of range",
            Self::VoxelOutOfRange => "voxel id outside the grid",
            Self::VoxelNotLoaded => "voxel is empty or not loaded",
            Self::ListTooLong => "traversal list too long",
            Self::PeMemoryOverflow => "PE memory image exceeds PE memory",
            Self::PeImageMalformed => "malformed PE memory image",
            Self::SceneNotLoaded => "no scene loaded",
            Self::NonFiniteRay => "ray has NaN/inf components or a zero direction",
            Self::BadFrame => "FRAME box is not finite or inverted",
            Self::Unsupported => "PE image holds primitives this co-processor does not test",
            Self::UnknownError => "unknown error code",
        }
    }
}

impl core::fmt::Display for FslError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for FslError {}

/// GridRT baseline (thesis App. D): packs up to 8 signed 4-bit PE ids, first voxel in the
/// low nibble, `0xF` for empty slots. Returns `None` if an id does not fit 4 signed bits.
///
/// Kept to document and test the baseline layout; the extended request replaces it.
pub fn pack_gridrt_list(ids: &[i8]) -> Option<u32> {
    if ids.len() > 8 {
        return None;
    }
    let mut word = 0xFFFF_FFFFu32;
    for (k, &id) in ids.iter().enumerate() {
        if !(-1..=7).contains(&id) {
            return None;
        }
        let nibble = (id as u32) & 0xF;
        // k < 8 (checked above), so the shift is below 32.
        let shift = (k as u32).wrapping_mul(4);
        word &= !(0xF << shift);
        word |= nibble << shift;
    }
    Some(word)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    /// SPEC.md §4.3 worked example.
    #[test]
    fn golden_ray_request_words() {
        let head = ray_request_head(RayKind::Closest, [0.0, 0.5, 2.0], [0.0, 0.0, -1.0], f32::INFINITY, 2);
        assert_eq!(
            head,
            [0x2000_0002, 0x0000_0000, 0x3F00_0000, 0x4000_0000, 0x0000_0000, 0x0000_0000, 0xBF80_0000, 0x7F80_0000]
        );
        let e = ListEntry { voxel: 5, pe: 3, t_exit: 1.5 };
        assert_eq!(entry_words(e), [0x0300_0005, 0x3FC0_0000]);
        assert_eq!(entry_from_words(0x0300_0005, 0x3FC0_0000), e);
        assert_eq!(ray_header(RayKind::Any, 0), 0x3000_0000);
        assert_eq!(load_header(3), 0x1000_0003);
    }

    #[test]
    fn golden_result_words_round_trip() {
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
        let w = r.to_words();
        assert_eq!(w, [0x8001_0201, 0x3FA0_0000, 42, 0x0011_0003, 0, 0, 0x3F80_0000, 11_016]);
        assert_eq!(RayResult::from_words(&w), Ok(r));
    }

    #[test]
    fn result_decoder_rejects_wrong_opcode() {
        let mut w = RayResult::MISS.to_words();
        w[0] = FslError::ListTooLong.to_word(9);
        assert_eq!(RayResult::from_words(&w), Err(FslError::UnknownOpcode));
        assert_eq!(FslError::from_word(w[0]), (FslError::ListTooLong, 9));
        assert_eq!(w[0], 0xE007_0009);
    }

    #[test]
    fn error_codes_round_trip() {
        for code in 1..=13 {
            assert_eq!(FslError::from_code(code).code(), code);
        }
        assert_eq!(FslError::from_code(999), FslError::UnknownError);
    }

    /// GridRT App. D: list (PE 2, PE 0, PE 3) → first voxel in the low nibble, 0xF fill.
    #[test]
    fn gridrt_baseline_list_packing() {
        assert_eq!(pack_gridrt_list(&[2, 0, 3]), Some(0xFFFF_F302));
        assert_eq!(pack_gridrt_list(&[]), Some(0xFFFF_FFFF));
        assert_eq!(pack_gridrt_list(&[8]), None);
        assert_eq!(pack_gridrt_list(&[0; 9]), None);
    }
}
