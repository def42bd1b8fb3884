//! Session tests against a scripted fake device.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::time::Duration;

use gridrt_shared::frame::{crc32, encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{render_flags, stat, DeviceInfo, ErrorCode, Msg, PixelEncoding, RenderRequest, SceneStatus};
use gridrt_shared::PROTOCOL_VERSION;

use super::*;

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
                    self.emit(&Msg::Error { code: ErrorCode::BadOffset, detail: self.expected, text: "bad offset" });
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
                for (k, v) in [(stat::PRIMARY_RAYS, (r.width as u64) * r.height as u64), (stat::COPROC_CYCLES, 12345)] {
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
        .baud(1_000_000)
        .turnaround(Duration::from_millis(20))
        .hello_timeout(Duration::from_millis(300))
        .max_probes(5)
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
fn hello_skips_errors_an_earlier_session_left_unread() {
    // A bootloader refuses a FlashBegin, then the probe that followed it (`NotBegun`); the
    // host that sent them stopped at the first refusal, so the second waits in the line.
    let mut s = session(Faults::default());
    s.port_mut().emit(&Msg::Error { code: ErrorCode::FlashRejected, detail: 2, text: "flash data without FlashBegin" });
    s.port_mut().emit(&Msg::Error { code: ErrorCode::NoScene, detail: 0, text: "no scene loaded" });
    let info = s.hello(&mut |_| {}).unwrap();
    assert_eq!(info.pe_count, 4);
}

#[test]
fn upload_ignores_a_late_no_scene_answer_to_an_earlier_render() {
    // After a device reset the answers to render requests sent before it arrive during the
    // re-upload; `NoScene` answers only renders, so it is not the upload's failure.
    let mut s = session(Faults::default());
    s.hello(&mut |_| {}).unwrap();
    s.port_mut().emit(&Msg::Error { code: ErrorCode::NoScene, detail: 0, text: "no scene loaded" });
    let image: Vec<u8> = (0..3000u32).map(|i| (i * 11) as u8).collect();
    s.upload_scene(&image, &mut |_| {}).unwrap();
    assert_eq!(s.port_mut().scene, image);
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

/// A device still sending an earlier session's frames: it ignores Hello while `busy` lasts
/// and sends a stale frame (an `Error` nobody asked for) every 20 ms, then answers.
struct BusyDevice {
    inner: FakeDevice,
    busy_until: std::time::Instant,
    next_stale: std::time::Instant,
}

impl BusyDevice {
    fn new(busy: Duration) -> Self {
        let now = std::time::Instant::now();
        Self { inner: FakeDevice::new(Faults::default()), busy_until: now + busy, next_stale: now }
    }
}

impl Write for BusyDevice {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if std::time::Instant::now() < self.busy_until {
            return Ok(buf.len());
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for BusyDevice {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let now = std::time::Instant::now();
        if now < self.busy_until && now >= self.next_stale {
            self.next_stale = now + Duration::from_millis(20);
            self.inner.emit(&Msg::Error { code: ErrorCode::NoScene, detail: 0, text: "stale" });
        }
        self.inner.read(buf)
    }
}

#[test]
fn hello_waits_for_a_device_still_sending_an_earlier_sessions_frames() {
    let cfg = SessionConfig::new("busy0")
        .baud(1_000_000)
        .hello_timeout(Duration::from_millis(100))
        .render_timeout(Duration::from_secs(5));
    let mut s = Session::new(BusyDevice::new(Duration::from_millis(400)), cfg.clone());
    assert_eq!(s.hello(&mut |_| {}).unwrap().pe_count, 4, "busy for 400 ms, hello_timeout 100 ms");
    // Patience has a bound: a device that never stops talking fails after render_timeout.
    let mut s = Session::new(BusyDevice::new(Duration::from_secs(60)), cfg.render_timeout(Duration::from_millis(300)));
    // (Unbounded, it would answer after the device's 60 s.)
    let err = s.hello(&mut |_| {}).unwrap_err();
    assert!(matches!(err, SessionError::Timeout { stage: Stage::Hello, .. }), "{err}");
}
