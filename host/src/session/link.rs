//! The line's condition as a session sees it: retransmission and error counters, and the
//! span size chosen from the error rate.

use std::collections::VecDeque;
use std::time::Duration;

use gridrt_shared::msg::PixelEncoding;
use serde::Serialize;

use super::estimate::best_payload;

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
    /// Pixel data bytes of the colour spans received (encoded, as on the wire).
    pub span_data_bytes: u64,
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
    /// Scene (or flash) chunks sent again.
    pub upload_chunks_resent: u64,
    /// Empty data frames sent to learn what the receiver holds (upload, flash).
    pub probes: u64,
    /// Smallest `max_span` (span data bytes) the adaptive span size chose (0 = never reduced).
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
            span_data_bytes: self.span_data_bytes - e.span_data_bytes,
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
            probes: self.probes - e.probes,
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
        self.span_data_bytes += o.span_data_bytes;
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
        self.probes += o.probes;
        self.min_max_span = match (self.min_max_span, o.min_max_span) {
            (0, b) => b,
            (a, 0) => a,
            (a, b) => a.min(b),
        };
    }
}

/// What the device's timing looks like, for the waits of a render (`region` module docs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DevicePace {
    /// Longest gap seen between two messages of an answer (ray work between spans).
    pub(crate) gap: Duration,
    /// Longest time seen from a request to the first message of its answer.
    pub(crate) first: Duration,
    /// Largest frame seen from the device, wire bytes.
    pub(crate) frame: usize,
    /// Time from a request leaving to the first message of its answer (that message's wire
    /// time excluded), smoothed: what another request leaves the line idle for.
    pub(crate) reply: Option<Duration>,
}

impl Default for DevicePace {
    fn default() -> Self {
        Self { gap: Duration::from_millis(50), first: Duration::from_millis(200), frame: 64, reply: None }
    }
}

impl DevicePace {
    /// Takes one request-to-first-answer time into [`Self::reply`] (a quarter of the way).
    pub(crate) fn learn_reply(&mut self, t: Duration) {
        self.reply = Some(self.reply.map_or(t, |r| (r * 3 + t) / 4));
    }
}

/// Wire bytes another request costs: its own and its `RegionEnd`'s bytes plus the line's idle
/// time until its answer starts — the measured reply time, at most `turnaround` (the allowance
/// for a device not heard yet) — at `baud`.
pub(crate) fn request_cost(wire: usize, reply: Option<Duration>, turnaround: Duration, baud: u32) -> f64 {
    let idle = reply.map_or(turnaround, |r| r.min(turnaround));
    wire as f64 + idle.as_secs_f64() * f64::from(baud) / 10.0
}

/// Chooses `max_span` (data bytes per span, `region_options::SPAN_BYTES`) from the device →
/// host byte error rate: spans whose frames have the best selective-repeat efficiency
/// (§3.14's model with the 10-byte span header). A byte limit, not a pixel limit, so spans of
/// run-length coded background stay whole rows. Also keeps the bytes per pixel seen, for the
/// cost of re-requests.
#[derive(Debug, Clone)]
pub(crate) struct SpanSizer {
    /// Bytes per pixel of fixed-size encodings.
    fixed: Option<f64>,
    /// (data bytes, pixels) of recent colour spans.
    spans: VecDeque<(u32, u32)>,
}

/// Bytes of a `PixelSpan` before its pixels.
pub(crate) const SPAN_HEAD: usize = 10;

impl SpanSizer {
    pub(crate) fn new(encoding: PixelEncoding) -> Self {
        Self { fixed: encoding.fixed_bytes_per_pixel().map(|n| n as f64), spans: VecDeque::new() }
    }

    /// Records a received colour span.
    pub(crate) fn record(&mut self, data_bytes: usize, pixels: u16) {
        if pixels >= 4 {
            if self.spans.len() == 256 {
                self.spans.pop_front();
            }
            self.spans.push_back((data_bytes as u32, pixels as u32));
        }
    }

    /// Bytes per pixel that 80 % of the span bytes seen stay under (dense spans decide the
    /// frame size; 1 until spans are seen).
    pub(crate) fn bytes_per_pixel_seen(&self) -> f64 {
        if let Some(b) = self.fixed {
            return b;
        }
        let mut v: Vec<(f64, u32)> = self.spans.iter().map(|&(b, p)| (b as f64 / p as f64, b)).collect();
        let total: u64 = v.iter().map(|x| x.1 as u64).sum();
        if total == 0 {
            return 1.0;
        }
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut acc = 0u64;
        for (bpp, b) in &v {
            acc += *b as u64;
            if acc as f64 >= 0.8 * total as f64 {
                return bpp.max(0.05);
            }
        }
        v.last().map_or(1.0, |x| x.0.max(0.05))
    }

    /// The span data limit in bytes at byte error rate `q` (0 = the device's default, for a
    /// clean line).
    pub(crate) fn max_span(&self, q: f64) -> u16 {
        if q <= 0.0 {
            return 0;
        }
        let bytes = best_payload(SPAN_HEAD, q, 16, gridrt_shared::frame::MAX_PAYLOAD - SPAN_HEAD);
        if bytes >= 1800 {
            return 0; // frames as long as they come: the device's default
        }
        bytes as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::estimate::byte_error_rate;

    #[test]
    fn another_request_costs_the_measured_reply_time_capped_by_the_turnaround() {
        let (turn, baud) = (Duration::from_millis(30), 3_000_000);
        // Not heard yet: the allowance, 30 ms of a 300 000 B/s line.
        assert_eq!(request_cost(60, None, turn, baud), 60.0 + 9000.0);
        // A quick answer: 3 ms of line.
        assert!((request_cost(60, Some(Duration::from_millis(3)), turn, baud) - 960.0).abs() < 1e-6);
        // A slow one costs no more than the allowance (as before the reply was measured).
        assert_eq!(request_cost(60, Some(Duration::from_millis(80)), turn, baud), 9060.0);
        let mut p = DevicePace::default();
        p.learn_reply(Duration::from_millis(8));
        p.learn_reply(Duration::from_millis(4));
        assert_eq!(p.reply, Some(Duration::from_millis(7)));
    }

    #[test]
    fn span_limit_follows_the_error_rate_in_bytes() {
        let mut s = SpanSizer::new(PixelEncoding::Rle);
        assert_eq!(s.max_span(0.0), 0);
        // Background spans of 320 px in 6 bytes, object spans of 100 px in 200 bytes: the dense
        // ones decide the bytes per pixel.
        for _ in 0..50 {
            s.record(6, 320);
            s.record(200, 100);
        }
        assert_eq!(s.bytes_per_pixel_seen(), 2.0);
        let at = |ber: f64| s.max_span(byte_error_rate(ber));
        assert!(at(1e-3) < at(1e-4) && at(1e-4) < at(1e-5), "{} {} {}", at(1e-3), at(1e-4), at(1e-5));
        // 1e-4: the best span frame is a correctable one (SPEC.md §2.5), ≤ 375 raw bytes.
        let limit = gridrt_shared::frame::CORRECTABLE_RAW - 20;
        assert!((250..=limit).contains(&(at(1e-4) as usize)), "{}", at(1e-4));
        let rgb = SpanSizer::new(PixelEncoding::Rgb888);
        assert_eq!(rgb.max_span(byte_error_rate(1e-4)), at(1e-4), "bytes, whatever the encoding");
        assert_eq!(rgb.max_span(byte_error_rate(1e-7)), 0, "the optimum exceeds a frame: default");
    }
}
