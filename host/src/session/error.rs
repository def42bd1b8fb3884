//! Why a session operation failed, and in which stage.

use std::time::Duration;

use gridrt_shared::msg::ErrorCode;

/// Which part of the protocol a session was in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Waiting for `Version`.
    Hello,
    /// Uploading the scene image.
    Upload,
    /// Receiving a frame.
    Render,
    /// Writing an application image through the bootloader.
    Flash,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Hello => "hello",
            Self::Upload => "scene upload",
            Self::Render => "render",
            Self::Flash => "flash",
        })
    }
}

/// Why a session operation failed.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// Nothing useful arrived for too long.
    #[error("{port}: timed out during {stage} after {}ms without progress{}{} (last heard: {last_heard}; last sequence number received: {}, sent: {sent_seq})", waited.as_millis(), if what.is_empty() { "" } else { ": " }, what, fmt_seq(*last_seq))]
    Timeout {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// How long the session waited.
        waited: Duration,
        /// Sequence number of the last valid frame received, if any.
        last_seq: Option<u16>,
        /// Sequence number of the last frame the host sent.
        sent_seq: u16,
        /// What was being waited for (may be empty).
        what: String,
        /// The last message heard from the device, how long before the error.
        last_heard: String,
    },
    /// The transport failed.
    #[error("{port}: I/O error during {stage}: {source}")]
    Io {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// The transport reported end of stream.
    #[error("{port}: link closed during {stage} (last heard: {last_heard})")]
    Disconnected {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// The last message heard from the device.
        last_heard: String,
    },
    /// The device sent an `Error` message.
    #[error("{port}: device error during {stage}: {code:?} (detail {detail:#010x}): {text}")]
    Device {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// Error code.
        code: ErrorCode,
        /// Code-specific detail.
        detail: u32,
        /// Device text.
        text: String,
    },
    /// The device speaks another protocol version.
    #[error("{port}: device speaks protocol {device}, host speaks {host}")]
    VersionMismatch {
        /// Port name.
        port: String,
        /// Device protocol.
        device: u16,
        /// Host protocol.
        host: u16,
    },
    /// The device sent something that violates the protocol.
    #[error("{port}: protocol violation during {stage}: {what}")]
    Protocol {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// What was wrong.
        what: String,
    },
    /// The upload made no progress after repeated rewinds.
    #[error("{port}: scene upload stalled at offset {offset} after {rewinds} rewinds (last heard: {last_heard})")]
    UploadStalled {
        /// Port name.
        port: String,
        /// Last acknowledged offset.
        offset: u32,
        /// Rewinds performed.
        rewinds: u32,
        /// The last message heard from the device.
        last_heard: String,
    },
    /// `FrameEnd` arrived but some pixels (or primitive ids) never did.
    #[error("{port}: frame {frame} incomplete: {missing} {what} missing, first at (x {first_x}, y {first_y})")]
    MissingPixels {
        /// Port name.
        port: String,
        /// Frame id.
        frame: u16,
        /// `"pixels"` or `"primitive ids"`.
        what: &'static str,
        /// How many.
        missing: u64,
        /// First missing column.
        first_x: u16,
        /// First missing row.
        first_y: u16,
    },
    /// The assembled image does not match the CRC in `FrameEnd`.
    #[error("{port}: frame {frame} image CRC mismatch: device {device:#010x}, received image {received:#010x}")]
    ImageCrc {
        /// Port name.
        port: String,
        /// Frame id.
        frame: u16,
        /// CRC the device computed.
        device: u32,
        /// CRC of what arrived.
        received: u32,
    },
    /// The request or image cannot be sent (size limits).
    #[error("{port}: cannot send during {stage}: {what}")]
    BadInput {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
        /// What is wrong.
        what: String,
    },
}

fn fmt_seq(s: Option<u16>) -> String {
    s.map_or_else(|| "none".to_string(), |v| v.to_string())
}
