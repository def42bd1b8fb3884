//! Messages carried in UART frame payloads (SPEC.md §3). All integers little-endian.
//!
//! Decoders check exact lengths: a payload with missing or extra bytes is an error, never
//! a guess. Variable-length messages (scene chunk, pixel span, stats, error) carry their
//! variable part last.
//!
//! | module | what |
//! | --- | --- |
//! | `message` | [`Msg`], its [`MsgType`] bytes, the scene and error fields ([`SceneStatus`], [`ErrorCode`]) |
//! | `device` | [`DeviceInfo`] and the [`feature`] bits |
//! | `render` | [`RenderRequest`], [`render_flags`], [`Region`], [`region_options`], [`PixelEncoding`] |
//! | `flash` | the bootloader's fields ([`FlashStatus`], [`FlashError`]) |
//! | `sack` | the windowed transfers' acknowledgement ([`Sack`], [`SackRanges`]) |
//! | `stats` | the [`stat`] keys and [`stat_entries`] |
//! | `codec` | [`Msg::encode`], [`Msg::decode`], [`MsgError`] |
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

mod codec;
mod device;
mod flash;
mod message;
mod render;
mod sack;
mod stats;

pub use codec::MsgError;
pub use device::{feature, DeviceInfo};
pub use flash::{FlashError, FlashStatus, FEATURE_BOOTLOADER, FLASH_FORMAT_VERSION};
pub use message::{ErrorCode, Msg, MsgType, SceneStatus, MAX_ERROR_TEXT};
pub use render::{
    region_options, render_flags, PixelEncoding, Region, RenderRequest, REGION_END_LEN, RENDER_REGION_LEN,
    RENDER_REQUEST_LEN,
};
pub use sack::{Sack, SackRanges, MAX_SACK_RANGES, SACK_HEAD_LEN, SACK_RANGE_LEN};
pub use stats::{stat, stat_entries, STAT_ENTRY_LEN, STAT_HARTS};
