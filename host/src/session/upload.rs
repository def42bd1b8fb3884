//! Scene upload: windowed selective repeat (SPEC.md §3.14, [`super::transfer`]) to a device
//! that advertises `WINDOWED`; otherwise `SceneChunk`s in order with go-back-N (§3.10).

use std::io::{Read, Write};
use std::sync::Arc;
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{feature, ErrorCode, Msg, MsgType, SceneStatus};

use super::client::{Incoming, Session};
use super::config::{MAX_CHUNK, MIN_CHUNK};
use super::error::{SessionError, Stage};
use super::progress::ProgressEvent;
use super::transfer::Kind;

/// Largest chunk of the in-order upload (its window is counted in chunks).
const IN_ORDER_CHUNK: usize = 1024;

impl<T: Read + Write> Session<T> {
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
    /// (until the line is quiet for a derived wait) before the error is returned, so the
    /// session can go on with the next request.
    pub fn upload_scene(&mut self, image: &[u8], progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let windowed = self.device.is_some_and(|d| d.features & feature::WINDOWED != 0);
        // A device that decodes compact streams (SPEC.md §5.12) gets one: the same image, in
        // about a third of the bytes; any other device gets the image itself.
        let compact = self.device.is_some_and(|d| d.features & feature::COMPACT_SCENE != 0);
        let packed = if compact { crate::compact::encode(image, crate::compact::CACHE_LOG2) } else { None };
        let wire = packed.as_deref().unwrap_or(image);
        let r = if windowed { self.upload_windowed(wire, progress) } else { self.upload_in_order(wire, progress) };
        if matches!(
            r,
            Err(SessionError::Device { .. } | SessionError::Protocol { .. } | SessionError::UploadStalled { .. })
        ) {
            let quiet = self.answer_wait(MAX_CHUNK, 64);
            self.drain(Stage::Upload, quiet, 10 * quiet);
        }
        if r.is_ok() && self.scene.as_deref() != Some(image) {
            // Kept for re-uploads after a device reset (SPEC.md §3.12).
            self.scene = Some(Arc::from(image));
        }
        r
    }

    fn upload_windowed(&mut self, image: &[u8], progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let total = u32::try_from(image.len()).map_err(|_| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage: Stage::Upload,
            what: "scene image larger than 4 GiB".into(),
        })?;
        let crc = crc32(image);
        progress(ProgressEvent::UploadStarted { total: total as u64 });
        self.send_windowed(Kind::Scene, &Msg::SceneBegin { total_len: total, crc }, image, crc, progress)?;
        progress(ProgressEvent::UploadFinished { total: total as u64 });
        Ok(())
    }

    /// `SceneChunk`s in order, a window of [`super::SessionConfig::window`] chunks, back to
    /// the device's offset on `BadOffset` or silence (go-back-N), smaller chunks on errors.
    fn upload_in_order(&mut self, image: &[u8], progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let stage = Stage::Upload;
        let total = u32::try_from(image.len()).map_err(|_| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage,
            what: "scene image larger than 4 GiB".into(),
        })?;
        let device_cap = self.device.map_or(IN_ORDER_CHUNK, |d| (d.max_payload as usize).saturating_sub(4));
        let mut chunk = self.cfg.chunk_size.min(IN_ORDER_CHUNK).min(device_cap).max(1);
        let min_chunk = (4 * MIN_CHUNK).min(chunk);
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
            if stalls > self.cfg.max_probes {
                return Err(SessionError::UploadStalled {
                    port: self.cfg.port_name.clone(),
                    offset: acked,
                    rewinds: stalls,
                    last_heard: self.last_heard(),
                });
            }
            // Everything in flight has to cross before its acknowledgement can.
            let wait = self.answer_wait((next - acked.min(next)) as usize + 32, 32);
            let in_flight = ((next - acked.min(next)) as usize).div_ceil(chunk.max(1));
            let mut restart = false;
            match self.poll(stage, Instant::now() + wait)? {
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
                Some(Incoming::Error { code: ErrorCode::NoScene, .. }) => {
                    // The device answers only render requests with `NoScene` (SPEC §3.12): this
                    // is a late answer to one sent before the device reset, not to the upload.
                }
                Some(Incoming::Error { code, detail, text }) => return Err(self.device_err(stage, code, detail, text)),
                Some(_) => {}
                None => {
                    self.link.timeouts += 1;
                    if next > acked {
                        // Nothing acknowledged in time: go back and resend, smaller.
                        chunk = (chunk / 2).max(min_chunk);
                        stalls += 1;
                        next = acked;
                        rewound_to = Some(acked);
                        progress(ProgressEvent::UploadRewound { offset: acked as u64 });
                    } else {
                        stalls += 1;
                    }
                    if stalls > self.cfg.max_probes {
                        return Err(self.timeout(
                            stage,
                            last_progress.elapsed(),
                            format!("acknowledgement of scene offset {acked} of {total}"),
                        ));
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
}
