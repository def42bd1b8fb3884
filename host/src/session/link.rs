//! The line's condition as a session sees it: retransmission and error counters, and the
//! span size chosen from the error rate.

use gridrt_shared::msg::PixelEncoding;
use serde::Serialize;

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

/// Chooses `max_span` from the frame error rate seen so far: spans short enough that about
/// one frame in ten is hit at the estimated bit error rate, never shorter than 4 pixels.
#[derive(Debug, Clone)]
pub(super) struct SpanSizer {
    /// Estimated bit error rate on the device → host line.
    ber: f64,
    /// Wire bytes per colour pixel seen (spans only).
    bytes_per_pixel: f64,
    pub(super) max_span: u16,
}

impl SpanSizer {
    pub(super) fn new(encoding: PixelEncoding) -> Self {
        let bpp = match encoding.fixed_bytes_per_pixel() {
            Some(n) => n as f64,
            None => 1.0,
        };
        Self { ber: 0.0, bytes_per_pixel: bpp, max_span: 0 }
    }

    /// Updates from one attempt: frames accepted/dropped and wire bytes seen.
    pub(super) fn update(&mut self, ok: u64, bad: u64, bytes: u64, span_bytes: u64, span_pixels: u64) {
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
