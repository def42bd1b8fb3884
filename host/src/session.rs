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

use std::collections::BTreeMap;
use std::io::{ErrorKind, Read, Write};
use std::sync::Arc;
use std::time::{Duration, Instant};

use gridrt_shared::frame::{crc32, encode_frame, FeedResult, FrameAccumulator, FrameError, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{
    feature, render_flags, stat_entries, DeviceInfo, ErrorCode, Msg, MsgError, MsgType, PixelEncoding, Region,
    RenderRequest, SceneStatus,
};
use gridrt_shared::PROTOCOL_VERSION;

mod region;
pub use region::{decode_colour, merge_stat, BandReport, Canvas, LinkStats};

/// Largest scene chunk the host sends.
pub const MAX_CHUNK: usize = 1024;

/// Smallest scene chunk the upload shrinks to on a noisy line.
pub const MIN_CHUNK: usize = 64;

/// Which part of the protocol a session was in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Waiting for `Version`.
    Hello,
    /// Uploading the scene image.
    Upload,
    /// Receiving a frame.
    Render,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Hello => "hello",
            Self::Upload => "scene upload",
            Self::Render => "render",
        })
    }
}

/// Progress of a session operation.
///
/// Order: `Connected` once per [`Session::hello`]; for an upload `UploadStarted`, then any
/// number of `Uploaded`/`UploadRewound`, then `UploadFinished`; for a render `RenderStarted`,
/// `RowReceived` once per completed row (rows may complete in any order), then `Finished`.
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
    /// Row `y` is complete; `rows_done` rows are complete in total.
    RowReceived {
        /// The row.
        y: u16,
        /// Completed rows.
        rows_done: u32,
    },
    /// The frame arrived complete and verified.
    Finished,
    /// Row `y` of a band is verified ([`Session::render_band`]; `render` turns these into
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
}

/// Why a session operation failed.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// Nothing useful arrived for too long.
    #[error("{port}: timed out during {stage} after {}ms without progress{}{} (last sequence number received: {}, sent: {sent_seq})", waited.as_millis(), if what.is_empty() { "" } else { ": " }, what, fmt_seq(*last_seq))]
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
    #[error("{port}: link closed during {stage}")]
    Disconnected {
        /// Port name.
        port: String,
        /// Stage.
        stage: Stage,
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
    #[error("{port}: scene upload stalled at offset {offset} after {rewinds} rewinds")]
    UploadStalled {
        /// Port name.
        port: String,
        /// Last acknowledged offset.
        offset: u32,
        /// Rewinds performed.
        rewinds: u32,
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

/// Timeouts and flow control of a session. Setters are builder-style.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// Name of the port, used in error messages.
    pub port_name: String,
    /// Total time to wait for `Version` (split over three `Hello` attempts).
    pub hello_timeout: Duration,
    /// Longest time an upload may go without an acknowledgement before it fails.
    pub upload_timeout: Duration,
    /// Time without acknowledgement after which unacknowledged chunks are sent again.
    pub retransmit_after: Duration,
    /// Longest time a render may go without a message before it fails.
    pub render_timeout: Duration,
    /// Scene chunk size in bytes (capped at [`MAX_CHUNK`] and the device's payload limit).
    pub chunk_size: usize,
    /// Chunks in flight.
    pub window: usize,
    /// Rewinds allowed in a row without any new byte acknowledged before the upload gives up.
    pub max_rewinds: u32,
    /// Render with `RenderRegion` (selective repeat, reset recovery) when the device
    /// supports it; `false` uses the single `RenderRequest` of protocol v1.
    pub regions: bool,
    /// Rows per region when a frame is rendered with regions (0 = the whole frame).
    pub band_rows: u16,
    /// Requests per band before it fails.
    pub max_requests_per_band: u32,
}

impl SessionConfig {
    /// Defaults for a port called `port_name`: hello 3 s, upload 10 s (retransmit after 1 s),
    /// render 30 s idle, 1024-byte chunks, window of 4, 64 rewinds.
    pub fn new(port_name: impl Into<String>) -> Self {
        Self {
            port_name: port_name.into(),
            hello_timeout: Duration::from_secs(3),
            upload_timeout: Duration::from_secs(10),
            retransmit_after: Duration::from_secs(1),
            render_timeout: Duration::from_secs(30),
            chunk_size: MAX_CHUNK,
            window: 4,
            max_rewinds: 64,
            regions: true,
            band_rows: 0,
            max_requests_per_band: 10_000,
        }
    }
    /// Chooses regions or the v1 `RenderRequest` (see [`Self::regions`]).
    #[must_use]
    pub fn regions(mut self, on: bool) -> Self {
        self.regions = on;
        self
    }
    /// Sets the rows per region (0 = whole frame).
    #[must_use]
    pub fn band_rows(mut self, rows: u16) -> Self {
        self.band_rows = rows;
        self
    }
    /// Sets the request budget per band.
    #[must_use]
    pub fn max_requests_per_band(mut self, n: u32) -> Self {
        self.max_requests_per_band = n.max(1);
        self
    }
    /// Sets the consecutive rewinds without progress allowed during an upload.
    #[must_use]
    pub fn max_rewinds(mut self, n: u32) -> Self {
        self.max_rewinds = n;
        self
    }
    /// Sets the hello timeout.
    #[must_use]
    pub fn hello_timeout(mut self, d: Duration) -> Self {
        self.hello_timeout = d;
        self
    }
    /// Sets the upload timeout.
    #[must_use]
    pub fn upload_timeout(mut self, d: Duration) -> Self {
        self.upload_timeout = d;
        self
    }
    /// Sets the retransmit interval.
    #[must_use]
    pub fn retransmit_after(mut self, d: Duration) -> Self {
        self.retransmit_after = d;
        self
    }
    /// Sets the render idle timeout.
    #[must_use]
    pub fn render_timeout(mut self, d: Duration) -> Self {
        self.render_timeout = d;
        self
    }
    /// Sets the chunk size.
    #[must_use]
    pub fn chunk_size(mut self, n: usize) -> Self {
        self.chunk_size = n;
        self
    }
    /// Sets the window (chunks in flight, at least 1).
    #[must_use]
    pub fn window(mut self, n: usize) -> Self {
        self.window = n.max(1);
        self
    }
}

/// A received frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedFrame {
    /// Frame id.
    pub frame: u16,
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// RGB8 row-major.
    pub rgb: Vec<u8>,
    /// Primitive id per pixel (`u32::MAX` = miss), when requested with `PRIM_IDS`.
    pub prim_ids: Option<Vec<u32>>,
    /// Device counters by key ([`gridrt_shared::msg::stat`]).
    pub stats: BTreeMap<u8, u64>,
    /// CRC-32 of the image (verified).
    pub image_crc: u32,
    /// Span count the device reported in `FrameEnd`.
    pub spans_reported: u32,
    /// Spans received (both encodings).
    pub spans_received: u32,
    /// Bytes sent during the render (request included).
    pub bytes_tx: u64,
    /// Bytes received during the render.
    pub bytes_rx: u64,
    /// From sending the request to `FrameEnd`.
    pub elapsed: Duration,
    /// Retransmissions and line errors during the render.
    pub link: LinkStats,
}

/// Owned form of the device → host messages.
#[derive(Debug, Clone, PartialEq)]
enum Incoming {
    Version(DeviceInfo),
    SceneAck { next_offset: u32, status: SceneStatus },
    PixelSpan { frame: u16, y: u16, x0: u16, count: u16, encoding: PixelEncoding, data: Vec<u8> },
    FrameEnd { frame: u16, spans: u32, image_crc: u32 },
    RegionEnd { frame: u16, region: Region, spans: u32, crc: u32 },
    Stats { frame: u16, entries: Vec<(u8, u64)> },
    Error { code: ErrorCode, detail: u32, text: String },
    Other,
}

impl Incoming {
    fn from_msg(m: Msg<'_>) -> Self {
        match m {
            Msg::Version(d) => Self::Version(d),
            Msg::SceneAck { next_offset, status } => Self::SceneAck { next_offset, status },
            Msg::PixelSpan { frame, y, x0, count, encoding, data } => {
                Self::PixelSpan { frame, y, x0, count, encoding, data: data.to_vec() }
            }
            Msg::FrameEnd { frame, spans, image_crc } => Self::FrameEnd { frame, spans, image_crc },
            Msg::RegionEnd { frame, region, spans, crc } => Self::RegionEnd { frame, region, spans, crc },
            Msg::Stats { frame, entries } => Self::Stats { frame, entries: stat_entries(entries).collect() },
            Msg::Error { code, detail, text } => Self::Error { code, detail, text: text.to_string() },
            _ => Self::Other,
        }
    }
}

/// A protocol session over transport `T`.
#[derive(Debug)]
pub struct Session<T> {
    port: T,
    cfg: SessionConfig,
    acc: Box<FrameAccumulator<MAX_ENCODED>>,
    rx: Vec<u8>,
    rx_pos: usize,
    tx_seq: u16,
    last_rx_seq: Option<u16>,
    bytes_tx: u64,
    bytes_rx: u64,
    bad_frames: u64,
    device: Option<DeviceInfo>,
    /// Valid frames received.
    rx_frames: u64,
    /// Retransmission counters.
    link: LinkStats,
    /// The last scene uploaded (uploaded again after a device reset).
    scene: Option<Arc<[u8]>>,
    /// Line-quality estimate carried from band to band.
    sizer: Option<region::SpanSizer>,
}

impl<T: Read + Write> Session<T> {
    /// A session over `port`.
    pub fn new(port: T, cfg: SessionConfig) -> Self {
        Self {
            port,
            cfg,
            acc: Box::new(FrameAccumulator::new()),
            rx: Vec::with_capacity(4096),
            rx_pos: 0,
            tx_seq: 0,
            last_rx_seq: None,
            bytes_tx: 0,
            bytes_rx: 0,
            bad_frames: 0,
            device: None,
            rx_frames: 0,
            link: LinkStats::default(),
            scene: None,
            sizer: None,
        }
    }

    /// Retransmission and line-error counters since the session started.
    pub fn link_stats(&self) -> &LinkStats {
        &self.link
    }

    /// The configuration.
    pub fn config(&self) -> &SessionConfig {
        &self.cfg
    }
    /// What the device said in `Version`, after [`Self::hello`].
    pub fn device(&self) -> Option<&DeviceInfo> {
        self.device.as_ref()
    }
    /// Bytes written to the transport so far.
    pub fn bytes_tx(&self) -> u64 {
        self.bytes_tx
    }
    /// Bytes read from the transport so far.
    pub fn bytes_rx(&self) -> u64 {
        self.bytes_rx
    }
    /// Frames dropped for bad CRC, bad COBS or overflow (line noise) so far.
    pub fn bad_frames(&self) -> u64 {
        self.bad_frames
    }
    /// The transport.
    pub fn port_mut(&mut self) -> &mut T {
        &mut self.port
    }
    /// Ends the session and returns the transport.
    pub fn into_inner(self) -> T {
        self.port
    }

    fn io_err(&self, stage: Stage, source: std::io::Error) -> SessionError {
        SessionError::Io { port: self.cfg.port_name.clone(), stage, source }
    }

    fn timeout(&self, stage: Stage, waited: Duration) -> SessionError {
        SessionError::Timeout {
            port: self.cfg.port_name.clone(),
            stage,
            waited,
            last_seq: self.last_rx_seq,
            sent_seq: self.tx_seq.wrapping_sub(1),
            what: String::new(),
        }
    }

    fn protocol(&self, stage: Stage, what: impl Into<String>) -> SessionError {
        SessionError::Protocol { port: self.cfg.port_name.clone(), stage, what: what.into() }
    }

    fn device_err(&self, stage: Stage, code: ErrorCode, detail: u32, text: String) -> SessionError {
        SessionError::Device { port: self.cfg.port_name.clone(), stage, code, detail, text }
    }

    fn write_bytes(&mut self, stage: Stage, bytes: &[u8]) -> Result<(), SessionError> {
        self.port.write_all(bytes).map_err(|e| self.io_err(stage, e))?;
        self.port.flush().map_err(|e| self.io_err(stage, e))?;
        self.bytes_tx += bytes.len() as u64;
        Ok(())
    }

    fn send(&mut self, stage: Stage, msg: &Msg<'_>) -> Result<(), SessionError> {
        let mut payload = [0u8; MAX_PAYLOAD];
        let n = msg.encode(&mut payload).map_err(|e: MsgError| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage,
            what: e.to_string(),
        })?;
        let mut wire = [0u8; MAX_ENCODED];
        let len = encode_frame(msg.kind() as u8, self.tx_seq, &payload[..n], &mut wire)
            .map_err(|e| SessionError::BadInput { port: self.cfg.port_name.clone(), stage, what: e.to_string() })?;
        self.tx_seq = self.tx_seq.wrapping_add(1);
        self.write_bytes(stage, &wire[..len])
    }

    /// Next message, or `None` once `until` has passed without one.
    fn poll(&mut self, stage: Stage, until: Instant) -> Result<Option<Incoming>, SessionError> {
        let mut buf = [0u8; 4096];
        loop {
            while self.rx_pos < self.rx.len() {
                let total = self.rx.len();
                let decoded = match self.acc.feed(&self.rx[self.rx_pos..]) {
                    FeedResult::Consumed => {
                        self.rx_pos = total;
                        None
                    }
                    FeedResult::Overflow { rest } => {
                        self.bad_frames += 1;
                        self.link.resyncs += 1;
                        self.rx_pos = total - rest.len();
                        None
                    }
                    FeedResult::BadFrame { error, rest } => {
                        self.bad_frames += 1;
                        self.link.resyncs += 1;
                        if error == FrameError::DecodeBadCrc {
                            self.link.crc_errors += 1;
                        }
                        self.rx_pos = total - rest.len();
                        None
                    }
                    FeedResult::Frame { frame, rest } => {
                        let pos = total - rest.len();
                        let seq = frame.seq;
                        let msg = match Msg::decode(frame.kind, frame.payload) {
                            Ok(m) => Ok(Incoming::from_msg(m)),
                            Err(MsgError::DecodeUnknownType) => Ok(Incoming::Other),
                            Err(e) => Err(format!("undecodable {:?} message: {e}", MsgType::from_u8(frame.kind))),
                        };
                        Some((pos, seq, msg))
                    }
                };
                if let Some((pos, seq, msg)) = decoded {
                    self.rx_pos = pos;
                    // Frames lost in between, by sequence number (a device restarts at 0).
                    if let Some(last) = self.last_rx_seq {
                        let gap = seq.wrapping_sub(last).wrapping_sub(1);
                        if seq != 0 && gap < 0x8000 {
                            self.link.seq_gaps += gap as u64;
                        }
                    }
                    self.rx_frames += 1;
                    self.last_rx_seq = Some(seq);
                    return msg.map(Some).map_err(|w| self.protocol(stage, w));
                }
            }
            self.rx.clear();
            self.rx_pos = 0;
            if Instant::now() >= until {
                return Ok(None);
            }
            match self.port.read(&mut buf) {
                Ok(0) => return Err(SessionError::Disconnected { port: self.cfg.port_name.clone(), stage }),
                Ok(n) => {
                    self.bytes_rx += n as u64;
                    self.rx.extend_from_slice(&buf[..n]);
                }
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::Interrupted => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(1)),
                Err(e) => return Err(self.io_err(stage, e)),
            }
        }
    }

    /// Opens the session: flushes the line, sends `Hello`, returns the device's `Version`.
    pub fn hello(&mut self, progress: &mut dyn FnMut(ProgressEvent)) -> Result<DeviceInfo, SessionError> {
        let stage = Stage::Hello;
        self.acc.reset();
        self.rx.clear();
        self.rx_pos = 0;
        // A lone delimiter ends whatever noise the device may have buffered.
        self.write_bytes(stage, &[0])?;
        let start = Instant::now();
        let attempts = 3u32;
        for attempt in 1..=attempts {
            self.send(stage, &Msg::Hello { protocol: PROTOCOL_VERSION as u16 })?;
            let until = start + self.cfg.hello_timeout * attempt / attempts;
            while let Some(m) = self.poll(stage, until)? {
                match m {
                    Incoming::Version(info) => {
                        if info.protocol != PROTOCOL_VERSION as u16 {
                            return Err(SessionError::VersionMismatch {
                                port: self.cfg.port_name.clone(),
                                device: info.protocol,
                                host: PROTOCOL_VERSION as u16,
                            });
                        }
                        self.device = Some(info);
                        progress(ProgressEvent::Connected(info));
                        return Ok(info);
                    }
                    Incoming::Error { code: ErrorCode::BadFrame, .. } => {} // noise before our Hello
                    Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                    _ => {} // stale traffic from an earlier session
                }
            }
        }
        Err(self.timeout(stage, start.elapsed()))
    }

    /// Discards incoming messages until the line has been quiet for `quiet` (at most `max`).
    /// Used after a failed upload: the device answers every chunk still in flight with an
    /// error of its own, which must not be mistaken for an answer to the next request.
    fn drain(&mut self, stage: Stage, quiet: Duration, max: Duration) {
        let end = Instant::now() + max;
        loop {
            let until = (Instant::now() + quiet).min(end);
            match self.poll(stage, until) {
                Ok(Some(_)) if Instant::now() < end => {}
                _ => return,
            }
        }
    }

    /// Uploads a scene image and waits until the device has loaded it.
    ///
    /// When the device refuses the image, the answers to chunks still in flight are drained
    /// (until the line is quiet for up to `retransmit_after`) before the error is returned,
    /// so the session can go on with the next request.
    pub fn upload_scene(&mut self, image: &[u8], progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let r = self.upload_inner(image, progress);
        if matches!(
            r,
            Err(SessionError::Device { .. } | SessionError::Protocol { .. } | SessionError::UploadStalled { .. })
        ) {
            let quiet = self.cfg.retransmit_after.min(Duration::from_millis(250));
            self.drain(Stage::Upload, quiet, 10 * quiet);
        }
        r
    }

    fn upload_inner(&mut self, image: &[u8], progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let stage = Stage::Upload;
        let total = u32::try_from(image.len()).map_err(|_| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage,
            what: "scene image larger than 4 GiB".into(),
        })?;
        let device_cap = self.device.map_or(MAX_CHUNK, |d| (d.max_payload as usize).saturating_sub(4));
        let mut chunk = self.cfg.chunk_size.min(MAX_CHUNK).min(device_cap).clamp(1, MAX_PAYLOAD - 4);
        let min_chunk = MIN_CHUNK.min(chunk);
        let begin = Msg::SceneBegin { total_len: total, crc: crc32(image) };

        // A lone delimiter first: the device drops whatever noise it holds.
        self.write_bytes(stage, &[0])?;
        self.send(stage, &begin)?;
        progress(ProgressEvent::UploadStarted { total: total as u64 });
        let mut acked = 0u32;
        let mut next = 0u32;
        let mut sent_hi = 0u32;
        // Rewinds in a row without a new byte acknowledged.
        let mut stalls = 0u32;
        let mut rewound_to: Option<u32> = None;
        // Answers still expected to chunks sent before a restart (ignored).
        let mut stale = 0usize;
        let mut last_progress = Instant::now();
        loop {
            // Fill the window.
            let window = (self.cfg.window.max(1) * chunk) as u32;
            while next < total && next - acked.min(next) < window {
                let end = (next as usize + chunk).min(image.len());
                if next < sent_hi {
                    self.link.upload_chunks_resent += 1;
                }
                self.send(stage, &Msg::SceneChunk { offset: next, data: &image[next as usize..end] })?;
                next = end as u32;
                sent_hi = sent_hi.max(next);
            }
            if stalls > self.cfg.max_rewinds {
                return Err(SessionError::UploadStalled {
                    port: self.cfg.port_name.clone(),
                    offset: acked,
                    rewinds: stalls,
                });
            }
            let until = (Instant::now() + self.cfg.retransmit_after).min(last_progress + self.cfg.upload_timeout);
            let in_flight = ((next - acked.min(next)) as usize).div_ceil(chunk.max(1));
            let mut restart = false;
            match self.poll(stage, until)? {
                Some(Incoming::SceneAck { next_offset, status }) => {
                    if next_offset > total {
                        return Err(self
                            .protocol(stage, format!("ack of offset {next_offset} beyond the image ({total} bytes)")));
                    }
                    if next_offset > acked {
                        acked = next_offset;
                        stalls = 0;
                        stale = 0;
                        last_progress = Instant::now();
                        if rewound_to.is_some_and(|r| acked > r) {
                            rewound_to = None;
                        }
                        next = next.max(acked);
                        progress(ProgressEvent::Uploaded { bytes: acked as u64, total: total as u64 });
                    }
                    if status == SceneStatus::Loaded {
                        if next_offset != total {
                            return Err(self
                                .protocol(stage, format!("device reports Loaded at offset {next_offset} of {total}")));
                        }
                        // Kept for re-uploads after a device reset (SPEC.md §3.12).
                        if self.scene.as_deref() != Some(image) {
                            self.scene = Some(Arc::from(image));
                        }
                        progress(ProgressEvent::UploadFinished { total: total as u64 });
                        return Ok(());
                    }
                }
                Some(Incoming::Error { code: ErrorCode::BadOffset, detail, .. }) => {
                    if detail > total {
                        return Err(self.protocol(
                            stage,
                            format!("device expects offset {detail} beyond the image ({total} bytes)"),
                        ));
                    }
                    if stale > 0 {
                        stale -= 1;
                    } else if detail > sent_hi {
                        // The device holds another upload (our SceneBegin was lost): start over.
                        restart = true;
                    } else if detail >= acked && rewound_to != Some(detail) {
                        // An offset below what the device already acknowledged is a stale
                        // report; the same offset twice means the rewind is already under way.
                        stalls += 1;
                        rewound_to = Some(detail);
                        acked = detail;
                        next = detail;
                        progress(ProgressEvent::UploadRewound { offset: detail as u64 });
                    }
                }
                Some(Incoming::Error { code: ErrorCode::BadFrame, .. }) => {
                    // The device dropped a corrupt frame, most likely one of our chunks: go
                    // back to the last acknowledged offset with smaller chunks.
                    self.link.device_bad_frames += 1;
                    chunk = (chunk / 2).max(min_chunk);
                    if rewound_to != Some(acked) && next > acked {
                        stalls += 1;
                        rewound_to = Some(acked);
                        next = acked;
                        progress(ProgressEvent::UploadRewound { offset: acked as u64 });
                    }
                }
                Some(Incoming::Error { code: ErrorCode::UnexpectedMessage, detail, .. })
                    if detail == MsgType::SceneChunk as u32 =>
                {
                    // A chunk without an upload: SceneBegin was lost, or the device reset.
                    if stale > 0 {
                        stale -= 1;
                    } else {
                        restart = true;
                    }
                }
                Some(Incoming::Version(_)) if self.last_rx_seq == Some(0) => {
                    // The device's reset banner: it forgot the upload.
                    self.link.device_resets += 1;
                    restart = true;
                }
                Some(Incoming::Error { code, detail, text }) => return Err(self.device_err(stage, code, detail, text)),
                Some(_) => {}
                None => {
                    let idle = last_progress.elapsed();
                    if idle >= self.cfg.upload_timeout {
                        return Err(SessionError::Timeout {
                            port: self.cfg.port_name.clone(),
                            stage,
                            waited: idle,
                            last_seq: self.last_rx_seq,
                            sent_seq: self.tx_seq.wrapping_sub(1),
                            what: format!("acknowledgement of scene offset {acked} of {total}"),
                        });
                    }
                    self.link.timeouts += 1;
                    if next > acked {
                        // Nothing acknowledged for a while: go back and resend, smaller.
                        chunk = (chunk / 2).max(min_chunk);
                        stalls += 1;
                        next = acked;
                        rewound_to = Some(acked);
                        progress(ProgressEvent::UploadRewound { offset: acked as u64 });
                    }
                }
            }
            if restart {
                stalls += 1;
                stale = in_flight;
                acked = 0;
                next = 0;
                rewound_to = None;
                self.write_bytes(stage, &[0])?;
                self.send(stage, &begin)?;
                progress(ProgressEvent::UploadRewound { offset: 0 });
            }
        }
    }

    /// Requests one frame and assembles it.
    pub fn render(
        &mut self,
        req: &RenderRequest,
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<RenderedFrame, SessionError> {
        let stage = Stage::Render;
        let (w, h) = (req.width as usize, req.height as usize);
        if w == 0 || h == 0 {
            return Err(SessionError::BadInput {
                port: self.cfg.port_name.clone(),
                stage,
                what: "image size is zero".into(),
            });
        }
        let features = self.device.map_or(0, |d| d.features);
        if req.encoding.feature_bit() & !features != 0 {
            return Err(SessionError::BadInput {
                port: self.cfg.port_name.clone(),
                stage,
                what: format!("the device does not send {:?} spans (features {features:#x})", req.encoding),
            });
        }
        if self.cfg.regions && features & feature::RENDER_REGION != 0 {
            return self.render_regions(req, progress);
        }
        let want_ids = req.flags & render_flags::PRIM_IDS != 0;
        let (tx0, rx0) = (self.bytes_tx, self.bytes_rx);
        let link0 = self.link.clone();
        let start = Instant::now();
        self.send(stage, &Msg::RenderRequest(*req))?;
        progress(ProgressEvent::RenderStarted { width: req.width, height: req.height });

        let mut rgb = vec![0u8; 3 * w * h];
        let mut got_rgb = vec![false; w * h];
        let mut ids = if want_ids { Some(vec![u32::MAX; w * h]) } else { None };
        let mut got_ids = vec![false; if want_ids { w * h } else { 0 }];
        let mut row_left = vec![if want_ids { 2 * w } else { w }; h];
        let mut rows_done = 0u32;
        let mut stats = BTreeMap::new();
        let mut spans_received = 0u32;
        let mut last_msg = Instant::now();
        loop {
            let Some(m) = self.poll(stage, last_msg + self.cfg.render_timeout)? else {
                return Err(self.timeout(stage, last_msg.elapsed()));
            };
            last_msg = Instant::now();
            match m {
                Incoming::PixelSpan { frame, y, x0, count, encoding, data } => {
                    if frame != req.frame {
                        continue; // stale span of an earlier frame
                    }
                    let (y, x0, count) = (y as usize, x0 as usize, count as usize);
                    if y >= h || x0 + count > w {
                        return Err(
                            self.protocol(stage, format!("span y {y} x {x0}+{count} outside the {w}×{h} image"))
                        );
                    }
                    spans_received += 1;
                    let base = y * w + x0;
                    let newly = match encoding {
                        PixelEncoding::Rgb888 | PixelEncoding::Rgb565 | PixelEncoding::Rle => {
                            decode_colour(encoding, count, &data, &mut rgb[3 * base..3 * (base + count)])
                                .map_err(|w| self.protocol(stage, w))?;
                            got_rgb[base..base + count]
                                .iter_mut()
                                .map(|g| !std::mem::replace(g, true))
                                .filter(|&n| n)
                                .count()
                        }
                        PixelEncoding::PrimId32 => match ids.as_mut() {
                            Some(ids) => {
                                for (k, c) in data.chunks_exact(4).enumerate() {
                                    ids[base + k] = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                                }
                                got_ids[base..base + count]
                                    .iter_mut()
                                    .map(|g| !std::mem::replace(g, true))
                                    .filter(|&n| n)
                                    .count()
                            }
                            None => 0,
                        },
                        #[allow(unreachable_patterns)]
                        _ => return Err(self.protocol(stage, format!("unsupported pixel encoding {encoding:?}"))),
                    };
                    if newly > 0 {
                        row_left[y] -= newly;
                        if row_left[y] == 0 {
                            rows_done += 1;
                            progress(ProgressEvent::RowReceived { y: y as u16, rows_done });
                        }
                    }
                }
                Incoming::Stats { frame, entries } if frame == req.frame => {
                    stats.extend(entries);
                }
                Incoming::FrameEnd { frame, spans, image_crc } if frame == req.frame => {
                    if let Some(i) = got_rgb.iter().position(|g| !g) {
                        return Err(SessionError::MissingPixels {
                            port: self.cfg.port_name.clone(),
                            frame,
                            what: "pixels",
                            missing: got_rgb.iter().filter(|g| !**g).count() as u64,
                            first_x: (i % w) as u16,
                            first_y: (i / w) as u16,
                        });
                    }
                    if let Some(i) = got_ids.iter().position(|g| !g) {
                        return Err(SessionError::MissingPixels {
                            port: self.cfg.port_name.clone(),
                            frame,
                            what: "primitive ids",
                            missing: got_ids.iter().filter(|g| !**g).count() as u64,
                            first_x: (i % w) as u16,
                            first_y: (i / w) as u16,
                        });
                    }
                    let received = crc32(&rgb);
                    if received != image_crc {
                        return Err(SessionError::ImageCrc {
                            port: self.cfg.port_name.clone(),
                            frame,
                            device: image_crc,
                            received,
                        });
                    }
                    progress(ProgressEvent::Finished);
                    return Ok(RenderedFrame {
                        frame,
                        width: req.width,
                        height: req.height,
                        rgb,
                        prim_ids: ids,
                        stats,
                        image_crc,
                        spans_reported: spans,
                        spans_received,
                        bytes_tx: self.bytes_tx - tx0,
                        bytes_rx: self.bytes_rx - rx0,
                        elapsed: start.elapsed(),
                        link: self.link.since(&link0),
                    });
                }
                Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                _ => {}
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use gridrt_shared::msg::stat;
    use std::collections::VecDeque;

    /// Faults the fake device can inject.
    #[derive(Debug, Clone, Default)]
    pub struct Faults {
        /// Drop the scene chunk at this offset the first time it arrives.
        pub drop_chunk_at: Option<u32>,
        /// Answer the render request with a device error.
        pub render_error: bool,
        /// Do not send this row.
        pub skip_row: Option<u16>,
        /// Corrupt the image CRC in FrameEnd.
        pub bad_crc: bool,
        /// Stop answering after this many rows.
        pub go_silent_after_rows: Option<u16>,
        /// Garbage to send before every frame.
        pub noise: Vec<u8>,
        /// Reject the scene with this error.
        pub reject_scene: bool,
    }

    /// A scripted fake device: decodes the host's frames and answers as the firmware would.
    pub struct FakeDevice {
        acc: Box<FrameAccumulator<MAX_ENCODED>>,
        out: VecDeque<u8>,
        seq: u16,
        faults: Faults,
        expected: u32,
        total: u32,
        dropped: bool,
        pub scene: Vec<u8>,
        pub requests: Vec<RenderRequest>,
    }

    impl FakeDevice {
        pub fn new(faults: Faults) -> Self {
            Self {
                acc: Box::new(FrameAccumulator::new()),
                out: VecDeque::new(),
                seq: 100,
                faults,
                expected: 0,
                total: 0,
                dropped: false,
                scene: Vec::new(),
                requests: Vec::new(),
            }
        }

        fn emit(&mut self, msg: &Msg<'_>) {
            self.out.extend(self.faults.noise.iter().copied());
            let mut p = [0u8; MAX_PAYLOAD];
            let n = msg.encode(&mut p).unwrap();
            let mut w = [0u8; MAX_ENCODED];
            let len = encode_frame(msg.kind() as u8, self.seq, &p[..n], &mut w).unwrap();
            self.seq = self.seq.wrapping_add(1);
            self.out.extend(&w[..len]);
        }

        /// The test image: pixel (x, y) = (x, y, x ^ y).
        pub fn pixel(x: u16, y: u16) -> [u8; 3] {
            [x as u8, y as u8, (x ^ y) as u8]
        }

        fn handle(&mut self, kind: u8, payload: &[u8]) {
            let msg = Msg::decode(kind, payload).unwrap();
            match msg {
                Msg::Hello { .. } => self.emit(&Msg::Version(DeviceInfo {
                    protocol: PROTOCOL_VERSION as u16,
                    firmware: [0, 1, 0],
                    board: 0,
                    max_payload: MAX_PAYLOAD as u16,
                    pe_count: 4,
                    voxel_capacity: 1 << 20,
                    pe_mem_words: 1 << 16,
                    features: 1,
                })),
                Msg::SceneBegin { total_len, .. } => {
                    self.total = total_len;
                    self.expected = 0;
                    self.scene.clear();
                }
                Msg::SceneChunk { offset, data } => {
                    if self.faults.drop_chunk_at == Some(offset) && !self.dropped {
                        self.dropped = true;
                        return;
                    }
                    if offset != self.expected {
                        self.emit(&Msg::Error {
                            code: ErrorCode::BadOffset,
                            detail: self.expected,
                            text: "bad offset",
                        });
                        return;
                    }
                    self.scene.extend_from_slice(data);
                    self.expected += data.len() as u32;
                    if self.faults.reject_scene {
                        self.emit(&Msg::Error {
                            code: ErrorCode::SceneRejected,
                            detail: 8,
                            text: "PE block exceeds PE memory",
                        });
                        return;
                    }
                    let status = if self.expected == self.total { SceneStatus::Loaded } else { SceneStatus::Receiving };
                    self.emit(&Msg::SceneAck { next_offset: self.expected, status });
                }
                Msg::RenderRequest(r) => {
                    self.requests.push(r);
                    if self.faults.render_error {
                        self.emit(&Msg::Error { code: ErrorCode::NoScene, detail: 0, text: "no scene loaded" });
                        return;
                    }
                    let mut image = Vec::new();
                    let mut spans = 0;
                    for y in 0..r.height {
                        let row: Vec<u8> = (0..r.width).flat_map(|x| Self::pixel(x, y)).collect();
                        image.extend_from_slice(&row);
                        if self.faults.go_silent_after_rows.is_some_and(|n| y >= n) {
                            return;
                        }
                        if self.faults.skip_row == Some(y) {
                            continue;
                        }
                        self.emit(&Msg::PixelSpan {
                            frame: r.frame,
                            y,
                            x0: 0,
                            count: r.width,
                            encoding: PixelEncoding::Rgb888,
                            data: &row,
                        });
                        spans += 1;
                        if r.flags & render_flags::PRIM_IDS != 0 {
                            let ids: Vec<u8> =
                                (0..r.width).flat_map(|x| (x as u32 + 1000 * y as u32).to_le_bytes()).collect();
                            self.emit(&Msg::PixelSpan {
                                frame: r.frame,
                                y,
                                x0: 0,
                                count: r.width,
                                encoding: PixelEncoding::PrimId32,
                                data: &ids,
                            });
                            spans += 1;
                        }
                    }
                    let mut entries = Vec::new();
                    for (k, v) in
                        [(stat::PRIMARY_RAYS, (r.width as u64) * r.height as u64), (stat::COPROC_CYCLES, 12345)]
                    {
                        entries.push(k);
                        entries.extend_from_slice(&u64::to_le_bytes(v));
                    }
                    self.emit(&Msg::Stats { frame: r.frame, entries: &entries });
                    let crc = crc32(&image) ^ if self.faults.bad_crc { 1 } else { 0 };
                    self.emit(&Msg::FrameEnd { frame: r.frame, spans, image_crc: crc });
                }
                _ => {}
            }
        }
    }

    impl Write for FakeDevice {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let mut input = buf;
            loop {
                match self.acc.feed(input) {
                    FeedResult::Consumed => break,
                    FeedResult::Overflow { rest } | FeedResult::BadFrame { rest, .. } => input = rest,
                    FeedResult::Frame { frame, rest } => {
                        let (kind, payload) = (frame.kind, frame.payload.to_vec());
                        input = rest;
                        self.handle(kind, &payload);
                    }
                }
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Read for FakeDevice {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.out.is_empty() {
                std::thread::sleep(Duration::from_millis(1));
                return Err(ErrorKind::TimedOut.into());
            }
            // Deliver in small pieces, as a UART would.
            let n = buf.len().min(self.out.len()).min(97);
            for b in buf.iter_mut().take(n) {
                *b = self.out.pop_front().unwrap_or(0);
            }
            Ok(n)
        }
    }

    fn session(faults: Faults) -> Session<FakeDevice> {
        let cfg = SessionConfig::new("fake0")
            .hello_timeout(Duration::from_millis(300))
            .upload_timeout(Duration::from_millis(500))
            .retransmit_after(Duration::from_millis(100))
            .render_timeout(Duration::from_millis(200));
        Session::new(FakeDevice::new(faults), cfg)
    }

    fn request(w: u16, h: u16, flags: u16) -> RenderRequest {
        RenderRequest {
            frame: 3,
            width: w,
            height: h,
            flags,
            eye: [0.0, 0.0, 5.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 45.0,
            light_pos: [1.0; 3],
            light_intensity: 1.0,
            ambient: 0.15,
            encoding: PixelEncoding::Rgb888,
        }
    }

    #[test]
    fn hello_returns_device_info_and_emits_connected() {
        let mut s = session(Faults::default());
        let mut events = Vec::new();
        let info = s.hello(&mut |e| events.push(e)).unwrap();
        assert_eq!(info.pe_count, 4);
        assert_eq!(events, vec![ProgressEvent::Connected(info)]);
        assert_eq!(s.device(), Some(&info));
    }

    #[test]
    fn upload_sends_every_byte_and_finishes_on_loaded() {
        let mut s = session(Faults::default());
        s.hello(&mut |_| {}).unwrap();
        let image: Vec<u8> = (0..5000u32).map(|i| (i * 7) as u8).collect();
        let mut events = Vec::new();
        s.upload_scene(&image, &mut |e| events.push(e)).unwrap();
        assert_eq!(s.port_mut().scene, image);
        assert_eq!(events.first(), Some(&ProgressEvent::UploadStarted { total: 5000 }));
        assert_eq!(events.last(), Some(&ProgressEvent::UploadFinished { total: 5000 }));
        assert!(events.contains(&ProgressEvent::Uploaded { bytes: 5000, total: 5000 }));
    }

    #[test]
    fn upload_recovers_from_a_lost_chunk_via_bad_offset() {
        let mut s = session(Faults { drop_chunk_at: Some(1024), ..Default::default() });
        s.hello(&mut |_| {}).unwrap();
        let image: Vec<u8> = (0..6000u32).map(|i| (i * 13) as u8).collect();
        let mut events = Vec::new();
        s.upload_scene(&image, &mut |e| events.push(e)).unwrap();
        assert_eq!(s.port_mut().scene, image);
        assert!(events.contains(&ProgressEvent::UploadRewound { offset: 1024 }), "{events:?}");
    }

    #[test]
    fn upload_recovers_when_the_last_chunk_is_lost() {
        // No later chunk provokes a BadOffset: the retransmit timer must resend.
        let mut s = session(Faults { drop_chunk_at: Some(2048), ..Default::default() });
        s.hello(&mut |_| {}).unwrap();
        let image = vec![0xA5u8; 2100];
        s.upload_scene(&image, &mut |_| {}).unwrap();
        assert_eq!(s.port_mut().scene, image);
    }

    #[test]
    fn device_error_during_upload_is_typed() {
        let mut s = session(Faults { reject_scene: true, ..Default::default() });
        s.hello(&mut |_| {}).unwrap();
        let err = s.upload_scene(&[1, 2, 3], &mut |_| {}).unwrap_err();
        assert!(
            matches!(&err, SessionError::Device { stage: Stage::Upload, code: ErrorCode::SceneRejected, detail: 8, text, .. } if text.contains("PE memory")),
            "{err}"
        );
        // Errors answering chunks that were still in flight were drained: the next request
        // gets its own answer.
        let mut s = session(Faults { reject_scene: true, ..Default::default() });
        let _ = s.upload_scene(&vec![0u8; 5000], &mut |_| {}).unwrap_err();
        s.port_mut().faults.reject_scene = false;
        s.render(&request(4, 4, 0), &mut |_| {}).unwrap();
    }

    #[test]
    fn render_assembles_image_ids_and_stats() {
        let mut s = session(Faults { noise: vec![0x55, 0x13, 0x00], ..Default::default() });
        s.hello(&mut |_| {}).unwrap();
        let mut events = Vec::new();
        let f = s.render(&request(20, 7, render_flags::PRIM_IDS), &mut |e| events.push(e)).unwrap();
        assert_eq!((f.width, f.height, f.frame), (20, 7, 3));
        for y in 0..7u16 {
            for x in 0..20u16 {
                let i = (y as usize * 20 + x as usize) * 3;
                assert_eq!(&f.rgb[i..i + 3], &FakeDevice::pixel(x, y));
            }
        }
        assert_eq!(f.prim_ids.as_ref().unwrap()[21], 1001);
        assert_eq!(f.stats.get(&stat::PRIMARY_RAYS), Some(&140));
        assert_eq!(f.stats.get(&stat::COPROC_CYCLES), Some(&12345));
        assert_eq!((f.spans_reported, f.spans_received), (14, 14));
        assert!(f.bytes_rx > 3 * 140 && f.bytes_tx > 72);
        assert!(s.bad_frames() > 0, "the noise must have been dropped");
        assert_eq!(events.first(), Some(&ProgressEvent::RenderStarted { width: 20, height: 7 }));
        assert_eq!(events.iter().filter(|e| matches!(e, ProgressEvent::RowReceived { .. })).count(), 7);
        assert_eq!(events.last(), Some(&ProgressEvent::Finished));
    }

    #[test]
    fn render_device_error_is_typed() {
        let mut s = session(Faults { render_error: true, ..Default::default() });
        let err = s.render(&request(4, 4, 0), &mut |_| {}).unwrap_err();
        assert!(matches!(err, SessionError::Device { stage: Stage::Render, code: ErrorCode::NoScene, .. }), "{err}");
    }

    #[test]
    fn render_detects_missing_pixels() {
        let mut s = session(Faults { skip_row: Some(2), ..Default::default() });
        let err = s.render(&request(8, 4, 0), &mut |_| {}).unwrap_err();
        assert!(
            matches!(err, SessionError::MissingPixels { missing: 8, first_x: 0, first_y: 2, what: "pixels", .. }),
            "{err}"
        );
    }

    #[test]
    fn render_detects_bad_image_crc() {
        let mut s = session(Faults { bad_crc: true, ..Default::default() });
        let err = s.render(&request(8, 4, 0), &mut |_| {}).unwrap_err();
        assert!(matches!(err, SessionError::ImageCrc { frame: 3, .. }), "{err}");
    }

    #[test]
    fn render_timeout_names_port_stage_and_last_seq() {
        let mut s = session(Faults { go_silent_after_rows: Some(2), ..Default::default() });
        s.hello(&mut |_| {}).unwrap(); // device seq 100
        let err = s.render(&request(8, 4, 0), &mut |_| {}).unwrap_err();
        assert!(matches!(err, SessionError::Timeout { stage: Stage::Render, last_seq: Some(102), .. }), "{err:?}");
        let text = err.to_string();
        assert!(text.contains("fake0") && text.contains("render") && text.contains("102"), "{text}");
    }

    #[test]
    fn hello_timeout_without_device() {
        struct Silent;
        impl Read for Silent {
            fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
                std::thread::sleep(Duration::from_millis(1));
                Err(ErrorKind::WouldBlock.into())
            }
        }
        impl Write for Silent {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let mut s = Session::new(Silent, SessionConfig::new("ttyUSB9").hello_timeout(Duration::from_millis(60)));
        let err = s.hello(&mut |_| {}).unwrap_err();
        assert!(matches!(err, SessionError::Timeout { stage: Stage::Hello, last_seq: None, .. }));
        assert!(err.to_string().contains("ttyUSB9: timed out during hello"), "{err}");
    }
}
