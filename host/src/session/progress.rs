//! Progress events: the library reports, the binary draws.

use std::time::Duration;

use gridrt_shared::msg::{DeviceInfo, Region};

use super::error::Stage;

/// Where a long operation stands: emitted at least once a second while an upload, a flash
/// or a render runs, whether or not it advances, so a front end can show progress (and
/// silence) at any rate it likes.
#[derive(Debug, Clone, PartialEq)]
pub struct Activity {
    /// The operation.
    pub stage: Stage,
    /// Payload done: image bytes acknowledged (upload, flash) or pixels verified (render).
    pub done: u64,
    /// Payload received: for a render, pixels of the rows whose spans all arrived (each
    /// passed its frame CRC), verified or not yet; otherwise = `done`.
    pub received: u64,
    /// Payload in all.
    pub total: u64,
    /// Wire bytes sent in this operation so far.
    pub wire_tx: u64,
    /// Wire bytes received in this operation so far.
    pub wire_rx: u64,
    /// Time since the operation started.
    pub elapsed: Duration,
    /// Chunks sent again (upload, flash) or pixel runs requested again (render).
    pub retransmits: u64,
    /// Frames seen lost or corrupted on the line so far, both directions.
    pub line_errors: u64,
    /// Payload bytes per frame in use (chunk size; for a render, the span data limit,
    /// 0 = the device's default).
    pub chunk: usize,
    /// The last message heard from the device and how long ago.
    pub last_heard: String,
}

/// Progress of a session operation.
///
/// Order: `Connected` once per [`Session::hello`](crate::session::Session::hello); for an upload `UploadStarted`, then any
/// number of `Uploaded`/`UploadRewound`, then `UploadFinished`; for a render `RenderStarted`,
/// `RowArrived` as each row's pixels are all in, `RowReceived` once per verified row (rows
/// may complete in any order), then `Finished`.
/// When an operation fails, no further events are emitted for it and the error is returned.
#[derive(Debug, Clone, PartialEq)]
pub enum ProgressEvent {
    /// The device answered `Hello`.
    Connected(DeviceInfo),
    /// A scene upload of `total` bytes started.
    UploadStarted {
        /// Image size in bytes.
        total: u64,
    },
    /// The device acknowledged `bytes` bytes of the image so far.
    Uploaded {
        /// Acknowledged bytes.
        bytes: u64,
        /// Image size in bytes.
        total: u64,
    },
    /// Chunks from `offset` on are sent again (device asked for it or nothing was acknowledged).
    UploadRewound {
        /// Offset sending restarts from.
        offset: u64,
    },
    /// The device loaded the scene.
    UploadFinished {
        /// Image size in bytes.
        total: u64,
    },
    /// A frame was requested.
    RenderStarted {
        /// Width in pixels.
        width: u16,
        /// Height in pixels.
        height: u16,
    },
    /// Every pixel of row `y` (from column `x0`, the band's width) arrived in spans that
    /// passed their frame CRC; its region's CRC may still be checked later (then
    /// `RowReceived` / `RowVerified`). Sent as the row arrives, never held to the frame's end.
    RowArrived {
        /// The row.
        y: u16,
        /// First column of `rgb`.
        x0: u16,
        /// The row's pixels, RGB8.
        rgb: Vec<u8>,
    },
    /// Row `y` is complete and verified; `rows_done` rows are complete in total.
    RowReceived {
        /// The row.
        y: u16,
        /// Completed rows.
        rows_done: u32,
    },
    /// The frame arrived complete and verified.
    Finished,
    /// Row `y` of a band is verified ([`Session::render_band`](crate::session::Session::render_band); `render` turns these into
    /// `RowReceived`).
    RowVerified {
        /// The row.
        y: u16,
    },
    /// Pixels of `region` are requested again (selective repeat).
    Resend {
        /// What is requested.
        region: Region,
    },
    /// The device reset; the scene is uploaded again and the render resumes.
    DeviceReset,
    /// Where the running operation stands (at least once a second).
    Activity(Activity),
}
