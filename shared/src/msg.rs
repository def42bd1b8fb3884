//! Messages carried in UART frame payloads (SPEC.md §3). All integers little-endian.
//!
//! Decoders check exact lengths: a payload with missing or extra bytes is an error, never
//! a guess. Variable-length messages (scene chunk, pixel span, stats, error) carry their
//! variable part last.

use crate::bytes::{Overflow, Reader, Truncated, Writer};

/// Message type bytes (frame header byte 0).
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum MsgType {
    /// Host → device: start of a session.
    Hello = 0x01,
    /// Device → host: answer to Hello.
    Version = 0x02,
    /// Host → device: a scene image follows.
    SceneBegin = 0x10,
    /// Host → device: bytes of the scene image.
    SceneChunk = 0x11,
    /// Device → host: scene bytes received so far.
    SceneAck = 0x12,
    /// Host → device: render one frame.
    RenderRequest = 0x20,
    /// Device → host: pixels of one row segment.
    PixelSpan = 0x21,
    /// Device → host: the frame is complete.
    FrameEnd = 0x22,
    /// Device → host: counters of the frame.
    Stats = 0x23,
    /// Host → device: render a rectangle of a frame (SPEC.md §3.12).
    RenderRegion = 0x24,
    /// Device → host: the rectangle is complete (SPEC.md §3.12).
    RegionEnd = 0x25,
    /// Host → bootloader: an application image follows (SPEC.md §3.11).
    FlashBegin = 0x30,
    /// Host → bootloader: bytes of the application image.
    FlashChunk = 0x31,
    /// Bootloader → host: image bytes received / verified / booting.
    FlashAck = 0x32,
    /// Host → bootloader: jump to the verified image.
    FlashBoot = 0x33,
    /// Either direction: something went wrong.
    Error = 0x7F,
}

impl MsgType {
    /// Type for a header byte.
    pub fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            0x01 => Self::Hello,
            0x02 => Self::Version,
            0x10 => Self::SceneBegin,
            0x11 => Self::SceneChunk,
            0x12 => Self::SceneAck,
            0x20 => Self::RenderRequest,
            0x21 => Self::PixelSpan,
            0x22 => Self::FrameEnd,
            0x23 => Self::Stats,
            0x24 => Self::RenderRegion,
            0x25 => Self::RegionEnd,
            0x30 => Self::FlashBegin,
            0x31 => Self::FlashChunk,
            0x32 => Self::FlashAck,
            0x33 => Self::FlashBoot,
            0x7F => Self::Error,
            _ => return None,
        })
    }
}

/// Why a payload could not be encoded or decoded.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MsgError {
    /// Unknown message type byte.
    DecodeUnknownType,
    /// Payload shorter than the message requires.
    DecodeTruncated,
    /// Payload longer than the message allows.
    DecodeTrailingBytes,
    /// A field holds a value outside its range.
    DecodeBadField,
    /// Error text is not UTF-8.
    DecodeBadText,
    /// Output buffer too small.
    EncodeBufferTooSmall,
    /// A field cannot be encoded as given (data length disagrees with a count, too many entries).
    EncodeBadField,
}

impl MsgError {
    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::DecodeUnknownType => "unknown message type",
            Self::DecodeTruncated => "payload truncated",
            Self::DecodeTrailingBytes => "payload has trailing bytes",
            Self::DecodeBadField => "field out of range",
            Self::DecodeBadText => "error text is not UTF-8",
            Self::EncodeBufferTooSmall => "output buffer too small",
            Self::EncodeBadField => "field cannot be encoded as given",
        }
    }
}

impl core::fmt::Display for MsgError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for MsgError {}

impl MsgError {
    /// Error number used in `Error.detail` (SPEC.md §3.9): declaration order, from 1.
    pub const fn code(self) -> u32 {
        match self {
            Self::DecodeUnknownType => 1,
            Self::DecodeTruncated => 2,
            Self::DecodeTrailingBytes => 3,
            Self::DecodeBadField => 4,
            Self::DecodeBadText => 5,
            Self::EncodeBufferTooSmall => 6,
            Self::EncodeBadField => 7,
        }
    }
}

impl From<Truncated> for MsgError {
    fn from(_: Truncated) -> Self {
        Self::DecodeTruncated
    }
}
impl From<Overflow> for MsgError {
    fn from(_: Overflow) -> Self {
        Self::EncodeBufferTooSmall
    }
}

/// Pixel encodings of a [`Msg::PixelSpan`].
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum PixelEncoding {
    /// 3 bytes per pixel: R, G, B.
    Rgb888 = 0,
    /// 2 bytes per pixel, LE `r5 << 11 | g6 << 5 | b5` (lossy; see [`crate::pixel`]).
    Rgb565 = 1,
    /// Lossless run-length + delta byte code, variable length ([`crate::pixel`]).
    Rle = 2,
    /// Auxiliary: 4 bytes per pixel, the primitive id of the primary hit (LE), `u32::MAX` for
    /// a miss. Sent after the colour span of the same pixels when
    /// [`render_flags::PRIM_IDS`] is set; lets the host compare hits with a reference.
    PrimId32 = 0x80,
}

impl PixelEncoding {
    /// Bytes per pixel on the wire of a fixed-size encoding; 0 for the variable-size
    /// [`Self::Rle`] (use [`Self::fixed_bytes_per_pixel`] to tell them apart).
    pub const fn bytes_per_pixel(self) -> usize {
        match self.fixed_bytes_per_pixel() {
            Some(n) => n,
            None => 0,
        }
    }
    /// Bytes per pixel, `None` for a variable-size encoding.
    pub const fn fixed_bytes_per_pixel(self) -> Option<usize> {
        match self {
            Self::Rgb888 => Some(3),
            Self::Rgb565 => Some(2),
            Self::Rle => None,
            Self::PrimId32 => Some(4),
        }
    }
    /// True for the colour encodings a render request may ask for.
    pub const fn is_colour(self) -> bool {
        !matches!(self, Self::PrimId32)
    }
    /// Encoding for a wire byte.
    pub fn from_u8(b: u8) -> Option<Self> {
        match b {
            0 => Some(Self::Rgb888),
            1 => Some(Self::Rgb565),
            2 => Some(Self::Rle),
            0x80 => Some(Self::PrimId32),
            _ => None,
        }
    }
    /// The `Version.features` bit a device sets when it can send this encoding (0 for
    /// encodings every device sends).
    pub const fn feature_bit(self) -> u32 {
        match self {
            Self::Rgb565 => feature::RGB565,
            Self::Rle => feature::RLE,
            Self::Rgb888 | Self::PrimId32 => 0,
        }
    }
}

/// What the device says about itself in [`Msg::Version`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceInfo {
    /// UART protocol version the device speaks.
    pub protocol: u16,
    /// Firmware version major, minor, patch.
    pub firmware: [u8; 3],
    /// Board id: 0 = loopback simulator, 1 = qemu-virt, 2 = FPGA SoC.
    pub board: u8,
    /// Largest payload the device accepts.
    pub max_payload: u16,
    /// PEs of the attached co-processor.
    pub pe_count: u16,
    /// Largest grid (voxels) the device can hold.
    pub voxel_capacity: u32,
    /// Words of memory per PE.
    pub pe_mem_words: u32,
    /// Compiled-in pipeline stages (bit flags, SPEC.md §3.2).
    pub features: u32,
}

/// Compiled-in pipeline stages (bit flags in [`DeviceInfo::features`]).
pub mod feature {
    /// The shadow-ray stage is compiled in.
    pub const SHADOWS: u32 = 1 << 0;
    /// The device can send primitive-id spans ([`super::render_flags::PRIM_IDS`]).
    pub const PRIM_IDS: u32 = 1 << 1;
    /// Mirror-reflection rays ([`super::render_flags::REFLECTIONS`] is honoured; SPEC.md §3.13).
    pub const REFLECTIONS: u32 = 1 << 16;
    /// Procedural textures ([`super::render_flags::TEXTURES`] is honoured).
    pub const TEXTURES: u32 = 1 << 17;
    /// Specular highlights ([`super::render_flags::SPECULAR`] is honoured).
    pub const SPECULAR: u32 = 1 << 18;
    /// Row interpolation (seed 003; the `render_flags` interpolation fields are honoured).
    pub const INTERP: u32 = 1 << 19;
    /// Scenes with analytic primitives and ViRAY materials (the scene image of SPEC.md §5) are
    /// accepted.
    pub const ANALYTIC_PRIMITIVES: u32 = 1 << 20;
    /// The device renders `RenderRegion` requests (SPEC.md §3.12).
    pub const RENDER_REGION: u32 = 1 << 8;
    /// The device sends `Rgb565` spans.
    pub const RGB565: u32 = 1 << 9;
    /// The device sends `Rle` spans.
    pub const RLE: u32 = 1 << 10;
}

/// Render request options (bit flags in [`RenderRequest::flags`]).
pub mod render_flags {
    /// Trace shadow rays toward the light.
    pub const SHADOWS: u16 = 1 << 0;
    /// Also send the primitive id of every primary hit ([`super::PixelEncoding::PrimId32`]).
    pub const PRIM_IDS: u16 = 1 << 1;
    /// Pipeline plan (SPEC.md §3.13): trace mirror-reflection rays.
    pub const REFLECTIONS: u16 = 1 << 2;
    /// Pipeline plan: run the texture stage.
    pub const TEXTURES: u16 = 1 << 3;
    /// Pipeline plan: evaluate specular BRDFs.
    pub const SPECULAR: u16 = 1 << 4;
    /// Row interpolation: adapt the step per row (seed 003 §3.5); else a fixed step.
    pub const INTERP_ADAPTIVE: u16 = 1 << 5;
    /// Row interpolation step l (trace every (l+1)-th pixel), bits 9..6; 0 = off.
    pub const INTERP_STEP_SHIFT: u32 = 6;
    /// Mask of the step field.
    pub const INTERP_STEP_MASK: u16 = 0xF << INTERP_STEP_SHIFT;
    /// Row interpolation colour threshold EPS (8-bit levels, 0..=31), bits 14..10.
    pub const INTERP_EPS_SHIFT: u32 = 10;
    /// Mask of the EPS field.
    pub const INTERP_EPS_MASK: u16 = 0x1F << INTERP_EPS_SHIFT;

    /// The interpolation bits for step `l` (0..=15) and threshold `eps` (0..=31).
    pub const fn interp(step: u8, eps: u8, adaptive: bool) -> u16 {
        (((step as u16) & 0xF) << INTERP_STEP_SHIFT)
            | (((eps as u16) & 0x1F) << INTERP_EPS_SHIFT)
            | if adaptive { INTERP_ADAPTIVE } else { 0 }
    }
    /// Interpolation step l of `flags` (0 = off).
    pub const fn interp_step(flags: u16) -> u8 {
        ((flags & INTERP_STEP_MASK) >> INTERP_STEP_SHIFT) as u8
    }
    /// Interpolation threshold EPS of `flags`.
    pub const fn interp_eps(flags: u16) -> u8 {
        ((flags & INTERP_EPS_MASK) >> INTERP_EPS_SHIFT) as u8
    }
}

/// Camera, light and output settings of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderRequest {
    /// Frame id echoed in every pixel span and the frame end.
    pub frame: u16,
    /// Image width in pixels.
    pub width: u16,
    /// Image height in pixels.
    pub height: u16,
    /// Option bits, see [`render_flags`].
    pub flags: u16,
    /// Camera position.
    pub eye: [f32; 3],
    /// Point the camera looks at.
    pub target: [f32; 3],
    /// Up vector.
    pub up: [f32; 3],
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Point light position.
    pub light_pos: [f32; 3],
    /// Point light intensity (scales the diffuse term).
    pub light_intensity: f32,
    /// Ambient term.
    pub ambient: f32,
    /// Pixel encoding of the spans.
    pub encoding: PixelEncoding,
}

/// Payload size of a render request.
pub const RENDER_REQUEST_LEN: usize = 72;

/// A rectangle of a frame: columns `x0..x0+cols` of rows `y0..y0+rows` (SPEC.md §3.12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Region {
    /// First column.
    pub x0: u16,
    /// First row.
    pub y0: u16,
    /// Columns.
    pub cols: u16,
    /// Rows.
    pub rows: u16,
}

impl Region {
    /// The whole `width`×`height` frame.
    pub const fn full(width: u16, height: u16) -> Self {
        Self { x0: 0, y0: 0, cols: width, rows: height }
    }
    /// Pixels in the region.
    pub const fn pixels(&self) -> u64 {
        self.cols as u64 * self.rows as u64
    }
    /// True when the region is non-empty and lies inside a `width`×`height` frame.
    pub const fn fits(&self, width: u16, height: u16) -> bool {
        self.cols > 0
            && self.rows > 0
            && self.x0 as u32 + self.cols as u32 <= width as u32
            && self.y0 as u32 + self.rows as u32 <= height as u32
    }
}

/// Option bits of a `RenderRegion` (SPEC.md §3.12).
pub mod region_options {
    /// Render the region but send no spans: only `Stats` and `RegionEnd` (its CRC lets the
    /// host verify pixels it already holds when an earlier `RegionEnd` was lost).
    pub const CRC_ONLY: u16 = 1 << 0;
}

/// Payload size of a `RenderRegion`.
pub const RENDER_REGION_LEN: usize = 12 + RENDER_REQUEST_LEN;
/// Payload size of a `RegionEnd`.
pub const REGION_END_LEN: usize = 20;

/// Status of a [`Msg::SceneAck`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum SceneStatus {
    /// Bytes up to `next_offset` were accepted; send more.
    Receiving = 0,
    /// The whole image arrived, its CRC matched, and the co-processor accepted every PE block.
    Loaded = 1,
}

/// Device error codes of a [`Msg::Error`] (SPEC.md §3.9).
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorCode {
    /// A frame failed its CRC or framing; detail = frame error number.
    BadFrame,
    /// A message arrived that is not valid in the current state; detail = its type byte.
    UnexpectedMessage,
    /// The scene image was rejected; detail = scene error number.
    SceneRejected,
    /// The co-processor reported a protocol violation; detail = its ERROR word.
    Coprocessor,
    /// A render request arrived before a scene was loaded.
    NoScene,
    /// A request field is out of range; detail = field offset.
    BadRequest,
    /// A scene chunk arrived out of order; detail = expected offset.
    BadOffset,
    /// The bootloader refused an application image; detail = [`FlashError`] number.
    FlashRejected,
    /// A code this build does not know.
    Unknown(u16),
}

impl ErrorCode {
    /// Wire value.
    pub fn code(self) -> u16 {
        match self {
            Self::BadFrame => 1,
            Self::UnexpectedMessage => 2,
            Self::SceneRejected => 3,
            Self::Coprocessor => 4,
            Self::NoScene => 5,
            Self::BadRequest => 6,
            Self::BadOffset => 7,
            Self::FlashRejected => 8,
            Self::Unknown(c) => c,
        }
    }
    /// Code for a wire value.
    pub fn from_code(c: u16) -> Self {
        match c {
            1 => Self::BadFrame,
            2 => Self::UnexpectedMessage,
            3 => Self::SceneRejected,
            4 => Self::Coprocessor,
            5 => Self::NoScene,
            6 => Self::BadRequest,
            7 => Self::BadOffset,
            8 => Self::FlashRejected,
            c => Self::Unknown(c),
        }
    }
}

/// Version of the flash image format a bootloader accepts in [`Msg::FlashBegin`]
/// (SPEC.md §3.11).
pub const FLASH_FORMAT_VERSION: u16 = 1;

/// `DeviceInfo::features` bit set by a bootloader: it accepts the `Flash*` messages and no
/// scenes or renders (SPEC.md §3.2).
pub const FEATURE_BOOTLOADER: u32 = 1 << 31;

/// Status of a [`Msg::FlashAck`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum FlashStatus {
    /// Bytes up to `next_offset` were written; send more.
    Receiving = 0,
    /// The whole image is in memory and its CRC-32, read back from memory, matched.
    Verified = 1,
    /// The bootloader jumps to the entry point right after this message.
    Booting = 2,
}

/// Why a bootloader refused an image: the detail of `Error{FlashRejected}` (SPEC.md §3.11).
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    /// `FlashBegin.version` is not [`FLASH_FORMAT_VERSION`].
    BadVersion,
    /// The image is empty or larger than the application region.
    TooLarge,
    /// The load address is misaligned or the image does not lie inside the application region.
    BadAddress,
    /// The entry point is misaligned or outside the image.
    BadEntry,
    /// The CRC-32 read back from memory differs from `FlashBegin.crc`.
    BadCrc,
    /// A chunk or boot request arrived without an accepted `FlashBegin`.
    NotBegun,
    /// `FlashBoot` before the image was verified, or with another CRC.
    NotVerified,
    /// A chunk reaches past `FlashBegin.total_len`.
    Overrun,
}

impl FlashError {
    /// Wire number (declaration order, from 1).
    pub const fn code(self) -> u32 {
        match self {
            Self::BadVersion => 1,
            Self::TooLarge => 2,
            Self::BadAddress => 3,
            Self::BadEntry => 4,
            Self::BadCrc => 5,
            Self::NotBegun => 6,
            Self::NotVerified => 7,
            Self::Overrun => 8,
        }
    }
    /// Error for a wire number.
    pub const fn from_code(c: u32) -> Option<Self> {
        Some(match c {
            1 => Self::BadVersion,
            2 => Self::TooLarge,
            3 => Self::BadAddress,
            4 => Self::BadEntry,
            5 => Self::BadCrc,
            6 => Self::NotBegun,
            7 => Self::NotVerified,
            8 => Self::Overrun,
            _ => return None,
        })
    }
}

impl core::fmt::Display for FlashError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BadVersion => "unsupported flash image format version",
            Self::TooLarge => "image empty or larger than the application region",
            Self::BadAddress => "image outside the application region or misaligned",
            Self::BadEntry => "entry point outside the image or misaligned",
            Self::BadCrc => "CRC-32 read back from memory differs",
            Self::NotBegun => "no image transfer in progress",
            Self::NotVerified => "image not verified",
            Self::Overrun => "chunk past the end of the image",
        })
    }
}

/// Keys of the device statistics in a [`Msg::Stats`] (SPEC.md §3.8).
pub mod stat {
    /// Camera rays generated.
    pub const PRIMARY_RAYS: u8 = 1;
    /// Shadow rays generated.
    pub const SHADOW_RAYS: u8 = 2;
    /// Rays sent to the co-processor (all kinds).
    pub const COPROC_RAYS: u8 = 3;
    /// Rays that missed the grid box and cost no FSL words.
    pub const CULLED_RAYS: u8 = 4;
    /// FSL words written to the co-processor.
    pub const FSL_WORDS_OUT: u8 = 5;
    /// FSL words read from the co-processor.
    pub const FSL_WORDS_IN: u8 = 6;
    /// Ray–primitive tests the co-processor reported.
    pub const INTERSECTION_TESTS: u8 = 7;
    /// Co-processor cycles the co-processor reported.
    pub const COPROC_CYCLES: u8 = 8;
    /// Pixels sent.
    pub const PIXELS: u8 = 9;
    /// Traversal-list entries sent.
    pub const LIST_ENTRIES: u8 = 10;
    /// First key of the per-stage device counters (instructions), see SPEC.md §3.8.
    pub const STAGE_BASE: u8 = 0x40;
    /// Mirror-reflection rays generated (SPEC.md §3.13).
    pub const REFLECTION_RAYS: u8 = 0x20;
    /// Pixels filled by row interpolation instead of traced.
    pub const INTERPOLATED_PIXELS: u8 = 0x21;
    /// Centre pixels traced because a segment failed the interpolation test.
    pub const INTERP_RETRACES: u8 = 0x22;
    /// The pipeline plan the device followed (`render_flags` bits it honoured).
    pub const PLAN: u8 = 0x23;
    /// FSL words (both directions) of primary rays.
    pub const FSL_WORDS_PRIMARY: u8 = 0x24;
    /// FSL words (both directions) of shadow rays.
    pub const FSL_WORDS_SHADOW: u8 = 0x25;
    /// FSL words (both directions) of reflection rays.
    pub const FSL_WORDS_REFLECTION: u8 = 0x26;
}

/// Bytes per stats entry: key u8, value u64.
pub const STAT_ENTRY_LEN: usize = 9;

/// A decoded message borrowing variable parts from the payload.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Msg<'a> {
    /// Host → device session start.
    Hello {
        /// Protocol version the host speaks.
        protocol: u16,
    },
    /// Device → host answer to Hello.
    Version(DeviceInfo),
    /// Host → device: a scene image of `total_len` bytes with CRC-32 `crc` follows.
    SceneBegin {
        /// Image length.
        total_len: u32,
        /// CRC-32 of the whole image.
        crc: u32,
    },
    /// Host → device: image bytes at `offset`.
    SceneChunk {
        /// Offset of `data[0]` in the image.
        offset: u32,
        /// The bytes.
        data: &'a [u8],
    },
    /// Device → host acknowledgement.
    SceneAck {
        /// Bytes accepted so far (the next offset expected).
        next_offset: u32,
        /// Loading state.
        status: SceneStatus,
    },
    /// Host → device render request.
    RenderRequest(RenderRequest),
    /// Device → host pixels of row `y`, columns `x0..x0+count`.
    PixelSpan {
        /// Frame id.
        frame: u16,
        /// Row.
        y: u16,
        /// First column.
        x0: u16,
        /// Pixel count.
        count: u16,
        /// Encoding of `data`.
        encoding: PixelEncoding,
        /// Encoded pixels.
        data: &'a [u8],
    },
    /// Device → host end of frame.
    FrameEnd {
        /// Frame id.
        frame: u16,
        /// Pixel spans sent for this frame.
        spans: u32,
        /// CRC-32 of the whole image as RGB888, row-major.
        image_crc: u32,
    },
    /// Host → device: render `region` of the frame `request` describes (SPEC.md §3.12).
    RenderRegion {
        /// The rectangle.
        region: Region,
        /// Most pixels per colour span; 0 = the device's default.
        max_span: u16,
        /// Option bits, see [`region_options`].
        options: u16,
        /// Camera, light, size, flags and encoding of the frame.
        request: RenderRequest,
    },
    /// Device → host: every span of `region` has been sent.
    RegionEnd {
        /// Frame id.
        frame: u16,
        /// The rectangle.
        region: Region,
        /// PixelSpan messages sent for it (both encodings).
        spans: u32,
        /// CRC-32 of the region's pixels as decoded RGB888, row-major.
        crc: u32,
    },
    /// Device → host counters; `entries` is a list of (key u8, value u64).
    Stats {
        /// Frame id.
        frame: u16,
        /// Raw entries, [`STAT_ENTRY_LEN`] bytes each; iterate with [`stat_entries`].
        entries: &'a [u8],
    },
    /// Error report.
    Error {
        /// What went wrong.
        code: ErrorCode,
        /// Code-specific detail.
        detail: u32,
        /// Human-readable text (≤ 128 bytes).
        text: &'a str,
    },
    /// Host → bootloader: an application image of `total_len` bytes is to be written at
    /// `load_addr` and started at `entry` (SPEC.md §3.11).
    FlashBegin {
        /// Flash image format version, [`FLASH_FORMAT_VERSION`].
        version: u16,
        /// Image length in bytes.
        total_len: u32,
        /// CRC-32 of the whole image.
        crc: u32,
        /// Target address of image byte 0.
        load_addr: u32,
        /// Address the bootloader jumps to.
        entry: u32,
    },
    /// Host → bootloader: image bytes at `offset`.
    FlashChunk {
        /// Offset of `data[0]` in the image.
        offset: u32,
        /// The bytes.
        data: &'a [u8],
    },
    /// Bootloader → host acknowledgement.
    FlashAck {
        /// Bytes written so far (the next offset expected).
        next_offset: u32,
        /// Transfer state.
        status: FlashStatus,
        /// CRC-32 read back from memory over the whole image (`Verified`, `Booting`); 0 while
        /// `Receiving`.
        crc: u32,
    },
    /// Host → bootloader: start the verified image whose CRC-32 is `crc`.
    FlashBoot {
        /// CRC-32 of the image to start (must equal the verified one).
        crc: u32,
    },
}

/// Longest error text.
pub const MAX_ERROR_TEXT: usize = 128;

/// Iterates over the (key, value) entries of a stats payload.
pub fn stat_entries(entries: &[u8]) -> impl Iterator<Item = (u8, u64)> + '_ {
    entries.chunks_exact(STAT_ENTRY_LEN).map(|c| {
        let mut v = [0u8; 8];
        v.copy_from_slice(c.get(1..9).unwrap_or(&[0; 8]));
        (c.first().copied().unwrap_or(0), u64::from_le_bytes(v))
    })
}

impl<'a> Msg<'a> {
    /// The type byte of this message.
    pub fn kind(&self) -> MsgType {
        match self {
            Self::Hello { .. } => MsgType::Hello,
            Self::Version(_) => MsgType::Version,
            Self::SceneBegin { .. } => MsgType::SceneBegin,
            Self::SceneChunk { .. } => MsgType::SceneChunk,
            Self::SceneAck { .. } => MsgType::SceneAck,
            Self::RenderRequest(_) => MsgType::RenderRequest,
            Self::PixelSpan { .. } => MsgType::PixelSpan,
            Self::FrameEnd { .. } => MsgType::FrameEnd,
            Self::Stats { .. } => MsgType::Stats,
            Self::RenderRegion { .. } => MsgType::RenderRegion,
            Self::RegionEnd { .. } => MsgType::RegionEnd,
            Self::FlashBegin { .. } => MsgType::FlashBegin,
            Self::FlashChunk { .. } => MsgType::FlashChunk,
            Self::FlashAck { .. } => MsgType::FlashAck,
            Self::FlashBoot { .. } => MsgType::FlashBoot,
            Self::Error { .. } => MsgType::Error,
        }
    }

    /// Writes the payload into `out` and returns its length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, MsgError> {
        let mut w = Writer::new(out);
        match *self {
            Self::Hello { protocol } => {
                w.u16(protocol)?;
                w.u16(0)?;
            }
            Self::Version(d) => {
                w.u16(d.protocol)?;
                w.bytes(&d.firmware)?;
                w.u8(d.board)?;
                w.u16(d.max_payload)?;
                w.u16(d.pe_count)?;
                w.u32(d.voxel_capacity)?;
                w.u32(d.pe_mem_words)?;
                w.u32(d.features)?;
            }
            Self::SceneBegin { total_len, crc } => {
                w.u32(total_len)?;
                w.u32(crc)?;
            }
            Self::SceneChunk { offset, data } => {
                w.u32(offset)?;
                w.bytes(data)?;
            }
            Self::SceneAck { next_offset, status } => {
                w.u32(next_offset)?;
                w.u8(status as u8)?;
                w.bytes(&[0; 3])?;
            }
            Self::RenderRequest(r) => write_request(&mut w, &r)?,
            Self::RenderRegion { region, max_span, options, request } => {
                write_region(&mut w, region)?;
                w.u16(max_span)?;
                w.u16(options)?;
                write_request(&mut w, &request)?;
            }
            Self::RegionEnd { frame, region, spans, crc } => {
                w.u16(frame)?;
                w.u16(0)?;
                write_region(&mut w, region)?;
                w.u32(spans)?;
                w.u32(crc)?;
            }
            Self::PixelSpan { frame, y, x0, count, encoding, data } => {
                if !span_data_valid(encoding, count, data) {
                    return Err(MsgError::EncodeBadField);
                }
                w.u16(frame)?;
                w.u16(y)?;
                w.u16(x0)?;
                w.u16(count)?;
                w.u8(encoding as u8)?;
                w.u8(0)?;
                w.bytes(data)?;
            }
            Self::FrameEnd { frame, spans, image_crc } => {
                w.u16(frame)?;
                w.u16(0)?;
                w.u32(spans)?;
                w.u32(image_crc)?;
            }
            Self::Stats { frame, entries } => {
                if entries.len() % STAT_ENTRY_LEN != 0 || entries.len() / STAT_ENTRY_LEN > u16::MAX as usize {
                    return Err(MsgError::EncodeBadField);
                }
                w.u16(frame)?;
                w.u16((entries.len() / STAT_ENTRY_LEN) as u16)?;
                w.bytes(entries)?;
            }
            Self::FlashBegin { version, total_len, crc, load_addr, entry } => {
                w.u16(version)?;
                w.u16(0)?;
                w.u32(total_len)?;
                w.u32(crc)?;
                w.u32(load_addr)?;
                w.u32(entry)?;
            }
            Self::FlashChunk { offset, data } => {
                w.u32(offset)?;
                w.bytes(data)?;
            }
            Self::FlashAck { next_offset, status, crc } => {
                w.u32(next_offset)?;
                w.u8(status as u8)?;
                w.bytes(&[0; 3])?;
                w.u32(crc)?;
            }
            Self::FlashBoot { crc } => {
                w.u32(crc)?;
            }
            Self::Error { code, detail, text } => {
                // Cut at a character boundary so the decoder's UTF-8 check accepts it.
                let mut cut = MAX_ERROR_TEXT.min(text.len());
                while !text.is_char_boundary(cut) {
                    cut -= 1;
                }
                let text = text.as_bytes().get(..cut).unwrap_or(&[]);
                w.u16(code.code())?;
                w.u16(text.len() as u16)?;
                w.u32(detail)?;
                w.bytes(text)?;
            }
        }
        Ok(w.len())
    }

    /// Decodes a payload of message type `kind`.
    pub fn decode(kind: u8, payload: &'a [u8]) -> Result<Self, MsgError> {
        let ty = MsgType::from_u8(kind).ok_or(MsgError::DecodeUnknownType)?;
        let mut r = Reader::new(payload);
        let msg = match ty {
            MsgType::Hello => {
                let protocol = r.u16()?;
                let _ = r.u16()?;
                Self::Hello { protocol }
            }
            MsgType::Version => Self::Version(DeviceInfo {
                protocol: r.u16()?,
                firmware: [r.u8()?, r.u8()?, r.u8()?],
                board: r.u8()?,
                max_payload: r.u16()?,
                pe_count: r.u16()?,
                voxel_capacity: r.u32()?,
                pe_mem_words: r.u32()?,
                features: r.u32()?,
            }),
            MsgType::SceneBegin => Self::SceneBegin { total_len: r.u32()?, crc: r.u32()? },
            MsgType::SceneChunk => Self::SceneChunk { offset: r.u32()?, data: r.rest() },
            MsgType::SceneAck => {
                let next_offset = r.u32()?;
                let status = match r.u8()? {
                    0 => SceneStatus::Receiving,
                    1 => SceneStatus::Loaded,
                    _ => return Err(MsgError::DecodeBadField),
                };
                let _ = r.take(3)?;
                Self::SceneAck { next_offset, status }
            }
            MsgType::RenderRequest => Self::RenderRequest(read_request(&mut r)?),
            MsgType::RenderRegion => {
                let region = read_region(&mut r)?;
                let max_span = r.u16()?;
                let options = r.u16()?;
                Self::RenderRegion { region, max_span, options, request: read_request(&mut r)? }
            }
            MsgType::RegionEnd => {
                let frame = r.u16()?;
                let _ = r.u16()?;
                Self::RegionEnd { frame, region: read_region(&mut r)?, spans: r.u32()?, crc: r.u32()? }
            }
            MsgType::PixelSpan => {
                let frame = r.u16()?;
                let y = r.u16()?;
                let x0 = r.u16()?;
                let count = r.u16()?;
                let encoding = PixelEncoding::from_u8(r.u8()?).ok_or(MsgError::DecodeBadField)?;
                let _ = r.u8()?;
                let data = r.rest();
                if !span_data_valid(encoding, count, data) {
                    return Err(MsgError::DecodeBadField);
                }
                Self::PixelSpan { frame, y, x0, count, encoding, data }
            }
            MsgType::FrameEnd => {
                let frame = r.u16()?;
                let _ = r.u16()?;
                Self::FrameEnd { frame, spans: r.u32()?, image_crc: r.u32()? }
            }
            MsgType::Stats => {
                let frame = r.u16()?;
                let n = r.u16()? as usize;
                let entries = r.take(n * STAT_ENTRY_LEN)?;
                Self::Stats { frame, entries }
            }
            MsgType::FlashBegin => {
                let version = r.u16()?;
                let _ = r.u16()?;
                Self::FlashBegin { version, total_len: r.u32()?, crc: r.u32()?, load_addr: r.u32()?, entry: r.u32()? }
            }
            MsgType::FlashChunk => Self::FlashChunk { offset: r.u32()?, data: r.rest() },
            MsgType::FlashAck => {
                let next_offset = r.u32()?;
                let status = match r.u8()? {
                    0 => FlashStatus::Receiving,
                    1 => FlashStatus::Verified,
                    2 => FlashStatus::Booting,
                    _ => return Err(MsgError::DecodeBadField),
                };
                let _ = r.take(3)?;
                Self::FlashAck { next_offset, status, crc: r.u32()? }
            }
            MsgType::FlashBoot => Self::FlashBoot { crc: r.u32()? },
            MsgType::Error => {
                let code = ErrorCode::from_code(r.u16()?);
                let len = r.u16()? as usize;
                if len > MAX_ERROR_TEXT {
                    return Err(MsgError::DecodeBadField);
                }
                let detail = r.u32()?;
                let text = core::str::from_utf8(r.take(len)?).map_err(|_| MsgError::DecodeBadText)?;
                Self::Error { code, detail, text }
            }
        };
        if r.remaining() != 0 {
            return Err(MsgError::DecodeTrailingBytes);
        }
        Ok(msg)
    }
}

fn write_request(w: &mut Writer<'_>, r: &RenderRequest) -> Result<(), MsgError> {
    w.u16(r.frame)?;
    w.u16(r.width)?;
    w.u16(r.height)?;
    w.u16(r.flags)?;
    w.vec3(r.eye)?;
    w.vec3(r.target)?;
    w.vec3(r.up)?;
    w.f32(r.fov_y_deg)?;
    w.vec3(r.light_pos)?;
    w.f32(r.light_intensity)?;
    w.f32(r.ambient)?;
    w.u8(r.encoding as u8)?;
    w.bytes(&[0; 3])?;
    Ok(())
}

fn read_request(r: &mut Reader<'_>) -> Result<RenderRequest, MsgError> {
    let req = RenderRequest {
        frame: r.u16()?,
        width: r.u16()?,
        height: r.u16()?,
        flags: r.u16()?,
        eye: r.vec3()?,
        target: r.vec3()?,
        up: r.vec3()?,
        fov_y_deg: r.f32()?,
        light_pos: r.vec3()?,
        light_intensity: r.f32()?,
        ambient: r.f32()?,
        encoding: PixelEncoding::from_u8(r.u8()?).ok_or(MsgError::DecodeBadField)?,
    };
    let _ = r.take(3)?;
    Ok(req)
}

fn write_region(w: &mut Writer<'_>, g: Region) -> Result<(), MsgError> {
    w.u16(g.x0)?;
    w.u16(g.y0)?;
    w.u16(g.cols)?;
    w.u16(g.rows)?;
    Ok(())
}

fn read_region(r: &mut Reader<'_>) -> Result<Region, MsgError> {
    Ok(Region { x0: r.u16()?, y0: r.u16()?, cols: r.u16()?, rows: r.u16()? })
}

/// `data` holds exactly `count` pixels of `encoding` (for `Rle`: decodes to exactly `count`).
fn span_data_valid(encoding: PixelEncoding, count: u16, data: &[u8]) -> bool {
    match encoding.fixed_bytes_per_pixel() {
        Some(bpp) => data.len() == count as usize * bpp,
        None => crate::pixel::rle_validate(count as usize, data).is_ok(),
    }
}
