//! `gridrt render --out-dir DIR [--frames N] [--orbit DEGREES] [--view]`: frames as a stream
//! (library: [`gridrt_host::stream`]); numbered PNGs, per-frame statistics, the live view.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use gridrt_host::camera_path::CameraPath;
use gridrt_host::scene::Scene;
use gridrt_host::session::ProgressEvent;
use gridrt_host::stream::{self, StreamEvent, StreamPlan};
use gridrt_host::view::{Figures, View};

use super::progress::{CliProgress, Mode};
use super::render::{Cmd, Setup};

/// The name of frame `i`'s PNG in the output folder.
pub fn frame_name(i: u32) -> String {
    format!("frame-{i:04}.png")
}

impl Cmd {
    /// The camera path of the stream: --orbit about the scene's centre, else the scene file's
    /// keyframes, else none.
    pub(super) fn camera_path(&self, scene: &Scene) -> CameraPath {
        match self.orbit {
            Some(degrees) => {
                let centre = scene.bounds().map_or_else(|| scene.settings.camera.target.map(f64::from), |b| b.center());
                CameraPath::Orbit { degrees, centre }
            }
            None if !scene.camera_path.is_empty() => CameraPath::Keyframes(scene.camera_path.clone()),
            None => CameraPath::Still,
        }
    }

    /// Checks every frame's camera before anything is sent.
    pub(super) fn check_stream(&self, scene: &Scene) -> anyhow::Result<()> {
        if self.out_dir.is_none() {
            return Ok(());
        }
        let n = self.frames.unwrap_or(1);
        self.camera_path(scene)
            .check(&scene.settings.camera, n)
            .map_err(|e| anyhow::anyhow!("the camera path (--orbit or the scene's [[camera_path]]): {e}"))
    }

    /// Renders the stream (module docs) on the connected boards of `setup`.
    pub(super) fn run_stream<T: Read + Write + Send>(
        &self,
        setup: Setup<T>,
        dir: &Path,
        mut progress: CliProgress,
        total_start: Instant,
    ) -> anyhow::Result<()> {
        let Setup { mut sessions, prepared, request, upload_ms, .. } = setup;
        let frames = self.frames.unwrap_or(1);
        let path = self.camera_path(&prepared.scene);
        let baud = self.port.baud();
        let plan = StreamPlan {
            request,
            base: prepared.scene.settings.camera,
            path: path.clone(),
            frames,
            band_rows: self.band_rows,
            baud,
        };
        let view = match self.view {
            Some(port) => {
                let v = View::start(port).with_context(|| format!("--view: serving on 127.0.0.1:{port}"))?;
                progress.println(&format!("view       {}", v.url()));
                Some(v)
            }
            None => None,
        };
        // PNGs are written on a thread of their own: the link never waits for the encoder.
        let (tx, rx) = std::sync::mpsc::channel::<(PathBuf, u16, u16, Vec<u8>)>();
        let writer = std::thread::spawn(move || -> anyhow::Result<()> {
            for (p, w, h, rgb) in rx {
                super::output::write_rgb(&p, w, h, rgb)?;
            }
            Ok(())
        });
        let (mut wire_rx, mut done) = (0u64, 0u32);
        let boards = sessions.len();
        let start = Instant::now();
        let result = stream::run(&mut sessions, &plan, &mut |e| {
            match e {
                StreamEvent::FrameStarted { index, of, .. } => {
                    progress.set_frame(Some(format!("frame {}/{of}", index + 1)));
                    if let Some(v) = &view {
                        v.frame_started(index, of, request.width, request.height);
                    }
                }
                StreamEvent::Progress(e) => {
                    if let (Some(v), ProgressEvent::RowArrived { y, x0, rgb }) = (&view, &e) {
                        v.row(*y, *x0, rgb);
                    }
                    progress.handle(e);
                }
                StreamEvent::FrameDone { frame, report, .. } => {
                    done += 1;
                    wire_rx += report.wire_rx;
                    let secs = start.elapsed().as_secs_f64();
                    let figures = Figures {
                        frames_done: done,
                        frames,
                        fps: f64::from(done) / secs.max(1e-9),
                        line_utilisation: stream::line_utilisation(wire_rx, boards, baud, secs),
                        wire_rx,
                        baud,
                        last_frame_ms: report.frame_ms,
                        done: false,
                    };
                    if let Some(v) = &view {
                        v.frame_done(report.index, frame.width, frame.height, &frame.rgb, figures.clone());
                    }
                    tx.send((dir.join(frame_name(report.index)), frame.width, frame.height, frame.rgb.clone()))
                        .map_err(|_| anyhow::anyhow!("the PNG writer stopped"))?;
                    let line = format!(
                        "frame {}/{frames} in {:.0} ms, {} B in, {:.2} fps so far, line {:.0} %",
                        report.index + 1,
                        report.frame_ms,
                        report.wire_rx,
                        figures.fps,
                        100.0 * figures.line_utilisation
                    );
                    match progress.mode() {
                        Mode::Lines => progress.println(&line),
                        Mode::Bars if frames <= 100 || report.index % 10 == 9 => progress.println(&line),
                        Mode::Bars => {}
                    }
                }
            }
            Ok(())
        });
        progress.set_frame(None);
        progress.finish();
        drop(progress);
        drop(tx);
        let written = writer.join().unwrap_or_else(|_| Err(anyhow::anyhow!("the PNG writer panicked")));
        let report = result?;
        written?;

        let describe = match &path {
            CameraPath::Still => "still".to_string(),
            CameraPath::Orbit { degrees, .. } => format!("orbit {degrees}°"),
            CameraPath::Keyframes(k) => format!("{} keyframes", k.len()),
        };
        if let Some(p) = &self.stats {
            let mut v = serde_json::to_value(&report)?;
            let extra = serde_json::json!({
                "scene": self.scene.scene.display().to_string(),
                "width": request.width,
                "height": request.height,
                "encoding": format!("{:?}", self.encoding).to_lowercase(),
                "camera_path": describe,
                "upload_ms": upload_ms,
                "scene_image_bytes": prepared.image.len(),
                "out_dir": dir.display().to_string(),
            });
            if let (Some(m), serde_json::Value::Object(e)) = (v.as_object_mut(), extra) {
                m.extend(e);
            }
            super::output::write_bytes(p, (serde_json::to_string_pretty(&v)? + "\n").as_bytes())?;
        }
        println!(
            "stream     {} frames {}×{} ({describe}) in {:.2} s: {:.2} fps, line utilisation {:.3} at {baud} baud on {} board{}, {} B from the board{}",
            report.frames.len(),
            request.width,
            request.height,
            report.elapsed_s,
            report.fps,
            report.line_utilisation,
            report.boards,
            if report.boards == 1 { "" } else { "s" },
            report.wire_rx,
            if report.boards == 1 { "" } else { "s" },
        );
        println!("upload     {upload_ms:.0} ms");
        if let Some(p) = &self.apng {
            let mut indices: Vec<u32> = report.frames.iter().map(|f| f.index).collect();
            indices.sort_unstable();
            let names: Vec<PathBuf> = indices.iter().map(|&i| dir.join(frame_name(i))).collect();
            let fps = self.apng_fps.unwrap_or(report.fps);
            super::output::write_apng(p, &names, super::output::apng_delay(fps))?;
            println!("wrote      {} ({} frames, {fps:.2} fps)", p.display(), names.len());
        }
        println!(
            "wrote      {}/{}{} ({:.1} s total)",
            dir.display(),
            frame_name(0),
            if frames > 1 { format!(" … {}", frame_name(frames - 1)) } else { String::new() },
            total_start.elapsed().as_secs_f64()
        );
        if let Some(v) = view {
            v.finish(Figures {
                frames_done: report.frames.len() as u32,
                frames,
                fps: report.fps,
                line_utilisation: report.line_utilisation,
                wire_rx: report.wire_rx,
                baud,
                last_frame_ms: report.frames.last().map_or(0.0, |f| f.frame_ms),
                done: true,
            });
            if self.view_linger > 0.0 {
                eprintln!("view       {} stays up {:.0} s", v.url(), self.view_linger);
                std::thread::sleep(Duration::from_secs_f64(self.view_linger));
            }
        }
        Ok(())
    }
}
