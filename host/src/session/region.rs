//! Reliable rendering with `RenderRegion` (SPEC.md §3.12): selective repeat of whatever did
//! not arrive intact, device-reset recovery, adaptive span size.
//!
//! # Acceptance rule
//! A pixel is accepted only when it lies in a region whose `RegionEnd` arrived and the CRC-32
//! of the region's pixels, as assembled here, equals the CRC the device computed while
//! rendering them. Every span also passed its frame CRC-32 on the way in. Pixels of a region
//! whose `RegionEnd` was lost, or whose CRC did not match, are requested again.
//!
//! # One band
//! [`Session::render_band`] renders one rectangle ("band") of a frame into a [`Canvas`]:
//! 1. request the unverified part of the band (at first, all of it), one `RenderRegion` in
//!    flight (the device does not read its UART while it renders, so a second request could
//!    be lost in its receive FIFO);
//! 2. take spans, `Stats` and `RegionEnd`s until the `RegionEnd` of that request arrives, or
//!    the line has been idle for [`SessionConfig::retransmit_after`] (request or end lost), or
//!    the device reports a corrupt frame before answering (request lost: resend after a
//!    short grace period);
//! 3. check every `RegionEnd` claim whose pixels are all present;
//! 4. if pixels remain unverified, group them into regions (consecutive rows with unverified
//!    pixels, the union of their column ranges) and go to 1.
//!
//! A device reset is recognised by its banner (an unsolicited `Version` with sequence number
//! 0) or by `Error{NoScene}` in answer to a request: the session uploads the scene again and
//! carries on with the pixels still missing. Every wait is bounded: no progress for
//! [`SessionConfig::render_timeout`], or more than [`SessionConfig::max_requests_per_band`]
//! requests, ends the band with an error naming port, stage and sequence numbers.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{region_options, render_flags, ErrorCode, Msg, MsgType, Region, RenderRequest};

use super::canvas::{merge_stat, Canvas, VERIFIED};
use super::client::{Incoming, Session};
use super::error::{SessionError, Stage};
use super::link::SpanSizer;
use super::progress::ProgressEvent;
use super::render::RenderedFrame;

/// Row interpolation (seed 003) makes a pixel depend on its row's traced neighbours and, in
/// the adaptive mode, on the step chosen for the rows before: re-requested pixels only come
/// out as in the first render when the request covers whole rows (fixed step), or the band
/// from its first row (adaptive).
fn widen_for_interpolation(gap: Region, band: Region, flags: u16) -> Region {
    if render_flags::interp_step(flags) == 0 {
        return gap;
    }
    let (y0, rows) = if flags & render_flags::INTERP_ADAPTIVE != 0 {
        (band.y0, gap.y0 + gap.rows - band.y0)
    } else {
        (gap.y0, gap.rows)
    };
    Region { x0: band.x0, y0, cols: band.cols, rows }
}

/// Counters of one `RenderRegion` attempt.
#[derive(Debug, Default)]
struct Attempt {
    got_any: bool,
    new_pixels: usize,
    span_bytes: u64,
    span_pixels: u64,
}

/// Outcome of waiting for one request.
enum Wait {
    /// The `RegionEnd` of the request arrived.
    Ended,
    /// Nothing more will come for it (lost request or end, device error report).
    GaveUp,
    /// The device reset (banner or `NoScene`).
    Reset,
}

/// Result of one band.
#[derive(Debug, Clone, Default)]
pub struct BandReport {
    /// Requests sent for the band.
    pub requests: u32,
    /// Sum of the device counters of every region rendered (re-renders included).
    pub stats: BTreeMap<u8, u64>,
    /// Spans the device reported in the `RegionEnd`s received.
    pub spans_reported: u32,
}

impl<T: Read + Write> Session<T> {
    /// Renders `band` of the frame `req` describes into `canvas` until every pixel of the
    /// band is verified (see the module docs). `canvas` must be `req.width`×`req.height`.
    pub fn render_band(
        &mut self,
        req: &RenderRequest,
        band: Region,
        canvas: &mut Canvas,
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<BandReport, SessionError> {
        let stage = Stage::Render;
        if !band.fits(req.width, req.height) || canvas.width != req.width || canvas.height != req.height {
            return Err(
                self.bad_input(stage, format!("band {band:?} does not fit the {}×{} frame", req.width, req.height))
            );
        }
        let mut report = BandReport::default();
        let mut claims: Vec<(Region, u32)> = Vec::new();
        let mut sizer = self.sizer.take().unwrap_or_else(|| SpanSizer::new(req.encoding));
        let mut announced = vec![false; band.rows as usize];
        let mut last_progress = Instant::now();
        let mut first = true;
        // How long a quiet line means the request or its end was lost. It adapts to the
        // device: doubled after each wait that gave up, and after a region that ended, twice
        // the longest quiet spell of its answer (at least `retransmit_after`): a board
        // simulated cycle by cycle goes quiet for seconds while it computes, and asking again
        // sooner would only queue requests behind the one it is serving.
        let mut idle = self.cfg.retransmit_after;
        loop {
            self.check_claims(canvas, &mut claims);
            for y in canvas.verified_rows(band) {
                let a = &mut announced[(y - band.y0) as usize];
                if !*a {
                    *a = true;
                    last_progress = Instant::now();
                    progress(ProgressEvent::RowVerified { y });
                }
            }
            let Some(gap) = canvas.next_gap(band) else {
                self.sizer = Some(sizer);
                return Ok(report);
            };
            let gap = widen_for_interpolation(gap, band, req.flags);
            if report.requests >= self.cfg.max_requests_per_band || last_progress.elapsed() >= self.cfg.render_timeout {
                self.sizer = Some(sizer);
                let waited = last_progress.elapsed();
                return Err(SessionError::Timeout {
                    port: self.cfg.port_name.clone(),
                    stage,
                    waited,
                    last_seq: self.last_rx_seq,
                    sent_seq: self.tx_seq.wrapping_sub(1),
                    what: format!(
                        "rows {}..{} of frame {} still unverified after {} requests",
                        gap.y0,
                        gap.y0 + gap.rows,
                        req.frame,
                        report.requests
                    ),
                });
            }
            if !first {
                self.link.regions_resent += 1;
                self.link.pixels_resent += gap.pixels();
                progress(ProgressEvent::Resend { region: gap });
            }
            let resend = !first;
            first = false;
            report.requests += 1;
            let (tx0, rx0) = (self.bytes_tx, self.bytes_rx);
            let (ok0, bad0) = (self.rx_frames, self.link.resyncs);
            let mut att = Attempt::default();
            let max_span = sizer.max_span;
            if max_span != 0 && (self.link.min_max_span == 0 || max_span < self.link.min_max_span) {
                self.link.min_max_span = max_span;
            }
            // Pixels all here but unverified (their RegionEnd was lost or did not match yet):
            // ask only for the CRC, the device re-renders without sending the pixels.
            let options = if canvas.complete(gap) { region_options::CRC_ONLY } else { 0 };
            // A lone delimiter first: the device drops whatever noise it holds.
            self.write_bytes(stage, &[0])?;
            self.send(stage, &Msg::RenderRegion { region: gap, max_span, options, request: *req })?;
            self.link.regions_requested += 1;
            let outcome = self.wait_region(req, gap, canvas, &mut claims, &mut report, &mut att, resend, &mut idle)?;
            let (dtx, drx) = (self.bytes_tx - tx0, self.bytes_rx - rx0);
            if resend {
                self.link.bytes_resent += dtx + drx;
            }
            sizer.update(self.rx_frames - ok0, self.link.resyncs - bad0, drx, att.span_bytes, att.span_pixels);
            if att.new_pixels > 0 {
                last_progress = Instant::now();
            }
            match outcome {
                Wait::Ended | Wait::GaveUp => {}
                Wait::Reset => {
                    self.link.device_resets += 1;
                    progress(ProgressEvent::DeviceReset);
                    self.recover_scene(progress)?;
                    last_progress = Instant::now();
                }
            }
        }
    }

    fn bad_input(&self, stage: Stage, what: String) -> SessionError {
        SessionError::BadInput { port: self.cfg.port_name.clone(), stage, what }
    }

    /// Checks every claim whose region is complete; drops checked claims.
    fn check_claims(&mut self, canvas: &mut Canvas, claims: &mut Vec<(Region, u32)>) {
        claims.retain(|&(r, crc)| {
            if !canvas.complete(r) {
                return true;
            }
            if canvas.crc(r) == crc {
                canvas.mark(r, |s| s | VERIFIED);
            } else {
                // Not what the device rendered: forget the unverified pixels and ask again.
                self.link.region_crc_mismatches += 1;
                canvas.mark(r, |s| if s & VERIFIED != 0 { s } else { 0 });
            }
            false
        });
    }

    /// Waits for the answer to the `RenderRegion` of `region`.
    #[allow(clippy::too_many_arguments)]
    fn wait_region(
        &mut self,
        req: &RenderRequest,
        region: Region,
        canvas: &mut Canvas,
        claims: &mut Vec<(Region, u32)>,
        report: &mut BandReport,
        att: &mut Attempt,
        resend: bool,
        idle_after: &mut Duration,
    ) -> Result<Wait, SessionError> {
        let stage = Stage::Render;
        let idle = *idle_after;
        let mut deadline = Instant::now() + idle;
        let mut last_msg = Instant::now();
        let mut quiet = Duration::ZERO;
        loop {
            let msg = self.poll(stage, deadline)?;
            let Some(m) = msg else {
                self.link.timeouts += 1;
                *idle_after = idle.saturating_mul(2).min(self.cfg.render_timeout.max(self.cfg.retransmit_after));
                return Ok(Wait::GaveUp);
            };
            quiet = quiet.max(last_msg.elapsed());
            last_msg = Instant::now();
            match m {
                Incoming::PixelSpan { frame, y, x0, count, encoding, data } if frame == req.frame => {
                    let wire = data.len() as u64 + 22;
                    att.new_pixels +=
                        canvas.place(y, x0, count, encoding, &data).map_err(|w| self.protocol(stage, w))?;
                    if encoding.is_colour() {
                        self.link.spans_received += 1;
                        if resend {
                            self.link.spans_resent += 1;
                        }
                        att.span_pixels += count as u64;
                    }
                    att.span_bytes += wire;
                    att.got_any = true;
                    deadline = Instant::now() + idle;
                }
                Incoming::Stats { frame, entries } if frame == req.frame => {
                    for (k, v) in entries {
                        merge_stat(&mut report.stats, k, v);
                    }
                    att.got_any = true;
                    deadline = Instant::now() + idle;
                }
                Incoming::RegionEnd { frame, region: r, spans, crc } if frame == req.frame => {
                    if r.fits(canvas.width, canvas.height) {
                        claims.push((r, crc));
                    }
                    report.spans_reported += spans;
                    att.got_any = true;
                    if r == region {
                        *idle_after = quiet
                            .saturating_mul(2)
                            .clamp(self.cfg.retransmit_after, self.cfg.render_timeout.max(self.cfg.retransmit_after));
                        return Ok(Wait::Ended);
                    }
                    deadline = Instant::now() + idle;
                }
                Incoming::Version(_) if self.last_rx_seq == Some(0) => return Ok(Wait::Reset),
                Incoming::Error { code: ErrorCode::NoScene, .. } => return Ok(Wait::Reset),
                Incoming::Error { code: ErrorCode::BadFrame, .. } => {
                    self.link.device_bad_frames += 1;
                    if !att.got_any {
                        // Probably our request: resend soon, unless spans start arriving.
                        deadline = deadline.min(Instant::now() + idle / 4);
                    }
                }
                // Late answers to scene chunks retransmitted during the upload.
                Incoming::Error { code: ErrorCode::BadOffset, .. } => {}
                Incoming::Error { code: ErrorCode::UnexpectedMessage, detail, .. }
                    if detail != MsgType::RenderRegion as u32 => {}
                Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                _ => {} // stale traffic of other frames, late Versions
            }
        }
    }

    /// After a device reset: upload the scene again (the device lost it).
    fn recover_scene(&mut self, progress: &mut dyn FnMut(ProgressEvent)) -> Result<(), SessionError> {
        let Some(scene) = self.scene.clone() else {
            return Err(self.device_err(
                Stage::Render,
                ErrorCode::NoScene,
                0,
                "device reset and no scene was uploaded in this session".into(),
            ));
        };
        self.link.scene_reuploads += 1;
        self.upload_scene(&scene, progress)
    }

    /// Renders a whole frame with regions of at most `cfg.band_rows` rows (0 = one region).
    pub(super) fn render_regions(
        &mut self,
        req: &RenderRequest,
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<RenderedFrame, SessionError> {
        let start = Instant::now();
        let (tx0, rx0) = (self.bytes_tx, self.bytes_rx);
        let link0 = self.link.clone();
        progress(ProgressEvent::RenderStarted { width: req.width, height: req.height });
        let mut canvas = Canvas::new(req.width, req.height, req.flags & render_flags::PRIM_IDS != 0);
        let band_rows = if self.cfg.band_rows == 0 { req.height } else { self.cfg.band_rows.min(req.height) };
        let mut stats = BTreeMap::new();
        let mut spans_reported = 0;
        let mut rows_done = 0u32;
        let mut y0 = 0;
        while y0 < req.height {
            let rows = band_rows.min(req.height - y0);
            let band = Region { x0: 0, y0, cols: req.width, rows };
            let mut on = |e: ProgressEvent| match e {
                ProgressEvent::RowVerified { y } => {
                    rows_done += 1;
                    progress(ProgressEvent::RowReceived { y, rows_done });
                }
                other => progress(other),
            };
            let r = self.render_band(req, band, &mut canvas, &mut on)?;
            for (k, v) in r.stats {
                merge_stat(&mut stats, k, v);
            }
            spans_reported += r.spans_reported;
            y0 += rows;
        }
        progress(ProgressEvent::Finished);
        let link = self.link.since(&link0);
        Ok(RenderedFrame {
            frame: req.frame,
            width: req.width,
            height: req.height,
            image_crc: crc32(&canvas.rgb),
            rgb: canvas.rgb,
            prim_ids: canvas.prim_ids,
            stats,
            spans_reported,
            spans_received: link.spans_received as u32 * if req.flags & render_flags::PRIM_IDS != 0 { 2 } else { 1 },
            bytes_tx: self.bytes_tx - tx0,
            bytes_rx: self.bytes_rx - rx0,
            elapsed: start.elapsed(),
            link,
        })
    }
}
