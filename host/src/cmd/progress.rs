//! Draws the library's progress events on stderr: indicatif bars when stderr is a terminal;
//! otherwise (a pipe, a file, a CI log) plain lines, one at each stage's start and end and
//! one every [`LINE_EVERY`] in between — bytes, rate, retransmits, line errors and when the
//! device was last heard (with `--verbose`, also which message) — so a long or struggling
//! transfer is never silent. Stdout keeps the results.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use gridrt_host::flash::FlashEvent;
use gridrt_host::session::{Activity, ProgressEvent, Stage};
use indicatif::{ProgressBar, ProgressStyle};

/// Time between progress lines when stdout is not a terminal (at most; the library reports
/// at least once a second).
pub const LINE_EVERY: Duration = Duration::from_secs(4);

/// `--verbose`: progress lines name the device's last message (protocol detail).
static VERBOSE: AtomicBool = AtomicBool::new(false);

/// Sets `--verbose` for every progress display of the process.
pub fn set_verbose(on: bool) {
    VERBOSE.store(on, Ordering::Relaxed);
}

/// Whether `--verbose` is on.
pub fn verbose() -> bool {
    VERBOSE.load(Ordering::Relaxed)
}

/// When the device was last heard, without the message's fields: `0.2 s ago` out of
/// `SceneSack {next 500, …} (seq 3) 0.2 s ago`.
fn heard_when(last_heard: &str) -> String {
    match last_heard.rfind(") ") {
        Some(i) => last_heard[i + 2..].to_string(),
        None if last_heard == "nothing" => "never".to_string(),
        None => last_heard.to_string(),
    }
}

/// How progress is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// indicatif bars on stderr.
    Bars,
    /// Lines on stderr.
    Lines,
}

/// Progress display for one command.
#[derive(Debug)]
pub struct CliProgress {
    mode: Mode,
    bar: Option<ProgressBar>,
    /// When the last line was printed (`Lines`).
    last_line: Option<Instant>,
    /// The latest activity, printed at a stage's end.
    latest: Option<Activity>,
    /// Rows of the current frame whose pixels all arrived (frame CRCs checked).
    rows_in: u64,
    /// Which frame of a stream is being drawn (`frame 3/30`), if any: per-frame start
    /// lines are left out then, and the stream prints one line per frame.
    frame_label: Option<String>,
}

impl Default for CliProgress {
    fn default() -> Self {
        Self::new(if std::io::stderr().is_terminal() { Mode::Bars } else { Mode::Lines })
    }
}

fn bar(len: u64, template: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// `n` bytes in B, KiB or MiB.
fn size(n: f64) -> String {
    if n >= 10.0 * 1024.0 * 1024.0 {
        format!("{:.1} MiB", n / 1048576.0)
    } else if n >= 10.0 * 1024.0 {
        format!("{:.1} KiB", n / 1024.0)
    } else {
        format!("{n:.0} B")
    }
}

/// One progress line for `a` (what `Lines` mode prints).
pub fn line(a: &Activity) -> String {
    let secs = a.elapsed.as_secs_f64().max(1e-3);
    // A render's rows count as they arrive; an upload's bytes when acknowledged.
    let shown = if a.stage == Stage::Render { a.received.max(a.done) } else { a.done };
    let pct = if a.total > 0 { 100.0 * shown as f64 / a.total as f64 } else { 0.0 };
    let (done, rate, again, unit) = match a.stage {
        Stage::Render => (
            format!("{} / {} px in, {} verified", a.received, a.total, a.done),
            format!("{}/s in", size(a.wire_rx as f64 / secs)),
            "runs re-requested",
            if a.chunk == 0 { "spans default".to_string() } else { format!("spans ≤ {} B", a.chunk) },
        ),
        _ => (
            format!("{} / {}", size(a.done as f64), size(a.total as f64)),
            format!("{}/s payload, {}/s out", size(a.done as f64 / secs), size(a.wire_tx as f64 / secs)),
            "chunks resent",
            format!("chunks {} B", a.chunk),
        ),
    };
    format!(
        "{:<7} {done} ({pct:.0} %) in {secs:.1} s, {rate}, {} {again}, {} line errors, {unit}; last heard {}",
        a.stage.to_string().split(' ').next_back().unwrap_or("link"),
        a.retransmits,
        a.line_errors,
        if verbose() { a.last_heard.clone() } else { heard_when(&a.last_heard) }
    )
}

impl CliProgress {
    /// A display in `mode`.
    pub fn new(mode: Mode) -> Self {
        Self { mode, bar: None, last_line: None, latest: None, rows_in: 0, frame_label: None }
    }

    /// Marks the frames of a stream: `label` (e.g. `frame 3/30`) prefixes the render bar.
    pub fn set_frame(&mut self, label: Option<String>) {
        self.frame_label = label;
    }

    /// How progress is shown.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// One line on stderr above the bar (or plain, in `Lines` mode).
    pub fn println(&mut self, text: &str) {
        match &self.bar {
            Some(b) => b.println(text),
            None => self.say(text),
        }
    }

    fn say(&mut self, text: &str) {
        let mut out = std::io::stderr().lock();
        let _ = writeln!(out, "{text}");
        let _ = out.flush();
        self.last_line = Some(Instant::now());
    }

    fn activity(&mut self, a: Activity) {
        match self.mode {
            Mode::Bars => {
                if let Some(b) = &self.bar {
                    if a.retransmits + a.line_errors > 0 {
                        b.set_message(format!("({} resent, {} line errors)", a.retransmits, a.line_errors));
                    }
                }
            }
            Mode::Lines => {
                if self.last_line.is_none_or(|t| t.elapsed() >= LINE_EVERY) {
                    self.say(&line(&a));
                }
            }
        }
        self.latest = Some(a);
    }

    fn start(&mut self, total: u64, template: &str, what: &str) {
        self.finish();
        self.latest = None;
        match self.mode {
            Mode::Bars => self.bar = Some(bar(total, template)),
            Mode::Lines => self.say(what),
        }
    }

    fn position(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.set_position(n);
        }
    }

    fn note(&self, text: String) {
        if let Some(b) = &self.bar {
            b.set_message(text);
        }
    }

    /// Handles one session event.
    pub fn handle(&mut self, event: ProgressEvent) {
        match event {
            ProgressEvent::Connected(_) | ProgressEvent::RowVerified { .. } => {}
            ProgressEvent::UploadStarted { total } => self.start(
                total,
                "upload [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} {msg}",
                &format!("upload  {} scene image", size(total as f64)),
            ),
            ProgressEvent::Uploaded { bytes, .. } => self.position(bytes),
            ProgressEvent::UploadRewound { offset } => self.note(format!("(resending from {offset})")),
            ProgressEvent::RenderStarted { width, height } => {
                self.rows_in = 0;
                match self.frame_label.clone() {
                    None => self.start(
                        height as u64,
                        "render [{bar:40}] {pos}/{len} rows in {elapsed_precise} eta {eta} {msg}",
                        &format!("render  {width}×{height} frame"),
                    ),
                    Some(label) => {
                        self.finish();
                        self.latest = None;
                        if self.mode == Mode::Bars {
                            let t = format!("{label} [{{bar:40}}] {{pos}}/{{len}} rows in {{elapsed_precise}} {{msg}}");
                            self.bar = Some(bar(height as u64, &t));
                        }
                    }
                }
            }
            // Counted as they arrive (every span passed its frame CRC), never at the frame's end.
            ProgressEvent::RowArrived { .. } => {
                self.rows_in += 1;
                self.position(self.rows_in);
            }
            ProgressEvent::RowReceived { rows_done, .. } => self.note(format!("{rows_done} verified")),
            ProgressEvent::Resend { region } => {
                self.note(format!("(re-requesting rows {}..{})", region.y0, region.y0 + region.rows))
            }
            ProgressEvent::DeviceReset => {
                self.note("(device reset: uploading the scene again)".into());
                if self.mode == Mode::Lines {
                    self.say("device reset: uploading the scene again, then the pixels still missing");
                }
            }
            ProgressEvent::Activity(a) => self.activity(a),
            ProgressEvent::UploadFinished { .. } | ProgressEvent::Finished => self.finish(),
        }
    }

    /// Handles one flash event.
    pub fn handle_flash(&mut self, event: FlashEvent) {
        match event {
            FlashEvent::Connected(_) => {}
            FlashEvent::Started { total } => self.start(
                total,
                "flash  [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} {msg}",
                &format!("flash   {} application image", size(total as f64)),
            ),
            FlashEvent::Written { bytes, .. } => self.position(bytes),
            FlashEvent::Resent { offset } => self.note(format!("(resending from {offset})")),
            FlashEvent::Activity(a) => self.activity(a),
            FlashEvent::Verified { .. } | FlashEvent::Booting { .. } => self.finish(),
        }
    }

    /// Ends the current stage: removes its bar, or prints its last line.
    pub fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        if self.mode == Mode::Lines {
            if let Some(a) = self.latest.take() {
                self.say(&line(&a));
            }
        }
    }

    /// Drops the bar without the final line (the operation failed; its error follows).
    pub fn abandon(&mut self) {
        if let Some(b) = self.bar.take() {
            b.abandon();
        }
        self.latest = None;
    }
}

impl Drop for CliProgress {
    fn drop(&mut self) {
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn act(stage: Stage, done: u64, secs: u64) -> Activity {
        Activity {
            stage,
            done,
            received: done + 100,
            total: 1000,
            wire_tx: 2 * done,
            wire_rx: done / 2,
            elapsed: Duration::from_secs(secs),
            retransmits: 7,
            line_errors: 9,
            chunk: 134,
            last_heard: "SceneSack {next 500, Receiving, 1 ranges} (seq 3) 0.2 s ago".into(),
        }
    }

    #[test]
    fn a_line_names_bytes_rate_retransmits_and_what_was_heard() {
        let l = line(&act(Stage::Upload, 500, 2));
        for part in ["upload", "500 B / 1000 B (50 %)", "250 B/s payload", "7 chunks resent", "9 line errors"] {
            assert!(l.contains(part), "`{part}` missing from: {l}");
        }
        assert!(l.contains("last heard 0.2 s ago") && !l.contains("SceneSack"), "{l}");
        set_verbose(true);
        let v = line(&act(Stage::Upload, 500, 2));
        set_verbose(false);
        assert!(v.contains("last heard SceneSack"), "{v}");
        let r = line(&act(Stage::Render, 500, 1));
        assert!(r.starts_with("render") && r.contains("600 / 1000 px in, 500 verified") && r.contains("7 runs"), "{r}");
    }

    #[test]
    fn lines_mode_keeps_quiet_between_lines_and_prints_the_last_state_at_the_end() {
        let mut p = CliProgress::new(Mode::Lines);
        p.handle(ProgressEvent::UploadStarted { total: 1000 });
        let t = p.last_line.expect("a line at the start");
        p.handle(ProgressEvent::Activity(act(Stage::Upload, 100, 1)));
        assert_eq!(p.last_line, Some(t), "no second line within {LINE_EVERY:?}");
        p.last_line = Some(t - LINE_EVERY);
        p.handle(ProgressEvent::Activity(act(Stage::Upload, 200, 5)));
        assert!(p.last_line.unwrap() > t, "a line once {LINE_EVERY:?} passed");
        p.handle(ProgressEvent::UploadFinished { total: 1000 });
        assert!(p.latest.is_none());
    }
}
