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
use std::time::Instant;

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{region_options, render_flags, ErrorCode, Msg, MsgType, PixelEncoding, Region, RenderRequest};
use gridrt_shared::pixel;
use serde::Serialize;

use super::{Incoming, ProgressEvent, Session, SessionError, Stage};

/// Pixel has its colour.
const HAVE_RGB: u8 = 1;
/// Pixel has its primitive id.
const HAVE_ID: u8 = 2;
/// Pixel is covered by a `RegionEnd` whose CRC matched.
const VERIFIED: u8 = 4;

/// Retransmission and error counters of the link (one session, cumulative).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct LinkStats {
    /// `RenderRegion` requests sent.
    pub regions_requested: u64,
    /// Of those, requests for pixels asked for before (selective repeat).
    pub regions_resent: u64,
    /// Pixels covered by the re-requests.
    pub pixels_resent: u64,
    /// Colour spans received.
    pub spans_received: u64,
    /// Colour spans received in answer to re-requests (frames resent by the device).
    pub spans_resent: u64,
    /// Wire bytes of re-requests and of everything received while one was outstanding.
    pub bytes_resent: u64,
    /// Frames the host dropped because their CRC-32 failed.
    pub crc_errors: u64,
    /// Frames the host dropped for any reason (bad COBS, length, CRC, overflow): each is a
    /// resynchronisation at the next delimiter.
    pub resyncs: u64,
    /// Device frames missing by sequence number (lost whole, or dropped as corrupt).
    pub seq_gaps: u64,
    /// `Error{BadFrame}` reports from the device (host → device corruption).
    pub device_bad_frames: u64,
    /// Waits that ended without the expected answer.
    pub timeouts: u64,
    /// `RegionEnd` CRCs that did not match the assembled pixels.
    pub region_crc_mismatches: u64,
    /// Device resets detected.
    pub device_resets: u64,
    /// Scene uploads repeated after a reset.
    pub scene_reuploads: u64,
    /// Scene chunks sent again (go-back-N rewinds).
    pub upload_chunks_resent: u64,
    /// Smallest `max_span` the adaptive span size chose (0 = never reduced).
    pub min_max_span: u16,
}

impl LinkStats {
    /// Counter-wise difference `self − earlier` (for one operation of a session).
    pub fn since(&self, e: &LinkStats) -> LinkStats {
        LinkStats {
            regions_requested: self.regions_requested - e.regions_requested,
            regions_resent: self.regions_resent - e.regions_resent,
            pixels_resent: self.pixels_resent - e.pixels_resent,
            spans_received: self.spans_received - e.spans_received,
            spans_resent: self.spans_resent - e.spans_resent,
            bytes_resent: self.bytes_resent - e.bytes_resent,
            crc_errors: self.crc_errors - e.crc_errors,
            resyncs: self.resyncs - e.resyncs,
            seq_gaps: self.seq_gaps - e.seq_gaps,
            device_bad_frames: self.device_bad_frames - e.device_bad_frames,
            timeouts: self.timeouts - e.timeouts,
            region_crc_mismatches: self.region_crc_mismatches - e.region_crc_mismatches,
            device_resets: self.device_resets - e.device_resets,
            scene_reuploads: self.scene_reuploads - e.scene_reuploads,
            upload_chunks_resent: self.upload_chunks_resent - e.upload_chunks_resent,
            min_max_span: self.min_max_span,
        }
    }

    /// Adds another session's counters (several devices).
    pub fn add(&mut self, o: &LinkStats) {
        self.regions_requested += o.regions_requested;
        self.regions_resent += o.regions_resent;
        self.pixels_resent += o.pixels_resent;
        self.spans_received += o.spans_received;
        self.spans_resent += o.spans_resent;
        self.bytes_resent += o.bytes_resent;
        self.crc_errors += o.crc_errors;
        self.resyncs += o.resyncs;
        self.seq_gaps += o.seq_gaps;
        self.device_bad_frames += o.device_bad_frames;
        self.timeouts += o.timeouts;
        self.region_crc_mismatches += o.region_crc_mismatches;
        self.device_resets += o.device_resets;
        self.scene_reuploads += o.scene_reuploads;
        self.upload_chunks_resent += o.upload_chunks_resent;
        self.min_max_span = match (self.min_max_span, o.min_max_span) {
            (0, b) => b,
            (a, 0) => a,
            (a, b) => a.min(b),
        };
    }
}

/// A frame being assembled: pixels plus, per pixel, what has arrived and what is verified.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// RGB8 row-major.
    pub rgb: Vec<u8>,
    /// Primitive ids, when requested.
    pub prim_ids: Option<Vec<u32>>,
    state: Vec<u8>,
}

impl Canvas {
    /// An empty `width`×`height` canvas; `prim_ids` also collects primitive ids.
    pub fn new(width: u16, height: u16, prim_ids: bool) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, rgb: vec![0; 3 * n], prim_ids: prim_ids.then(|| vec![u32::MAX; n]), state: vec![0; n] }
    }

    fn need(&self) -> u8 {
        if self.prim_ids.is_some() {
            HAVE_RGB | HAVE_ID
        } else {
            HAVE_RGB
        }
    }

    fn rows(&self, r: Region) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let w = self.width as usize;
        (r.y0 as usize..r.y0 as usize + r.rows as usize)
            .map(move |y| y * w + r.x0 as usize..y * w + (r.x0 + r.cols) as usize)
    }

    /// True when every pixel of `r` has arrived (colour, and id when collected).
    pub fn complete(&self, r: Region) -> bool {
        let need = self.need();
        self.rows(r).all(|row| self.state[row].iter().all(|&s| s & need == need))
    }

    /// True when every pixel of `r` is verified.
    pub fn verified(&self, r: Region) -> bool {
        self.rows(r).all(|row| self.state[row].iter().all(|&s| s & VERIFIED != 0))
    }

    /// CRC-32 of the RGB888 pixels of `r`, row-major.
    pub fn crc(&self, r: Region) -> u32 {
        let mut d = gridrt_shared::frame::Crc32Digest::default();
        for row in self.rows(r) {
            d.update(&self.rgb[3 * row.start..3 * row.end]);
        }
        d.finalize()
    }

    fn mark(&mut self, r: Region, f: impl Fn(u8) -> u8) {
        let w = self.width as usize;
        for y in r.y0 as usize..r.y0 as usize + r.rows as usize {
            for s in &mut self.state[y * w + r.x0 as usize..y * w + (r.x0 + r.cols) as usize] {
                *s = f(*s);
            }
        }
    }

    /// Copies region `r` (pixels, ids, state) from `other`, a canvas of the same size.
    pub fn copy_region_from(&mut self, other: &Canvas, r: Region) {
        let rows: Vec<_> = self.rows(r).collect();
        for row in rows {
            self.rgb[3 * row.start..3 * row.end].copy_from_slice(&other.rgb[3 * row.start..3 * row.end]);
            if let (Some(dst), Some(src)) = (self.prim_ids.as_mut(), other.prim_ids.as_ref()) {
                dst[row.clone()].copy_from_slice(&src[row.clone()]);
            }
            self.state[row.clone()].copy_from_slice(&other.state[row]);
        }
    }

    /// Places a decoded span; returns how many of its pixels are new.
    fn place(&mut self, y: u16, x0: u16, count: u16, encoding: PixelEncoding, data: &[u8]) -> Result<usize, String> {
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, x0, n) = (y as usize, x0 as usize, count as usize);
        if y >= h || x0 + n > w {
            return Err(format!("span y {y} x {x0}+{n} outside the {w}×{h} image"));
        }
        let base = y * w + x0;
        let flag = match encoding {
            PixelEncoding::PrimId32 => {
                let Some(ids) = self.prim_ids.as_mut() else { return Ok(0) };
                for (k, c) in data.chunks_exact(4).enumerate() {
                    ids[base + k] = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                }
                HAVE_ID
            }
            enc => {
                let dst = &mut self.rgb[3 * base..3 * (base + n)];
                decode_colour(enc, n, data, dst)?;
                HAVE_RGB
            }
        };
        let mut newly = 0;
        for s in &mut self.state[base..base + n] {
            if *s & flag == 0 {
                newly += 1;
            }
            *s |= flag;
        }
        Ok(newly)
    }

    /// The first group of rows of `band` with unverified pixels, as one region (the union of
    /// their column ranges); `None` when the band is verified.
    fn next_gap(&self, band: Region) -> Option<Region> {
        let w = self.width as usize;
        let mut group: Option<(u16, u16, usize, usize)> = None; // (y0, rows, xmin, xmax)
        for y in band.y0..band.y0 + band.rows {
            let row = &self.state[y as usize * w + band.x0 as usize..y as usize * w + (band.x0 + band.cols) as usize];
            let first = row.iter().position(|&s| s & VERIFIED == 0);
            match (first, group.as_mut()) {
                (Some(a), None) => {
                    let b = row.iter().rposition(|&s| s & VERIFIED == 0).unwrap_or(a);
                    group = Some((y, 1, a, b));
                }
                (Some(a), Some(g)) => {
                    let b = row.iter().rposition(|&s| s & VERIFIED == 0).unwrap_or(a);
                    g.1 += 1;
                    g.2 = g.2.min(a);
                    g.3 = g.3.max(b);
                }
                (None, Some(_)) => break,
                (None, None) => {}
            }
        }
        group.map(|(y0, rows, a, b)| Region { x0: band.x0 + a as u16, y0, cols: (b - a + 1) as u16, rows })
    }

    /// Rows of `band` that are fully verified.
    fn verified_rows(&self, band: Region) -> Vec<u16> {
        (band.y0..band.y0 + band.rows)
            .filter(|&y| self.verified(Region { x0: band.x0, y0: y, cols: band.cols, rows: 1 }))
            .collect()
    }
}

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

/// Adds one device counter of a region to the counters of a frame: counts add up; the
/// `PLAN` bit set is OR-ed (every region of a frame follows the same plan).
pub fn merge_stat(into: &mut BTreeMap<u8, u64>, key: u8, value: u64) {
    let slot = into.entry(key).or_insert(0);
    if key == gridrt_shared::msg::stat::PLAN {
        *slot |= value;
    } else {
        *slot += value;
    }
}

/// Decodes `count` colour pixels into RGB888.
pub fn decode_colour(enc: PixelEncoding, count: usize, data: &[u8], dst: &mut [u8]) -> Result<(), String> {
    match enc {
        PixelEncoding::Rgb888 => dst.copy_from_slice(data),
        PixelEncoding::Rgb565 => {
            for (d, c) in dst.chunks_exact_mut(3).zip(data.chunks_exact(2)) {
                d.copy_from_slice(&pixel::rgb565_unpack(u16::from_le_bytes([c[0], c[1]])));
            }
        }
        PixelEncoding::Rle => pixel::rle_decode(count, data, dst).map_err(|e| format!("Rle span: {e}"))?,
        other => return Err(format!("unsupported pixel encoding {other:?}")),
    }
    Ok(())
}

/// Chooses `max_span` from the frame error rate seen so far: spans short enough that about
/// one frame in ten is hit at the estimated bit error rate, never shorter than 4 pixels.
#[derive(Debug, Clone)]
pub(super) struct SpanSizer {
    /// Estimated bit error rate on the device → host line.
    ber: f64,
    /// Wire bytes per colour pixel seen (spans only).
    bytes_per_pixel: f64,
    max_span: u16,
}

impl SpanSizer {
    fn new(encoding: PixelEncoding) -> Self {
        let bpp = match encoding.fixed_bytes_per_pixel() {
            Some(n) => n as f64,
            None => 1.0,
        };
        Self { ber: 0.0, bytes_per_pixel: bpp, max_span: 0 }
    }

    /// Updates from one attempt: frames accepted/dropped and wire bytes seen.
    fn update(&mut self, ok: u64, bad: u64, bytes: u64, span_bytes: u64, span_pixels: u64) {
        if span_pixels > 0 {
            self.bytes_per_pixel = (span_bytes as f64 / span_pixels as f64).max(0.05);
        }
        let frames = ok + bad;
        if frames < 3 || bytes == 0 {
            return;
        }
        let p = (bad as f64 / frames as f64).min(0.95);
        let bits = bytes as f64 * 10.0 / frames as f64;
        let ber = -(1.0 - p).ln() / bits;
        self.ber = if bad == 0 { self.ber * 0.5 } else { 0.5 * self.ber + 0.5 * ber };
        // Frame bytes for ~10 % loss; 22 bytes are header, CRC, COBS and delimiter.
        let target = if self.ber > 0.0 { 0.105 / (self.ber * 10.0) } else { f64::INFINITY };
        self.max_span = if target >= 2048.0 {
            0
        } else {
            (((target - 22.0).max(0.0) / self.bytes_per_pixel) as u16).clamp(4, 4096)
        };
    }
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
            let outcome = self.wait_region(req, gap, canvas, &mut claims, &mut report, &mut att, resend)?;
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
    ) -> Result<Wait, SessionError> {
        let stage = Stage::Render;
        let idle = self.cfg.retransmit_after;
        let mut deadline = Instant::now() + idle;
        loop {
            let msg = self.poll(stage, deadline)?;
            let Some(m) = msg else {
                self.link.timeouts += 1;
                return Ok(Wait::GaveUp);
            };
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
    ) -> Result<super::RenderedFrame, SessionError> {
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
        Ok(super::RenderedFrame {
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
