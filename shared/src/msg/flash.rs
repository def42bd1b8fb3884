//! The flash bootloader's messages' fields (SPEC.md §3.11): format version, status and why
//! an image was refused.

/// Version of the flash image format a bootloader accepts in [`Msg::FlashBegin`](crate::msg::Msg::FlashBegin)
/// (SPEC.md §3.11).
pub const FLASH_FORMAT_VERSION: u16 = 1;

/// `DeviceInfo::features` bit set by a bootloader: it accepts the `Flash*` messages and no
/// scenes or renders (SPEC.md §3.2).
pub const FEATURE_BOOTLOADER: u32 = 1 << 31;

/// Status of a [`Msg::FlashAck`](crate::msg::Msg::FlashAck).
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
