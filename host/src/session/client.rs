//! The session itself: transport, frame codec, sequence numbers, byte counters, and the
//! `Hello` exchange every stage starts from.

use std::io::{ErrorKind, Read, Write};
use std::sync::Arc;
use std::time::{Duration, Instant};

use gridrt_shared::frame::{encode_frame, FeedResult, FrameAccumulator, FrameError, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{
    stat_entries, DeviceInfo, ErrorCode, FlashStatus, Msg, MsgError, MsgType, PixelEncoding, Region, Sack, SceneStatus,
};
use gridrt_shared::PROTOCOL_VERSION;

use super::config::SessionConfig;
use super::error::{SessionError, Stage};
use super::estimate::LossEstimator;
use super::link::DevicePace;
use super::link::{LinkStats, SpanSizer};
use super::progress::ProgressEvent;

/// Owned form of the device → host messages.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Incoming {
    Version(DeviceInfo),
    SceneAck { next_offset: u32, status: SceneStatus },
    SceneSack { status: SceneStatus, sack: Sack },
    FlashAck { next_offset: u32, status: FlashStatus, crc: u32 },
    FlashSack { status: FlashStatus, sack: Sack },
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
            Msg::SceneSack { status, sack } => Self::SceneSack { status, sack },
            Msg::FlashAck { next_offset, status, crc } => Self::FlashAck { next_offset, status, crc },
            Msg::FlashSack { status, sack } => Self::FlashSack { status, sack },
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

    /// A short description for error messages ("last heard: …").
    fn summary(&self) -> String {
        match self {
            Self::Version(d) => format!("Version (firmware {}.{}.{})", d.firmware[0], d.firmware[1], d.firmware[2]),
            Self::SceneAck { next_offset, status } => format!("SceneAck {{{next_offset}, {status:?}}}"),
            Self::SceneSack { status, sack } => {
                format!("SceneSack {{next {}, {status:?}, {} ranges}}", sack.next_offset, sack.ranges.len())
            }
            Self::FlashAck { next_offset, status, .. } => format!("FlashAck {{{next_offset}, {status:?}}}"),
            Self::FlashSack { status, sack } => {
                format!("FlashSack {{next {}, {status:?}, {} ranges}}", sack.next_offset, sack.ranges.len())
            }
            Self::PixelSpan { y, x0, count, .. } => format!("PixelSpan {{row {y}, x {x0}+{count}}}"),
            Self::FrameEnd { frame, .. } => format!("FrameEnd {{frame {frame}}}"),
            Self::RegionEnd { region: r, .. } => {
                format!("RegionEnd {{rows {}..{}, x {}+{}}}", r.y0, r.y0 + r.rows, r.x0, r.cols)
            }
            Self::Stats { frame, .. } => format!("Stats {{frame {frame}}}"),
            Self::Error { code, detail, text } => format!("Error {{{code:?}, {detail:#x}: {text}}}"),
            Self::Other => "a message this host does not know".into(),
        }
    }
}

/// A protocol session over transport `T`.
#[derive(Debug)]
pub struct Session<T> {
    port: T,
    pub(crate) cfg: SessionConfig,
    acc: Box<FrameAccumulator<MAX_ENCODED>>,
    rx: Vec<u8>,
    rx_pos: usize,
    pub(crate) tx_seq: u16,
    pub(crate) last_rx_seq: Option<u16>,
    pub(crate) bytes_tx: u64,
    pub(crate) bytes_rx: u64,
    bad_frames: u64,
    pub(crate) device: Option<DeviceInfo>,
    /// Valid frames received.
    pub(crate) rx_frames: u64,
    /// Retransmission counters.
    pub(crate) link: LinkStats,
    /// The last scene uploaded (uploaded again after a device reset).
    pub(crate) scene: Option<Arc<[u8]>>,
    /// Line-quality estimate carried from band to band.
    pub(crate) sizer: Option<SpanSizer>,
    /// Byte error rate host → device, from data frames that arrived or were lost.
    pub(crate) est_up: LossEstimator,
    /// Byte error rate device → host, from the frames received intact or corrupt.
    pub(crate) est_down: LossEstimator,
    /// Bytes received since the last frame outcome (the size of the next one).
    frame_bytes: usize,
    /// The device's compute gaps and frame sizes seen while rendering.
    pub(crate) pace: DevicePace,
    /// When, with which sequence number, and what was last heard.
    heard: Option<(Instant, u16, String)>,
    /// Measured seconds per byte of a round trip beyond the turnaround (smoothed); 0 until
    /// the first answer. A receiver slower than the line (a simulated SoC, a bootloader
    /// busy with each chunk) lengthens every derived wait ([`Self::answer_wait`]).
    byte_time_s: f64,
    /// First requests already sent ahead ([`Self::send_ahead`]): (frame id, band), oldest
    /// first; `render_band` does not send these again.
    pub(crate) ahead: std::collections::VecDeque<(u16, gridrt_shared::msg::Region)>,
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
            est_up: LossEstimator::default(),
            est_down: LossEstimator::default(),
            frame_bytes: 0,
            pace: DevicePace::default(),
            heard: None,
            byte_time_s: 0.0,
            ahead: std::collections::VecDeque::new(),
        }
    }

    /// How long an answer of `back` bytes to `out` bytes may take: twice their time on the
    /// line plus the turnaround, the time per byte being the line rate's or, when answers
    /// were measured to take longer, the measured one ([`SessionConfig::answer_wait`] on a
    /// line as fast as its baud rate).
    pub fn answer_wait(&self, out: usize, back: usize) -> Duration {
        let wire = 10.0 / f64::from(self.cfg.baud.max(1));
        let per_byte = self.byte_time_s.max(wire);
        Duration::from_secs_f64(2.0 * per_byte * (out + back) as f64) + self.cfg.turnaround
    }

    /// Learns from an answer that came `rtt` after a request, with `bytes` wire bytes to
    /// cross in both directions (the request, what was queued ahead of it, the answer).
    pub(crate) fn learn_round_trip(&mut self, rtt: Duration, bytes: usize) {
        let sample = rtt.saturating_sub(self.cfg.turnaround).as_secs_f64() / bytes.max(1) as f64;
        self.byte_time_s = if self.byte_time_s == 0.0 { sample } else { 0.75 * self.byte_time_s + 0.25 * sample };
    }

    /// The last valid message from the device, its sequence number and how long ago; for
    /// error messages and progress lines.
    pub fn last_heard(&self) -> String {
        match &self.heard {
            None => "nothing".into(),
            Some((at, seq, what)) => format!("{what} (seq {seq}) {:.1} s ago", at.elapsed().as_secs_f64()),
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

    pub(crate) fn timeout(&self, stage: Stage, waited: Duration, what: impl Into<String>) -> SessionError {
        SessionError::Timeout {
            port: self.cfg.port_name.clone(),
            stage,
            waited,
            last_seq: self.last_rx_seq,
            sent_seq: self.tx_seq.wrapping_sub(1),
            what: what.into(),
            last_heard: self.last_heard(),
        }
    }

    pub(crate) fn protocol(&self, stage: Stage, what: impl Into<String>) -> SessionError {
        SessionError::Protocol { port: self.cfg.port_name.clone(), stage, what: what.into() }
    }

    pub(crate) fn device_err(&self, stage: Stage, code: ErrorCode, detail: u32, text: String) -> SessionError {
        SessionError::Device { port: self.cfg.port_name.clone(), stage, code, detail, text }
    }

    pub(crate) fn write_bytes(&mut self, stage: Stage, bytes: &[u8]) -> Result<(), SessionError> {
        self.port.write_all(bytes).map_err(|e| self.io_err(stage, e))?;
        self.port.flush().map_err(|e| self.io_err(stage, e))?;
        self.bytes_tx += bytes.len() as u64;
        Ok(())
    }

    /// Sends `msg` as one frame; returns its sequence number and wire length.
    pub(crate) fn send(&mut self, stage: Stage, msg: &Msg<'_>) -> Result<(u16, usize), SessionError> {
        let mut payload = [0u8; MAX_PAYLOAD];
        let n = msg.encode(&mut payload).map_err(|e: MsgError| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage,
            what: e.to_string(),
        })?;
        let mut wire = [0u8; MAX_ENCODED];
        let len = encode_frame(msg.kind() as u8, self.tx_seq, &payload[..n], &mut wire)
            .map_err(|e| SessionError::BadInput { port: self.cfg.port_name.clone(), stage, what: e.to_string() })?;
        let seq = self.tx_seq;
        self.tx_seq = self.tx_seq.wrapping_add(1);
        self.write_bytes(stage, &wire[..len])?;
        Ok((seq, len))
    }

    /// Next message, or `None` once `until` has passed without one.
    pub(crate) fn poll(&mut self, stage: Stage, until: Instant) -> Result<Option<Incoming>, SessionError> {
        let mut buf = [0u8; 4096];
        loop {
            while self.rx_pos < self.rx.len() {
                let total = self.rx.len();
                let decoded = match self.acc.feed(&self.rx[self.rx_pos..]) {
                    FeedResult::Consumed => {
                        self.frame_bytes += total - self.rx_pos;
                        self.rx_pos = total;
                        None
                    }
                    FeedResult::Overflow { rest } => {
                        self.bad_frames += 1;
                        self.link.resyncs += 1;
                        self.est_down.record(self.frame_bytes + (total - rest.len() - self.rx_pos), false);
                        self.frame_bytes = 0;
                        self.rx_pos = total - rest.len();
                        None
                    }
                    FeedResult::BadFrame { error, rest } => {
                        self.bad_frames += 1;
                        self.link.resyncs += 1;
                        if error == FrameError::DecodeBadCrc {
                            self.link.crc_errors += 1;
                        }
                        // A lone garbage byte or two is noise between frames, not a frame.
                        let n = self.frame_bytes + (total - rest.len() - self.rx_pos);
                        if n > 4 {
                            self.est_down.record(n, false);
                        }
                        self.frame_bytes = 0;
                        self.rx_pos = total - rest.len();
                        None
                    }
                    FeedResult::Frame { frame, rest } => {
                        let pos = total - rest.len();
                        self.est_down.record(self.frame_bytes + (pos - self.rx_pos), true);
                        self.frame_bytes = 0;
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
                    if let Ok(m) = &msg {
                        self.heard = Some((Instant::now(), seq, m.summary()));
                    }
                    return msg.map(Some).map_err(|w| self.protocol(stage, w));
                }
            }
            self.rx.clear();
            self.rx_pos = 0;
            if Instant::now() >= until {
                return Ok(None);
            }
            match self.port.read(&mut buf) {
                Ok(0) => {
                    return Err(SessionError::Disconnected {
                        port: self.cfg.port_name.clone(),
                        stage,
                        last_heard: self.last_heard(),
                    })
                }
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
        // One Hello per derived answer wait (at least 100 ms: a device may be busy for a
        // moment), until the device had `hello_timeout` to boot.
        let wait = self.answer_wait(16, 36).max(Duration::from_millis(100));
        // A device still sending an earlier session's frames (a slow board finishing regions
        // that host re-requested) is alive but busy: each such frame gives it another
        // `hello_timeout`, up to `render_timeout` in all.
        let mut deadline = start + self.cfg.hello_timeout;
        let patience = start + self.cfg.render_timeout.max(self.cfg.hello_timeout);
        while Instant::now() < deadline {
            let sent = Instant::now();
            self.send(stage, &Msg::Hello { protocol: PROTOCOL_VERSION as u16 })?;
            let until = (Instant::now() + wait).min(deadline);
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
                        // A Version answering an earlier Hello makes this too short: never too long.
                        self.learn_round_trip(sent.elapsed(), 16 + 36);
                        progress(ProgressEvent::Connected(info));
                        return Ok(info);
                    }
                    Incoming::Error { code: ErrorCode::UnexpectedMessage, detail, text }
                        if detail == MsgType::Hello as u32 =>
                    {
                        // The one error that answers Hello: the device does not speak it.
                        return Err(self.device_err(stage, ErrorCode::UnexpectedMessage, detail, text));
                    }
                    // Noise before our Hello, or stale traffic from an earlier session: an
                    // earlier host may have left answers unread (e.g. a bootloader's refusal
                    // of the data that followed a refused FlashBegin), or the device is
                    // still sending an earlier frame's rows.
                    _ => deadline = deadline.max((Instant::now() + self.cfg.hello_timeout).min(patience)),
                }
            }
        }
        Err(self.timeout(stage, start.elapsed(), "Version in answer to Hello"))
    }
}
