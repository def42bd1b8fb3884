//! The messages ([`Msg`]), their type bytes ([`MsgType`]) and the fields that belong to no
//! other module: scene upload status and device error codes.

use super::device::DeviceInfo;
use super::flash::FlashStatus;
use super::render::{PixelEncoding, Region, RenderRequest};
use super::sack::Sack;

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
    /// Host → device: bytes of the scene image, windowed (SPEC.md §3.14).
    SceneData = 0x13,
    /// Device → host: selective acknowledgement of `SceneData` (SPEC.md §3.14).
    SceneSack = 0x14,
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
    /// Host → bootloader: bytes of the application image, windowed (SPEC.md §3.14).
    FlashData = 0x34,
    /// Bootloader → host: selective acknowledgement of `FlashData` (SPEC.md §3.14).
    FlashSack = 0x35,
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
            0x13 => Self::SceneData,
            0x14 => Self::SceneSack,
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
            0x34 => Self::FlashData,
            0x35 => Self::FlashSack,
            0x7F => Self::Error,
            _ => return None,
        })
    }
}

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
    /// The bootloader refused an application image; detail = [`FlashError`](super::FlashError) number.
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
    /// Host → device: image bytes at `offset`, any order inside the device's window
    /// (SPEC.md §3.14); no data asks for a `SceneSack` only.
    SceneData {
        /// Offset of `data[0]` in the image.
        offset: u32,
        /// The bytes.
        data: &'a [u8],
    },
    /// Device → host selective acknowledgement of a `SceneData`.
    SceneSack {
        /// Loading state (`Loaded` once the whole image is in and checked).
        status: SceneStatus,
        /// What the device holds.
        sack: Sack,
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
        /// Option bits, see [`region_options`](super::region_options).
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
        /// Raw entries, [`STAT_ENTRY_LEN`](super::STAT_ENTRY_LEN) bytes each; iterate with [`stat_entries`](super::stat_entries).
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
        /// Flash image format version, [`FLASH_FORMAT_VERSION`](super::FLASH_FORMAT_VERSION).
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
    /// Host → bootloader: image bytes at `offset`, any order inside the bootloader's window
    /// (SPEC.md §3.14); no data asks for a `FlashSack` only.
    FlashData {
        /// Offset of `data[0]` in the image.
        offset: u32,
        /// The bytes.
        data: &'a [u8],
    },
    /// Bootloader → host selective acknowledgement of a `FlashData`.
    FlashSack {
        /// `Receiving`, or `Verified` once the whole image is in memory and its CRC-32 read
        /// back matched.
        status: FlashStatus,
        /// What the bootloader holds.
        sack: Sack,
    },
}

/// Longest error text.
pub const MAX_ERROR_TEXT: usize = 128;

impl<'a> Msg<'a> {
    /// The type byte of this message.
    pub fn kind(&self) -> MsgType {
        match self {
            Self::Hello { .. } => MsgType::Hello,
            Self::Version(_) => MsgType::Version,
            Self::SceneBegin { .. } => MsgType::SceneBegin,
            Self::SceneChunk { .. } => MsgType::SceneChunk,
            Self::SceneAck { .. } => MsgType::SceneAck,
            Self::SceneData { .. } => MsgType::SceneData,
            Self::SceneSack { .. } => MsgType::SceneSack,
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
            Self::FlashData { .. } => MsgType::FlashData,
            Self::FlashSack { .. } => MsgType::FlashSack,
            Self::Error { .. } => MsgType::Error,
        }
    }
}
