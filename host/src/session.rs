//! Protocol client: talks to a device (board, QEMU, loopback simulator) over any byte
//! transport.
//!
//! # Transport contract
//! `T: Read + Write`. `read` blocks until at least one byte is available or the transport's
//! own timeout expires, and then returns `Err(TimedOut)` or `Err(WouldBlock)` (what
//! `serialport` ports and the loopback `SimPort` do). `Ok(0)` means the link is gone.
//! The session keeps its own per-stage idle timeouts on top ([`SessionConfig`]); keep the
//! transport timeout short (tens of milliseconds) so the session can react in time.
//!
//! # Stages
//! - [`Session::hello`]: flushes the line with a `0x00` delimiter, sends `Hello` (up to three
//!   times) and waits for `Version`.
//! - [`Session::upload_scene`]: `SceneBegin`, then `SceneChunk`s of at most 1024 bytes with up to
//!   [`SessionConfig::window`] chunks in flight. The device must acknowledge every chunk with a
//!   `SceneAck { next_offset, Receiving }`. A device `Error(BadOffset, expected)` rewinds to
//!   the offset it expects (go-back-N; repeated reports of the same offset are handled once);
//!   if nothing is acknowledged for [`SessionConfig::retransmit_after`], the unacknowledged
//!   chunks are sent again. The upload ends at `SceneAck { Loaded }`.
//! - [`Session::render`]: `RenderRequest`, then `PixelSpan`s (and `Stats`) until `FrameEnd`. The
//!   frame is accepted only if every pixel arrived and the CRC-32 of the RGB888 image matches
//!   the one in `FrameEnd`. `Stats` must arrive before `FrameEnd`.
//!
//! Any device `Error` message ends the stage with [`SessionError::Device`]. The library never
//! prints; progress is reported through [`ProgressEvent`]s.

mod canvas;
mod client;
mod config;
mod error;
pub mod estimate;
mod link;
mod progress;
mod region;
mod render;
mod sender;
#[cfg(test)]
mod tests;
pub(crate) mod transfer;
mod upload;

pub use canvas::{decode_colour, merge_stat, Canvas};
pub(crate) use client::Incoming;
pub use client::Session;
pub use config::{SessionConfig, MAX_CHUNK, MIN_CHUNK};
pub use error::{SessionError, Stage};
pub use link::LinkStats;
pub use progress::{Activity, ProgressEvent};
pub use region::BandReport;
pub use render::RenderedFrame;
