//! Draws the library's [`ProgressEvent`]s with indicatif (on stderr; hidden when stderr is
//! not a terminal).

use gridrt_host::session::ProgressEvent;
use indicatif::{ProgressBar, ProgressStyle};

/// Progress bars for one command.
#[derive(Debug, Default)]
pub struct CliProgress {
    bar: Option<ProgressBar>,
}

fn bar(len: u64, template: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

impl CliProgress {
    /// Handles one event.
    pub fn handle(&mut self, event: ProgressEvent) {
        match event {
            ProgressEvent::Connected(_) => {}
            ProgressEvent::UploadStarted { total } => {
                self.finish();
                self.bar = Some(bar(total, "upload [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} {msg}"));
            }
            ProgressEvent::Uploaded { bytes, .. } => {
                if let Some(b) = &self.bar {
                    b.set_position(bytes);
                }
            }
            ProgressEvent::UploadRewound { offset } => {
                if let Some(b) = &self.bar {
                    b.set_message(format!("(resending from {offset})"));
                }
            }
            ProgressEvent::RenderStarted { height, .. } => {
                self.finish();
                self.bar = Some(bar(height as u64, "render [{bar:40}] {pos}/{len} rows {elapsed_precise} eta {eta}"));
            }
            ProgressEvent::RowReceived { rows_done, .. } => {
                if let Some(b) = &self.bar {
                    b.set_position(rows_done as u64);
                }
            }
            ProgressEvent::Resend { region } => {
                if let Some(b) = &self.bar {
                    b.set_message(format!("(re-requesting rows {}..{})", region.y0, region.y0 + region.rows));
                }
            }
            ProgressEvent::DeviceReset => {
                if let Some(b) = &self.bar {
                    b.set_message("(device reset: uploading the scene again)");
                }
            }
            ProgressEvent::RowVerified { .. } => {}
            ProgressEvent::UploadFinished { .. } | ProgressEvent::Finished => self.finish(),
        }
    }

    /// Removes the current bar.
    pub fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }
}

impl Drop for CliProgress {
    fn drop(&mut self) {
        self.finish();
    }
}
