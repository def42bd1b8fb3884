//! Reliable rendering with `RenderRegion` (SPEC.md §3.12): selective repeat of exactly what
//! did not arrive intact, device-reset recovery, span size adapted to the line.
//!
//! # Acceptance rule
//! A pixel is accepted only when it lies in a region whose `RegionEnd` arrived and the CRC-32
//! of the region's pixels, as assembled here, equals the CRC the device computed while
//! rendering them. Every span also passed its frame CRC-32 on the way in. Pixels of a region
//! whose `RegionEnd` was lost, or whose CRC did not match, are requested again.
//!
//! # One band
//! [`Session::render_band`] renders one rectangle ("band") of a frame into a [`Canvas`]:
//! 1. request the whole band once (with `Stats`);
//! 2. take spans, `Stats` and `RegionEnd`s until the `RegionEnd` of that request arrives, the
//!    device reports the request corrupt (`Error{BadFrame}` before any answer: sent again at
//!    once), or the line has been quiet for longer than the next frame takes to cross it plus
//!    the device's measured compute gap (request or end lost);
//! 3. check every `RegionEnd` claim whose pixels are all present;
//! 4. request again exactly the runs of pixels that never arrived — row by row, runs merged
//!    into one rectangle only while the pixels resent cost less line time than another request
//!    (`NO_STATS`: the first request's counters stand for the band); once every pixel is
//!    present, only pixels whose claim was lost stay unverified: ask for their CRC
//!    (`CRC_ONLY`, the device re-renders but sends no pixels). Go to 2.
//!
//! The device renders inside its receive loop and does not read its UART meanwhile (a soft-
//! core's receive FIFO holds 16 bytes, 1.4 ms at 115 200 baud, against tens of ms per row),
//! so one request is in flight at a time; the next leaves the moment the previous one ends.
//!
//! A device reset is recognised by its banner (an unsolicited `Version` with sequence number
//! 0) or by `Error{NoScene}` in answer to a request: the session uploads the scene again and
//! carries on with the pixels still missing. Every wait is bounded: no new pixel for
//! [`SessionConfig::render_timeout`](super::SessionConfig::render_timeout), more than
//! [`SessionConfig::max_probes`](super::SessionConfig::max_probes) requests in a row without
//! any answer, or more than [`SessionConfig::max_requests_per_band`](super::SessionConfig::max_requests_per_band)
//! requests, ends the band with an error naming port, stage, sequence numbers and what was
//! last heard.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{
    region_options, render_flags, ErrorCode, Msg, MsgType, Region, RenderRequest, RENDER_REGION_LEN,
};

use super::canvas::{merge_stat, Canvas, VERIFIED};
use super::client::{Incoming, Session};
use super::error::{SessionError, Stage};
use super::estimate::wire_len;
use super::link::{request_cost, SpanSizer};
use super::progress::{Activity, ProgressEvent};
use super::render::RenderedFrame;

/// Wire bytes of a `RenderRegion` (the lone `0x00` before it included).
const REQUEST_WIRE: usize = RENDER_REGION_LEN + 13;
/// Wire bytes of a `RegionEnd`.
const END_WIRE: usize = 32;

/// Row interpolation (Malcheva et al.) makes a pixel depend on its row's traced neighbours and, in
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

/// The smallest region holding `a` and the run `(y, x0, x1)`.
fn grow(a: Option<Region>, (y, x0, x1): (u16, u16, u16)) -> Region {
    match a {
        None => Region { x0, y0: y, cols: x1 - x0, rows: 1 },
        Some(r) => {
            let (lx, ly) = (r.x0.min(x0), r.y0.min(y));
            let (hx, hy) = ((r.x0 + r.cols).max(x1), (r.y0 + r.rows).max(y + 1));
            Region { x0: lx, y0: ly, cols: hx - lx, rows: hy - ly }
        }
    }
}

/// The first request for the missing `runs` (row-major): the first run, grown over the next
/// ones while the pixels that arrived already but would be sent again cost fewer wire bytes
/// than another request (`request_cost`) at `bytes_per_pixel`.
fn group_runs(runs: &[(u16, u16, u16)], bytes_per_pixel: f64, request_cost: f64, canvas: &Canvas) -> Region {
    let mut rect = grow(None, runs[0]);
    for &run in &runs[1..] {
        let bigger = grow(Some(rect), run);
        let resent_now = (rect.pixels() - canvas.missing_in(rect)) as f64;
        let resent = (bigger.pixels() - canvas.missing_in(bigger)) as f64;
        if (resent - resent_now) * bytes_per_pixel >= request_cost {
            break;
        }
        rect = bigger;
    }
    rect
}

/// Counters of one `RenderRegion` attempt.
#[derive(Debug, Default)]
struct Attempt {
    got_any: bool,
    new_pixels: usize,
}

/// Outcome of waiting for one request.
enum Wait {
    /// The `RegionEnd` of the request arrived.
    Ended,
    /// Nothing more will come for it (lost request or end, device error report).
    GaveUp,
    /// The device reset (banner or `NoScene`).
    Reset,
    /// Time for a progress report; the wait goes on after it.
    Tick,
}

/// Where the wait for one request stands (kept across progress reports).
struct Waiting {
    /// When the last message arrived (or the request left).
    last: Instant,
    /// When the device reported a corrupt frame before answering, if it did.
    nak: Option<Instant>,
    /// Pixels of the requested region not arrived yet, kept up to date span by span (a
    /// full scan of the region per message made a 1080p frame quadratic).
    missing: u64,
    /// Requests in a row the device left unanswered: each doubles the quiet limit (a device
    /// slower than its pace so far, e.g. a simulated SoC, is not sent the same work again
    /// and again; it renders every request it gets).
    backoff: u32,
}

/// Doublings of the quiet limit at most (×1024).
const MAX_BACKOFF: u32 = 10;

/// Result of one band.
#[derive(Debug, Clone, Default)]
pub struct BandReport {
    /// Requests sent for the band.
    pub requests: u32,
    /// The device counters of the band (the `Stats` of its first request; empty when that
    /// message was lost on the line).
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
        let mut arrived = vec![false; band.rows as usize];
        let mut last_progress = Instant::now();
        let mut first = true;
        let mut silent = 0u32;
        let start = Instant::now();
        let (tx0, rx0, errors0, resent0) = (self.bytes_tx, self.bytes_rx, self.line_errors(), self.link.regions_resent);
        let mut next_tick = Instant::now();
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
            let runs = canvas.missing_runs(band);
            let (gap, options) = if first {
                (band, 0)
            } else if !runs.is_empty() {
                let bpp = sizer.bytes_per_pixel_seen();
                let cost = request_cost(REQUEST_WIRE + END_WIRE, self.pace.reply, self.cfg.turnaround, self.cfg.baud);
                let g = widen_for_interpolation(group_runs(&runs, bpp, cost, canvas), band, req.flags);
                (g, region_options::NO_STATS)
            } else if let Some(g) = canvas.next_unverified(band) {
                // Every pixel is here; these lost their RegionEnd: ask for the CRC only.
                (widen_for_interpolation(g, band, req.flags), region_options::CRC_ONLY | region_options::NO_STATS)
            } else {
                self.sizer = Some(sizer);
                return Ok(report);
            };
            let stalled = last_progress.elapsed() >= self.cfg.render_timeout || silent > self.cfg.max_probes;
            if report.requests >= self.cfg.max_requests_per_band || stalled {
                self.sizer = Some(sizer);
                let what = format!(
                    "rows {}..{} of frame {} still unverified after {} requests ({} in a row unanswered)",
                    gap.y0,
                    gap.y0 + gap.rows,
                    req.frame,
                    report.requests,
                    silent
                );
                return Err(self.timeout(stage, last_progress.elapsed(), what));
            }
            if !first {
                self.link.regions_resent += 1;
                self.link.pixels_resent += gap.pixels();
                progress(ProgressEvent::Resend { region: gap });
            }
            let resend = !first;
            first = false;
            report.requests += 1;
            let (tx1, rx1) = (self.bytes_tx, self.bytes_rx);
            let max_span = sizer.max_span(self.est_down.byte_error_rate());
            if max_span != 0 && (self.link.min_max_span == 0 || max_span < self.link.min_max_span) {
                self.link.min_max_span = max_span;
            }
            let mut att = Attempt::default();
            let options = if max_span != 0 { options | region_options::SPAN_BYTES } else { options };
            if resend || self.ahead.front() != Some(&(req.frame, gap)) {
                // A lone delimiter first: the device drops whatever noise it holds.
                self.write_bytes(stage, &[0])?;
                self.send(stage, &Msg::RenderRegion { region: gap, max_span, options, request: *req })?;
            } else {
                // Sent ahead (`send_ahead`): the device is on it already.
                self.ahead.pop_front();
            }
            self.link.regions_requested += 1;
            let mut waiting = Waiting {
                last: Instant::now(),
                nak: None,
                missing: canvas.missing_in(gap),
                backoff: silent.min(MAX_BACKOFF),
            };
            let outcome = loop {
                let w = self.wait_region(
                    req,
                    gap,
                    canvas,
                    &mut claims,
                    &mut report,
                    &mut att,
                    &mut sizer,
                    resend,
                    &mut waiting,
                    next_tick,
                    (band, &mut arrived),
                    progress,
                )?;
                if !matches!(w, Wait::Tick) && Instant::now() < next_tick {
                    break w;
                }
                next_tick = Instant::now() + Duration::from_secs(1);
                progress(ProgressEvent::Activity(Activity {
                    stage,
                    received: arrived.iter().filter(|a| **a).count() as u64 * u64::from(band.cols),
                    done: canvas.verified_pixels(band),
                    total: band.pixels(),
                    wire_tx: self.bytes_tx - tx0,
                    wire_rx: self.bytes_rx - rx0,
                    elapsed: start.elapsed(),
                    retransmits: self.link.regions_resent - resent0,
                    line_errors: self.line_errors() - errors0,
                    chunk: max_span as usize,
                    last_heard: self.last_heard(),
                }));
                if !matches!(w, Wait::Tick) {
                    break w;
                }
            };
            if resend {
                self.link.bytes_resent += (self.bytes_tx - tx1) + (self.bytes_rx - rx1);
            }
            silent = if att.got_any { 0 } else { silent + 1 };
            if att.new_pixels > 0 {
                last_progress = Instant::now();
            }
            match outcome {
                Wait::Ended | Wait::GaveUp | Wait::Tick => {}
                Wait::Reset => {
                    self.link.device_resets += 1;
                    progress(ProgressEvent::DeviceReset);
                    self.recover_scene(progress)?;
                    last_progress = Instant::now();
                    silent = 0;
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

    /// How long the line may stay quiet while an answer to `region` is under way: the next
    /// frame's wire time plus the device's compute gap (the first message of an answer comes
    /// after a longer gap: the first row's work).
    fn quiet_limit(&self, got_any: bool, complete: bool) -> Duration {
        let p = self.pace;
        if complete {
            // Only the end (and maybe Stats) is left; it follows the last span at once.
            return self.answer_wait(0, 300) + p.gap;
        }
        let compute = if got_any { 2 * p.gap } else { 2 * p.first };
        self.answer_wait(0, p.frame) + compute
    }

    /// Waits for the answer to the `RenderRegion` of `region` (returns `Tick` at `tick`).
    #[allow(clippy::too_many_arguments)]
    fn wait_region(
        &mut self,
        req: &RenderRequest,
        region: Region,
        canvas: &mut Canvas,
        claims: &mut Vec<(Region, u32)>,
        report: &mut BandReport,
        att: &mut Attempt,
        sizer: &mut SpanSizer,
        resend: bool,
        waiting: &mut Waiting,
        tick: Instant,
        (band, arrived): (Region, &mut [bool]),
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<Wait, SessionError> {
        let stage = Stage::Render;
        loop {
            let (last, nak) = (waiting.last, waiting.nak);
            let limit = match nak {
                // The device found a corrupt frame before answering: most likely our request.
                // Send it again unless spans start to flow within a turnaround.
                Some(at) => at + self.cfg.turnaround + self.answer_wait(0, 64),
                None => {
                    let quiet = self.quiet_limit(att.got_any, waiting.missing == 0);
                    // Backed off, but no longer than a render may go without a pixel.
                    last + (quiet * (1 << waiting.backoff)).min(self.cfg.render_timeout.max(quiet))
                }
            };
            let before = self.bytes_rx;
            let msg = self.poll(stage, limit.min(tick))?;
            let Some(m) = msg else {
                if Instant::now() < limit {
                    return Ok(Wait::Tick);
                }
                self.link.timeouts += 1;
                return Ok(Wait::GaveUp);
            };
            let now = Instant::now();
            // Learn the device's pace from its answers (wire time of this frame excluded).
            let wire = self.cfg.wire_time((self.bytes_rx - before) as usize);
            let gap = now.duration_since(last).saturating_sub(wire + self.cfg.turnaround);
            if att.got_any {
                self.pace.gap = self.pace.gap.max(gap);
            } else {
                self.pace.first = self.pace.first.max(gap);
                self.pace.learn_reply(now.duration_since(last).saturating_sub(wire));
            }
            waiting.last = now;
            match m {
                Incoming::PixelSpan { frame, y, x0, count, encoding, data } if frame == req.frame => {
                    self.pace.frame = self.pace.frame.max(wire_len(data.len() + 10));
                    // The span's pixels inside the region: what it may complete there.
                    let inside = row_overlap(region, y, x0, count);
                    let before = inside.map_or(0, |r| canvas.missing_in(r));
                    att.new_pixels +=
                        canvas.place(y, x0, count, encoding, &data).map_err(|w| self.protocol(stage, w))?;
                    let after = inside.map_or(0, |r| canvas.missing_in(r));
                    waiting.missing = waiting.missing.saturating_sub(before.saturating_sub(after));
                    // A row of the band whose pixels are all here (each span passed its frame
                    // CRC): reported now, verified when its region's CRC is checked.
                    if let Some(a) = y.checked_sub(band.y0).and_then(|i| arrived.get_mut(i as usize)) {
                        let row = Region { x0: band.x0, y0: y, cols: band.cols, rows: 1 };
                        if !*a && canvas.complete(row) {
                            *a = true;
                            let w = canvas.width as usize;
                            let (s, e) = (3 * (y as usize * w + band.x0 as usize), 3 * band.cols as usize);
                            let rgb = canvas.rgb.get(s..s + e).map(<[u8]>::to_vec).unwrap_or_default();
                            progress(ProgressEvent::RowArrived { y, x0: band.x0, rgb });
                        }
                    }
                    if encoding.is_colour() {
                        self.link.spans_received += 1;
                        self.link.span_data_bytes += data.len() as u64;
                        if resend {
                            self.link.spans_resent += 1;
                        }
                        sizer.record(data.len(), count);
                    }
                    att.got_any = true;
                    waiting.nak = None;
                }
                Incoming::Stats { frame, entries } if frame == req.frame => {
                    if report.stats.is_empty() {
                        for (k, v) in entries {
                            merge_stat(&mut report.stats, k, v);
                        }
                    }
                    att.got_any = true;
                    waiting.nak = None;
                }
                Incoming::RegionEnd { frame, region: r, spans, crc } if frame == req.frame => {
                    if r.fits(canvas.width, canvas.height) {
                        claims.push((r, crc));
                    }
                    report.spans_reported += spans;
                    att.got_any = true;
                    waiting.nak = None;
                    if r == region {
                        return Ok(Wait::Ended);
                    }
                }
                Incoming::Version(_) if self.last_rx_seq == Some(0) => return Ok(Wait::Reset),
                Incoming::Error { code: ErrorCode::NoScene, .. } => return Ok(Wait::Reset),
                Incoming::Error { code: ErrorCode::BadFrame, .. } => {
                    self.link.device_bad_frames += 1;
                    if !att.got_any {
                        waiting.nak = Some(now);
                    }
                }
                // Late answers to scene chunks retransmitted during the upload.
                Incoming::Error { code: ErrorCode::BadOffset, .. } => {}
                Incoming::Error { code: ErrorCode::UnexpectedMessage, detail, .. }
                    if detail != MsgType::RenderRegion as u32 => {}
                Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                _ => {} // stale traffic of other frames, late Versions, Sacks
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

    /// Whether [`Self::send_ahead`] works on this device: it renders `RenderRegion` and its
    /// receiver holds requests that arrive while it renders (`REQUEST_QUEUE`, SPEC.md
    /// §3.12.3).
    pub fn can_send_ahead(&self) -> bool {
        let f = self.device.map_or(0, |d| d.features);
        self.cfg.regions
            && f & gridrt_shared::msg::feature::RENDER_REGION != 0
            && f & gridrt_shared::msg::feature::REQUEST_QUEUE != 0
    }

    /// Sends the first request of frame `req` now, before the frame is rendered with
    /// [`Self::render`], so the device starts on it as soon as it finishes what it renders
    /// now (a stream: frame n+1 rendered while frame n is on the line). Does nothing and
    /// returns `false` unless [`Self::can_send_ahead`]. A request sent ahead is answered and
    /// checked like any other; `render` does not send it again.
    pub fn send_ahead(&mut self, req: &RenderRequest) -> Result<bool, SessionError> {
        if !self.can_send_ahead() || req.width == 0 || req.height == 0 {
            return Ok(false);
        }
        let stage = Stage::Render;
        let rows = if self.cfg.band_rows == 0 { req.height } else { self.cfg.band_rows.min(req.height) };
        let band = Region { x0: 0, y0: 0, cols: req.width, rows };
        let max_span = self
            .sizer
            .as_ref()
            .map_or_else(|| SpanSizer::new(req.encoding), Clone::clone)
            .max_span(self.est_down.byte_error_rate());
        let options = if max_span != 0 { region_options::SPAN_BYTES } else { 0 };
        self.write_bytes(stage, &[0])?;
        self.send(stage, &Msg::RenderRegion { region: band, max_span, options, request: *req })?;
        self.ahead.push_back((req.frame, band));
        Ok(true)
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

/// The part of row `y`, columns `x0..x0 + count`, that lies in `r`, as a one-row region.
fn row_overlap(r: Region, y: u16, x0: u16, count: u16) -> Option<Region> {
    if y < r.y0 || y - r.y0 >= r.rows {
        return None;
    }
    let a = x0.max(r.x0);
    let b = (x0 as u32 + count as u32).min(r.x0 as u32 + r.cols as u32);
    (u32::from(a) < b).then(|| Region { x0: a, y0: y, cols: (b - u32::from(a)) as u16, rows: 1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_merge_while_resending_costs_less_than_a_request() {
        let mut c = Canvas::new(100, 10, false);
        // Everything arrived but two runs on row 3 (10..20, 24..30) and one on row 8 (50..60).
        for y in 0..10u16 {
            c.place(y, 0, 100, gridrt_shared::msg::PixelEncoding::Rgb888, &[7; 300]).unwrap();
        }
        c.mark(Region { x0: 10, y0: 3, cols: 10, rows: 1 }, |_| 0);
        c.mark(Region { x0: 24, y0: 3, cols: 6, rows: 1 }, |_| 0);
        c.mark(Region { x0: 50, y0: 8, cols: 10, rows: 1 }, |_| 0);
        let runs = c.missing_runs(Region::full(100, 10));
        assert_eq!(runs, [(3, 10, 20), (3, 24, 30), (8, 50, 60)]);
        // Cheap pixels, dear requests: the two runs of row 3 go together (4 pixels resent),
        // row 8 is too far (5 rows × 50 columns).
        assert_eq!(group_runs(&runs, 3.0, 150.0, &c), Region { x0: 10, y0: 3, cols: 20, rows: 1 });
        // Dear pixels: each run on its own.
        assert_eq!(group_runs(&runs, 3.0, 10.0, &c), Region { x0: 10, y0: 3, cols: 10, rows: 1 });
        // Free pixels: one rectangle.
        assert_eq!(group_runs(&runs, 0.0, 10.0, &c), Region { x0: 10, y0: 3, cols: 50, rows: 6 });
    }

    #[test]
    fn a_span_overlaps_a_region_only_within_its_rows_and_columns() {
        let r = Region { x0: 10, y0: 5, cols: 20, rows: 3 };
        assert_eq!(row_overlap(r, 6, 0, 15), Some(Region { x0: 10, y0: 6, cols: 5, rows: 1 }));
        assert_eq!(row_overlap(r, 7, 25, 100), Some(Region { x0: 25, y0: 7, cols: 5, rows: 1 }));
        assert_eq!(row_overlap(r, 5, 12, 3), Some(Region { x0: 12, y0: 5, cols: 3, rows: 1 }));
        assert_eq!(row_overlap(r, 4, 10, 20), None);
        assert_eq!(row_overlap(r, 8, 10, 20), None);
        assert_eq!(row_overlap(r, 6, 0, 10), None);
        assert_eq!(row_overlap(r, 6, 30, 10), None);
        assert_eq!(row_overlap(r, 6, u16::MAX, u16::MAX), None);
    }
}
