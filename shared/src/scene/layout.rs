//! Sizes, magic numbers and limits of the scene image (SPEC.md §5), and the error every reader
//! of it returns. Every other file of `scene` builds on this one.

/// Magic bytes at offset 0.
pub const MAGIC: [u8; 4] = *b"GRTS";
/// Scene image format version (the only layout this build reads or writes).
pub const VERSION: u16 = 2;
/// Header size in bytes.
pub const HEADER_LEN: usize = 64;
/// Bytes per material colour record.
pub const MATERIAL_LEN: usize = 16;
/// Bytes per material model record (shading models, Fresnel, texture).
pub const MATERIAL_MODEL_LEN: usize = 96;
/// Bytes per object record.
pub const OBJECT_LEN: usize = 64;
/// Bytes of the lighting record.
pub const LIGHTING_LEN: usize = 80;
/// Voxel-map value of an empty voxel.
pub const EMPTY_VOXEL: u8 = 0xFF;
/// Largest PE count (ids 0..=254; 255 marks empty voxels).
pub const MAX_PES: usize = 255;
/// Largest grid: voxel ids are 24-bit on the FSL link.
pub const MAX_VOXELS: u32 = 1 << 24;
/// First word of a PE memory image: a tag, so that a stray word stream (or an image of an
/// earlier layout, whose first word was a triangle count) is never taken for one.
pub const PE_IMAGE_TAG: u32 = 0xFFFF_0002;
/// Words before the voxel table in a PE image: tag, T, V, R, P.
pub const PE_HEADER_WORDS: usize = 5;
/// Words per triangle record in a PE image: 9 vertex coordinates, prim id, material.
pub const TRIANGLE_WORDS: usize = 11;
/// Words per analytic primitive record in a PE image.
pub const PRIM_WORDS: usize = 16;
/// Words per voxel-table entry in a PE image: voxel id, first ref, ref count.
pub const VOXEL_ENTRY_WORDS: usize = 3;
/// Largest ray depth of the lighting record (`max_depth`).
pub const MAX_DEPTH: u8 = 8;

/// Why a scene image was rejected.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneError {
    /// The image does not start with `GRTS`.
    BadMagic,
    /// The image has a version this build cannot read.
    BadVersion,
    /// The image ends before a section it declares.
    Truncated,
    /// The image has bytes past its declared end.
    TrailingBytes,
    /// A header field is out of range (zero grid size, bad bounds, too many PEs, …).
    BadHeader,
    /// The voxel map names a PE that the image does not have.
    BadVoxelMap,
    /// A PE block is out of order or malformed.
    BadPeBlock,
    /// A PE block is larger than the PE memory the image was built for.
    PeMemoryOverflow,
    /// The body CRC does not match.
    BadCrc,
    /// The grid has more voxels than this device can hold.
    GridTooLarge,
    /// More materials than this device can hold.
    TooManyMaterials,
    /// A coordinate or material value is NaN or infinite.
    NonFinite,
    /// The consumer of the stream refused a piece (e.g. the co-processor reported an error).
    Rejected,
    /// A record (material model, object, lighting, primitive) has an out-of-range enum or
    /// value.
    BadRecord,
    /// The point section holds more points than this device can hold (SPEC.md §5.10).
    TooManyPoints,
    /// A compact scene stream (SPEC.md §5.12) is malformed: a reserved op, an over-long
    /// varint, a vertex-cache index not yet filled, output past the declared image length.
    BadCompact,
}

impl SceneError {
    /// Error number used in `Error.detail` (SPEC.md §3.9): declaration order, from 1.
    pub const fn code(self) -> u32 {
        match self {
            Self::BadMagic => 1,
            Self::BadVersion => 2,
            Self::Truncated => 3,
            Self::TrailingBytes => 4,
            Self::BadHeader => 5,
            Self::BadVoxelMap => 6,
            Self::BadPeBlock => 7,
            Self::PeMemoryOverflow => 8,
            Self::BadCrc => 9,
            Self::GridTooLarge => 10,
            Self::TooManyMaterials => 11,
            Self::NonFinite => 12,
            Self::Rejected => 13,
            Self::BadRecord => 14,
            Self::TooManyPoints => 15,
            Self::BadCompact => 16,
        }
    }

    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::BadMagic => "not a scene image (bad magic)",
            Self::BadVersion => "unsupported scene image version",
            Self::Truncated => "scene image truncated",
            Self::TrailingBytes => "bytes after the end of the scene image",
            Self::BadHeader => "scene header field out of range",
            Self::BadVoxelMap => "voxel map names a PE that does not exist",
            Self::BadPeBlock => "malformed PE block",
            Self::PeMemoryOverflow => "PE block exceeds PE memory",
            Self::BadCrc => "scene image CRC mismatch",
            Self::GridTooLarge => "grid has more voxels than the device can hold",
            Self::TooManyMaterials => "more materials than the device can hold",
            Self::NonFinite => "NaN or infinite value in scene image",
            Self::Rejected => "scene piece rejected by the loader",
            Self::BadRecord => "scene record field out of range",
            Self::TooManyPoints => "more points than the device can hold",
            Self::BadCompact => "malformed compact scene stream",
        }
    }
}

impl core::fmt::Display for SceneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for SceneError {}

/// Decodes a one-byte enum field: `table[v]`, or [`SceneError::BadRecord`].
pub(crate) fn enum_u8<T: Copy>(v: u8, table: &[T]) -> Result<T, SceneError> {
    table.get(v as usize).copied().ok_or(SceneError::BadRecord)
}
