//! `gridrt bench stream`: frame rate and link goodput of a frame stream ([`crate::stream`])
//! for a scene × line rate × pixel encoding, measured on the loopback simulator with its
//! device → host line paced at the baud rate (8N1), and once unpaced (the device's own
//! frame rate: what a line could at best be fed with).
//!
//! Per row: frames per second, seconds per frame, wire bytes per frame, line utilisation
//! (bytes sent ÷ the line's capacity over the stream), goodput (pixel-span payload bytes per
//! second, and against the line's byte rate), and the frame rate the line alone would allow
//! (its byte rate ÷ wire bytes per frame). Every frame of every row is compared with the
//! unpaced run's: the line rate must not change a pixel.

use std::time::Duration;

use gridrt_shared::msg::{PixelEncoding, RenderRequest};
use serde::Serialize;

use crate::camera_path::CameraPath;
use crate::render_settings::Camera;
use crate::session::{Session, SessionConfig};
use crate::stream::{self, StreamPlan, StreamReport};

/// One measured stream.
#[derive(Debug, Clone, Serialize)]
pub struct StreamRow {
    /// Scene name.
    pub scene: String,
    /// Pixel encoding.
    pub encoding: String,
    /// Line rate (0 = unpaced: the device's own rate).
    pub baud: u32,
    /// Frames.
    pub frames: u32,
    /// Frames per second.
    pub fps: f64,
    /// Seconds per frame.
    pub frame_s: f64,
    /// Wire bytes device → host per frame.
    pub wire_per_frame: f64,
    /// Bytes sent ÷ the line's capacity over the stream (0 unpaced).
    pub line_utilisation: f64,
    /// Pixel-span payload bytes per second.
    pub goodput_bytes_per_s: f64,
    /// Goodput ÷ the line's byte rate (0 unpaced).
    pub goodput_ratio: f64,
    /// The frame rate the line alone allows: baud ÷ 10 ÷ wire bytes per frame (0 unpaced).
    pub link_bound_fps: f64,
    /// Every frame equals the unpaced run's.
    pub identical: bool,
}

/// What one stream run returned: its report and its frames (RGB8).
#[derive(Debug, Clone)]
pub struct Run {
    /// The stream's numbers.
    pub report: StreamReport,
    /// Each frame's pixels.
    pub frames: Vec<Vec<u8>>,
}

/// Renders `frames` frames of `req` along `path` (from `base`) on a fresh loopback simulator
/// (`sim`), its line paced at `baud` (`None`: unpaced), after hello and the upload of
/// `image`.
pub fn run(
    image: &[u8],
    req: &RenderRequest,
    base: Camera,
    path: &CameraPath,
    frames: u32,
    baud: Option<u32>,
    sim: gridrt_loopback::SimConfig,
) -> anyhow::Result<Run> {
    let mut port = gridrt_loopback::spawn(sim);
    port.set_timeout(Duration::from_millis(20));
    port.set_line_rate(baud);
    let line = baud.unwrap_or(3_000_000);
    let mut s = Session::new(
        port,
        SessionConfig::new(format!("sim@{line}")).baud(line).render_timeout(Duration::from_secs(120)),
    );
    s.hello(&mut |_| {})?;
    s.upload_scene(image, &mut |_| {})?;
    let plan = StreamPlan { request: *req, base, path: path.clone(), frames, band_rows: 0, baud: line };
    let mut sessions = vec![s];
    let mut pixels = Vec::new();
    let report = stream::run(&mut sessions, &plan, &mut |e| {
        if let stream::StreamEvent::FrameDone { frame, .. } = e {
            pixels.push(frame.rgb.clone());
        }
        Ok(())
    })?;
    Ok(Run { report, frames: pixels })
}

/// The row of `run` (`reference`: the unpaced run's frames).
pub fn row(scene: &str, enc: PixelEncoding, baud: Option<u32>, run: &Run, reference: &[Vec<u8>]) -> StreamRow {
    let r = &run.report;
    let n = r.frames.len().max(1) as f64;
    let wire_per_frame = r.wire_rx as f64 / n;
    let bytes_per_s = baud.map_or(0.0, |b| f64::from(b) / 10.0);
    StreamRow {
        scene: scene.to_string(),
        encoding: format!("{enc:?}").to_lowercase(),
        baud: baud.unwrap_or(0),
        frames: r.frames.len() as u32,
        fps: r.fps,
        frame_s: if r.fps > 0.0 { 1.0 / r.fps } else { 0.0 },
        wire_per_frame,
        line_utilisation: if baud.is_some() { r.line_utilisation } else { 0.0 },
        goodput_bytes_per_s: r.goodput_bytes_per_s,
        goodput_ratio: if bytes_per_s > 0.0 { r.goodput_bytes_per_s / bytes_per_s } else { 0.0 },
        link_bound_fps: if wire_per_frame > 0.0 { bytes_per_s / wire_per_frame } else { 0.0 },
        identical: run.frames == reference,
    }
}

/// The rows as CSV.
pub fn csv(rows: &[StreamRow]) -> String {
    let mut s = String::from(
        "scene,encoding,baud,frames,fps,frame_s,wire_per_frame,line_utilisation,goodput_bytes_per_s,goodput_ratio,link_bound_fps,identical\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{:.3},{:.4},{:.0},{:.4},{:.0},{:.4},{:.3},{}\n",
            r.scene,
            r.encoding,
            r.baud,
            r.frames,
            r.fps,
            r.frame_s,
            r.wire_per_frame,
            r.line_utilisation,
            r.goodput_bytes_per_s,
            r.goodput_ratio,
            r.link_bound_fps,
            r.identical
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::FrameReport;

    #[test]
    fn a_row_relates_the_stream_to_its_line() {
        let report = StreamReport {
            frames: vec![FrameReport::default(); 4],
            elapsed_s: 2.0,
            fps: 2.0,
            line_utilisation: 0.8,
            goodput_bytes_per_s: 9_000.0,
            wire_rx: 48_000,
            ..Default::default()
        };
        let run = Run { report, frames: vec![vec![1]; 4] };
        let r = row("s", PixelEncoding::Rle, Some(115_200), &run, &vec![vec![1]; 4]);
        assert_eq!((r.wire_per_frame, r.frame_s, r.identical), (12_000.0, 0.5, true));
        assert!((r.link_bound_fps - 0.96).abs() < 1e-9 && (r.goodput_ratio - 9_000.0 / 11_520.0).abs() < 1e-9);
        let unpaced = row("s", PixelEncoding::Rle, None, &run, &vec![vec![2]; 4]);
        assert_eq!(
            (unpaced.baud, unpaced.line_utilisation, unpaced.link_bound_fps, unpaced.identical),
            (0, 0.0, 0.0, false)
        );
        assert!(csv(&[r]).lines().nth(1).unwrap().starts_with("s,rle,115200,4,2.000,0.5000,12000,0.8000"));
    }
}
