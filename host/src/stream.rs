//! Frames as a stream (`gridrt render --frames N`): one request per frame along a camera
//! path ([`crate::camera_path`]), on one board or several (row bands, [`crate::multi`]),
//! each frame reported as it completes, with its time and wire bytes, and the stream's frame
//! rate and line utilisation at the end.
//!
//! # Frame n+1 rendered while frame n is on the line, where the board allows it
//! A board that advertises `REQUEST_QUEUE` (SPEC.md §3.12.3, "Flow control": the loopback
//! simulator and `gridrt device`, whose UART path buffers what arrives during a render) gets
//! frame n+1's request before frame n's answer is in ([`Session::send_ahead`]): two frames
//! requested at a time, so the device starts the next frame the moment it finishes one and
//! the device → host line does not idle between frames. Elsewhere — a soft-core renders
//! inside its receive loop and its 16-byte receive FIFO would lose a request sent early —
//! and on several boards (row bands from a shared queue), a frame's request leaves when the
//! previous frame is complete, and the line idles between frames for the request's wire
//! time, the turnaround and the device's work on the first row.
//!
//! # Line utilisation
//! `line_utilisation` = the bytes the boards sent ÷ (boards × baud ÷ 10 × the stream's
//! elapsed time, from the first request to the last frame's end): 1 is a line that never
//! idled (8N1: 10 bit times per byte).

use std::io::{Read, Write};
use std::time::Instant;

use gridrt_shared::msg::RenderRequest;
use serde::Serialize;

use crate::camera_path::CameraPath;
use crate::multi::{render_multi, DeviceShare};
use crate::render_settings::Camera;
use crate::session::{Activity, ProgressEvent, RenderedFrame, Session, SessionError};

/// Frames a stream may have at most (`--frames`).
pub const MAX_FRAMES: u32 = 100_000;

/// One frame of a stream, as the statistics report it.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FrameReport {
    /// Index in the stream (0-based; `frame-0000.png` is 0).
    pub index: u32,
    /// Frame id on the wire.
    pub frame_id: u16,
    /// From the end of the previous frame (the stream's start for frame 0) to this frame's
    /// last verified pixel, ms.
    pub frame_ms: f64,
    /// The frame rate this frame alone would give (1000 / `frame_ms`).
    pub fps: f64,
    /// Wire bytes device → host (every board).
    pub wire_rx: u64,
    /// Wire bytes host → device (every board) from the previous frame's end to this one's:
    /// with requests sent ahead, the next frame's request rather than this one's.
    pub wire_tx: u64,
    /// Pixel spans received.
    pub spans: u32,
    /// Pixel runs requested again (selective repeat).
    pub regions_resent: u64,
    /// Camera eye of the frame.
    pub eye: [f32; 3],
    /// Camera target of the frame.
    pub target: [f32; 3],
    /// Seconds since the stream's first request when the frame was complete.
    pub at_s: f64,
}

/// A whole stream.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct StreamReport {
    /// Per frame, in order.
    pub frames: Vec<FrameReport>,
    /// From the first request to the last frame's end, seconds.
    pub elapsed_s: f64,
    /// Frames per second over the stream.
    pub fps: f64,
    /// Bytes the boards sent ÷ (boards × baud ÷ 10 × `elapsed_s`) (module docs).
    pub line_utilisation: f64,
    /// Pixel-span payload bytes per second, device → host (all boards).
    pub goodput_bytes_per_s: f64,
    /// Wire bytes device → host, all frames.
    pub wire_rx: u64,
    /// Wire bytes host → device, all frames.
    pub wire_tx: u64,
    /// Line rate the utilisation refers to.
    pub baud: u32,
    /// Boards.
    pub boards: usize,
    /// Frame n+1 was requested before frame n was in (one board with `REQUEST_QUEUE`).
    pub requested_ahead: bool,
}

/// What a stream reports while it runs.
#[derive(Debug)]
pub enum StreamEvent<'a> {
    /// Frame `index` of `of` is requested with `camera`.
    FrameStarted {
        /// Index in the stream.
        index: u32,
        /// Frames in the stream.
        of: u32,
        /// Its camera.
        camera: Camera,
    },
    /// A session event of the current frame (`RowArrived` as rows come in, `Activity`, …).
    Progress(ProgressEvent),
    /// Frame `report.index` is complete and verified.
    FrameDone {
        /// The frame.
        frame: &'a RenderedFrame,
        /// Its numbers.
        report: &'a FrameReport,
        /// Per board, with several boards (empty with one).
        devices: &'a [DeviceShare],
    },
}

/// A stream to render: `frames` frames of `request` (its size, flags and encoding) along
/// `path` from `base`.
#[derive(Debug, Clone)]
pub struct StreamPlan {
    /// The frame every request starts from (camera replaced per frame).
    pub request: RenderRequest,
    /// The scene's camera (the path's base).
    pub base: Camera,
    /// How the camera moves.
    pub path: CameraPath,
    /// Frames.
    pub frames: u32,
    /// Rows per band on several boards (0: [`crate::multi::default_band_rows`]).
    pub band_rows: u16,
    /// Line rate of the boards' links (for `line_utilisation`).
    pub baud: u32,
}

impl StreamPlan {
    /// The request of frame `i`.
    pub fn request(&self, i: u32) -> RenderRequest {
        let c = self.path.camera(&self.base, i, self.frames);
        RenderRequest {
            frame: (i % u32::from(u16::MAX)) as u16 + 1,
            eye: c.eye,
            target: c.target,
            up: c.up,
            fov_y_deg: c.fov_y_deg,
            ..self.request
        }
    }
}

/// Renders `req` on `sessions` (connected, scene uploaded): one board asks for the frame in
/// one piece, several share it in row bands ([`render_multi`]). Progress of several boards is
/// merged: `RowReceived` counts the frame's verified rows, `Activity` shows them as its
/// progress.
pub fn render_frame<T: Read + Write + Send>(
    sessions: &mut Vec<Session<T>>,
    req: &RenderRequest,
    band_rows: u16,
    progress: &mut (dyn FnMut(ProgressEvent) + Send),
) -> Result<(RenderedFrame, Vec<DeviceShare>), SessionError> {
    if let [session] = &mut sessions[..] {
        return Ok((session.render(req, progress)?, Vec::new()));
    }
    progress(ProgressEvent::RenderStarted { width: req.width, height: req.height });
    let pixels = u64::from(req.width) * u64::from(req.height);
    let shared = std::sync::Mutex::new((0u32, 0u32, &mut *progress));
    let owned = std::mem::take(sessions);
    let (multi, back) = render_multi(owned, req, band_rows, &|_, e| {
        let mut g = shared.lock().unwrap_or_else(|p| p.into_inner());
        match e {
            ProgressEvent::RowVerified { y } => {
                g.0 += 1;
                let rows_done = g.0;
                (g.2)(ProgressEvent::RowReceived { y, rows_done });
            }
            ProgressEvent::RowArrived { .. } => {
                g.1 += 1;
                (g.2)(e);
            }
            // One board's activity, with the frame's rows as its progress.
            ProgressEvent::Activity(a) => {
                let done = u64::from(g.0) * u64::from(req.width);
                let received = u64::from(g.1) * u64::from(req.width);
                (g.2)(ProgressEvent::Activity(Activity { done, received, total: pixels, ..a }));
            }
            _ => {}
        }
    })?;
    *sessions = back;
    progress(ProgressEvent::Finished);
    Ok((multi.frame, multi.devices))
}

/// Renders the stream `plan` on `sessions` (connected, scene uploaded); `on` sees every
/// frame start, session event and finished frame (write the PNG there). Stops at the first
/// error.
pub fn run<T: Read + Write + Send>(
    sessions: &mut Vec<Session<T>>,
    plan: &StreamPlan,
    on: &mut (dyn FnMut(StreamEvent<'_>) -> anyhow::Result<()> + Send),
) -> anyhow::Result<StreamReport> {
    let boards = sessions.len().max(1);
    let start = Instant::now();
    let mut report = StreamReport { baud: plan.baud, boards, ..Default::default() };
    let mut span_bytes = 0u64;
    // One board that queues requests: keep the next frame's request in flight.
    let ahead = matches!(&sessions[..], [s] if s.can_send_ahead());
    report.requested_ahead = ahead;
    let sent = |s: &Vec<Session<T>>| s.iter().map(Session::bytes_tx).sum::<u64>();
    let mut tx_mark = sent(sessions);
    if let (true, [s]) = (ahead, &mut sessions[..]) {
        s.send_ahead(&plan.request(0))?;
    }
    for i in 0..plan.frames {
        let req = plan.request(i);
        if let (true, [s]) = (ahead && i + 1 < plan.frames, &mut sessions[..]) {
            s.send_ahead(&plan.request(i + 1))?;
        }
        let camera = Camera { eye: req.eye, target: req.target, up: req.up, fov_y_deg: req.fov_y_deg };
        on(StreamEvent::FrameStarted { index: i, of: plan.frames, camera })?;
        let t = Instant::now();
        let mut failed = None;
        let (frame, devices) = render_frame(sessions, &req, plan.band_rows, &mut |e| {
            if failed.is_none() {
                if let Err(err) = on(StreamEvent::Progress(e)) {
                    failed = Some(err);
                }
            }
        })
        .map_err(|e| anyhow::Error::new(e).context(format!("frame {i} of {}", plan.frames)))?;
        if let Some(e) = failed {
            return Err(e);
        }
        let frame_ms = t.elapsed().as_secs_f64() * 1e3;
        span_bytes += frame.link.span_data_bytes;
        let r = FrameReport {
            index: i,
            frame_id: req.frame,
            frame_ms,
            fps: if frame_ms > 0.0 { 1e3 / frame_ms } else { 0.0 },
            wire_rx: frame.bytes_rx,
            wire_tx: sent(sessions) - tx_mark,
            spans: frame.spans_received,
            regions_resent: frame.link.regions_resent,
            eye: req.eye,
            target: req.target,
            at_s: start.elapsed().as_secs_f64(),
        };
        tx_mark = sent(sessions);
        report.wire_rx += r.wire_rx;
        report.wire_tx += r.wire_tx;
        on(StreamEvent::FrameDone { frame: &frame, report: &r, devices: &devices })?;
        report.frames.push(r);
    }
    // The stream ends with its last frame (not with what `on` did after it).
    report.elapsed_s = report.frames.last().map_or(0.0, |f| f.at_s);
    let secs = report.elapsed_s.max(1e-9);
    report.fps = report.frames.len() as f64 / secs;
    report.line_utilisation = line_utilisation(report.wire_rx, boards, plan.baud, secs);
    report.goodput_bytes_per_s = span_bytes as f64 / secs;
    Ok(report)
}

/// Bytes sent ÷ what `boards` lines at `baud` (8N1) could carry in `secs`.
pub fn line_utilisation(bytes: u64, boards: usize, baud: u32, secs: f64) -> f64 {
    let capacity = boards.max(1) as f64 * f64::from(baud.max(1)) / 10.0 * secs;
    if capacity > 0.0 {
        bytes as f64 / capacity
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utilisation_is_bytes_over_line_capacity() {
        // 3 Mbaud carries 300 000 B/s; 270 000 B in 1 s is 0.9.
        assert!((line_utilisation(270_000, 1, 3_000_000, 1.0) - 0.9).abs() < 1e-12);
        assert!((line_utilisation(270_000, 2, 3_000_000, 0.5) - 0.9).abs() < 1e-12);
        assert_eq!(line_utilisation(1, 1, 115_200, 0.0), 0.0);
    }

    #[test]
    fn frame_ids_are_never_zero_and_the_camera_follows_the_path() {
        let base = Camera { eye: [0.0, 0.0, 5.0], target: [0.0; 3], up: [0.0, 1.0, 0.0], fov_y_deg: 45.0 };
        let plan = StreamPlan {
            request: crate::render_settings::RenderSettings::default_for(&crate::bounds::Bounds {
                min: [-1.0; 3],
                max: [1.0; 3],
            })
            .to_request(1),
            base,
            path: CameraPath::Orbit { degrees: 360.0, centre: [0.0; 3] },
            frames: 4,
            band_rows: 0,
            baud: 115_200,
        };
        assert_eq!(plan.request(0).frame, 1);
        assert_eq!(plan.request(65_534).frame, 65_535);
        assert_eq!(plan.request(65_535).frame, 1);
        assert_eq!(plan.request(0).eye, base.eye);
        assert!((plan.request(1).eye[0] - 5.0).abs() < 1e-5);
    }
}
