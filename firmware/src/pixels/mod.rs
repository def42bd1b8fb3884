//! Outbound frames: the UART frame encoder with the device's sequence number (`tx`:
//! [`FrameTx`]), and the pixel span packer with the running image CRC (`spans`:
//! [`SpanEncoder`]). Both are re-exported here: their paths are `crate::pixels::…`.
//!
//! Wire format: `shared::frame` (COBS + CRC-32 frames) carrying `shared::msg` payloads.
//! A frame's pixels leave as `PixelSpan` messages of one row segment each, in row-major order,
//! so the CRC-32 of the whole RGB888 image (sent in `FrameEnd`) can be computed on the fly
//! without holding the image.
//!
//! Output goes to any [`embedded_io::Write`] (the UART drivers of `crate::bsp`, a test
//! buffer, a channel). A write error has no one to be reported to: [`FrameTx`] counts it
//! ([`FrameTx::write_errors`]) and returns [`TxError::Write`], and the caller stops what it
//! was sending (the device stops the frame, see `crate::device`).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

mod spans;
mod tx;

pub use spans::{
    SpanEncoder, MAX_RLE_SPAN_PIXELS, MAX_SPAN_DATA, MAX_SPAN_PIXELS, MAX_SPAN_PIXELS_WITH_IDS, SPAN_HEADER_LEN,
};
pub use tx::{FrameTx, TxError};

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
pub(crate) mod tests;
