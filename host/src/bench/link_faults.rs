//! `gridrt bench link --faults`: goodput of the scene upload and of the frame against the
//! bit error rate, measured over a paced [`PtyRelay`](crate::faults::relay::PtyRelay), next to the
//! selective-repeat bound (SPEC.md §3.14) for the chunk and span sizes in use.
//!
//! # What is measured
//! For each bit error rate `b` (0 first: the reference), one whole session — hello, upload,
//! frame — over the relay at `baud` with [`Faults::line`]`(b)` in both directions, to the
//! simulated board. Goodput is payload bytes per second of wall time (the relay paces every
//! byte, so wall time is wire time), as a share of the line rate `baud / 10`:
//! - upload: the scene image's bytes over the upload time;
//! - frame: the pixel data bytes the frame needs (its spans' encoded bytes in the clean run)
//!   over the frame time.
//!
//! Upload goodput counts the scene image's decoded bytes, so the compact upload (SPEC.md
//! §5.12) puts it above 1. How busy the line was is the line utilisation, per phase in the
//! direction that carries it: bytes the relay paced onto the line (framing, resends and
//! everything else included) over `baud / 10 ×` the phase's wall time — host → device during
//! the upload, device → host during the frame.
//!
//! # The bound
//! [`efficiency`] of selective repeat at the byte error rate `q = 1 − (1 − b)^8` plus the
//! drop rate, for data frames (4-byte header, the upload) and span frames (10-byte header,
//! the frame): at the best payload (the upper bound of any chunk size) and at the payload
//! the run actually used (the last chunk size; the mean span). Acknowledgements, requests,
//! `RegionEnd`s and the turnaround are not in it: measured goodput stays below it.

use serde::Serialize;

use crate::faults::run::LineRun;
use crate::faults::Faults;
use crate::session::estimate::{best_payload, byte_error_rate, efficiency};
use crate::session::MAX_CHUNK;

/// Header bytes of a data message (`offset`).
const DATA_HEAD: usize = 4;
/// Header bytes of a `PixelSpan`.
const SPAN_HEAD: usize = 10;

/// One bit error rate's results.
#[derive(Debug, Clone, Serialize)]
pub struct FaultRow {
    /// Bit error rate (flips of data bits), both directions.
    pub ber: f64,
    /// Byte drop rate, both directions.
    pub drop: f64,
    /// Garbage burst rate per byte, both directions.
    pub burst: f64,
    /// Seconds to `Version`.
    pub hello_s: f64,
    /// Seconds of the upload.
    pub upload_s: f64,
    /// Seconds of the frame.
    pub frame_s: f64,
    /// Seconds from hello to the frame.
    pub total_s: f64,
    /// `total_s` over the clean run's.
    pub total_ratio: f64,
    /// `upload_s` over the clean run's.
    pub upload_ratio: f64,
    /// `frame_s` over the clean run's.
    pub frame_ratio: f64,
    /// Scene image bytes (decoded, not wire bytes) per second of upload over the line rate.
    pub upload_goodput: f64,
    /// The clean frame's span data bytes per second of frame over the line rate.
    pub frame_goodput: f64,
    /// Host → device bytes on the line during the upload over the line rate × upload time.
    pub upload_line_utilisation: f64,
    /// Device → host bytes on the line during the frame over the line rate × frame time.
    pub frame_line_utilisation: f64,
    /// Bytes the relay paced during the upload: [host → device, device → host].
    pub upload_line_bytes: [u64; 2],
    /// Bytes the relay paced during the frame: [host → device, device → host].
    pub frame_line_bytes: [u64; 2],
    /// Bytes the host's session counted during the upload: [sent, received].
    pub upload_session_bytes: [u64; 2],
    /// Bytes the host's session counted during the frame: [sent, received].
    pub frame_session_bytes: [u64; 2],
    /// Selective-repeat bound of the upload at the best chunk size.
    pub upload_bound: f64,
    /// Bound at the chunk size the run ended with.
    pub upload_bound_in_use: f64,
    /// The chunk size the run ended with (bytes).
    pub upload_chunk: usize,
    /// Bound of the frame at the best span payload.
    pub frame_bound: f64,
    /// Bound at the mean span payload of the run.
    pub frame_bound_in_use: f64,
    /// Mean span payload of the run (bytes).
    pub frame_span_bytes: f64,
    /// The image equals the clean run's, byte for byte.
    pub identical: bool,
    /// Chunks sent again.
    pub chunks_resent: u64,
    /// Pixel runs requested again.
    pub runs_rerequested: u64,
    /// The session's link counters (spans, re-requests, probes, smallest span limit).
    pub link: crate::session::LinkStats,
    /// Bits flipped, bytes dropped and bursts inserted, both directions together.
    pub flips: u64,
    /// Bytes dropped.
    pub drops: u64,
    /// Bursts inserted.
    pub bursts: u64,
}

/// Byte error rate of a line with faults `f`: flips of the 8 data bits, plus drops.
pub fn line_byte_error_rate(f: &Faults) -> f64 {
    1.0 - (1.0 - byte_error_rate(f.ber)) * (1.0 - f.drop.clamp(0.0, 1.0))
}

/// Share of a line at `baud` (8N1) that `bytes` kept busy for `secs`.
pub fn line_utilisation(bytes: u64, baud: u32, secs: f64) -> f64 {
    bytes as f64 * 10.0 / (f64::from(baud.max(1)) * secs.max(1e-9))
}

/// The row of `run` at faults `f`, against the clean run `clean`, for a scene image of
/// `image_bytes` bytes at `baud`; `upload_chunk` is the chunk size the upload ended with.
pub fn fault_row(
    f: &Faults,
    run: &LineRun,
    clean: &LineRun,
    image_bytes: usize,
    baud: u32,
    upload_chunk: usize,
) -> FaultRow {
    let line = baud as f64 / 10.0;
    let q = line_byte_error_rate(f);
    let frame_payload = clean.link.span_data_bytes as f64;
    let spans = run.link.spans_received.max(1) as f64;
    let span_bytes = run.link.span_data_bytes as f64 / spans;
    let n_up = best_payload(DATA_HEAD, q, 1, MAX_CHUNK);
    let n_span = best_payload(SPAN_HEAD, q, 1, 2038);
    let (up, down) = (run.up, run.down);
    FaultRow {
        ber: f.ber,
        drop: f.drop,
        burst: f.burst,
        hello_s: run.hello_s,
        upload_s: run.upload_s,
        frame_s: run.frame_s,
        total_s: run.total_s,
        total_ratio: run.total_s / clean.total_s,
        upload_ratio: run.upload_s / clean.upload_s,
        frame_ratio: run.frame_s / clean.frame_s,
        upload_goodput: image_bytes as f64 / run.upload_s / line,
        frame_goodput: frame_payload / run.frame_s / line,
        upload_line_utilisation: line_utilisation(run.upload_line.0, baud, run.upload_s),
        frame_line_utilisation: line_utilisation(run.frame_line.1, baud, run.frame_s),
        upload_line_bytes: [run.upload_line.0, run.upload_line.1],
        frame_line_bytes: [run.frame_line.0, run.frame_line.1],
        upload_session_bytes: [run.upload_wire.0, run.upload_wire.1],
        frame_session_bytes: [run.frame_wire.0, run.frame_wire.1],
        upload_bound: efficiency(n_up, DATA_HEAD, q),
        upload_bound_in_use: efficiency(upload_chunk.max(1), DATA_HEAD, q),
        upload_chunk,
        frame_bound: efficiency(n_span, SPAN_HEAD, q),
        frame_bound_in_use: efficiency(span_bytes.round().max(1.0) as usize, SPAN_HEAD, q),
        frame_span_bytes: span_bytes,
        identical: run.frame.rgb == clean.frame.rgb,
        chunks_resent: run.link.upload_chunks_resent,
        runs_rerequested: run.link.regions_resent,
        link: run.link.clone(),
        flips: up.flips + down.flips,
        drops: up.drops + down.drops,
        bursts: up.bursts + down.bursts,
    }
}

/// CSV of the rows (header first).
pub fn csv(rows: &[FaultRow]) -> String {
    let mut s = String::from(
        "ber,drop,burst,hello_s,upload_s,frame_s,total_s,total_ratio,upload_ratio,frame_ratio,upload_goodput,upload_bound,upload_bound_in_use,upload_chunk,frame_goodput,frame_bound,frame_bound_in_use,frame_span_bytes,upload_line_utilisation,frame_line_utilisation,upload_line_bytes_up,upload_line_bytes_down,frame_line_bytes_up,frame_line_bytes_down,identical,chunks_resent,runs_rerequested,flips,drops,bursts\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{:e},{:e},{:e},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{},{:.4},{:.4},{:.4},{:.1},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{}\n",
            r.ber,
            r.drop,
            r.burst,
            r.hello_s,
            r.upload_s,
            r.frame_s,
            r.total_s,
            r.total_ratio,
            r.upload_ratio,
            r.frame_ratio,
            r.upload_goodput,
            r.upload_bound,
            r.upload_bound_in_use,
            r.upload_chunk,
            r.frame_goodput,
            r.frame_bound,
            r.frame_bound_in_use,
            r.frame_span_bytes,
            r.upload_line_utilisation,
            r.frame_line_utilisation,
            r.upload_line_bytes[0],
            r.upload_line_bytes[1],
            r.frame_line_bytes[0],
            r.frame_line_bytes[1],
            r.identical,
            r.chunks_resent,
            r.runs_rerequested,
            r.flips,
            r.drops,
            r.bursts
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_error_rate_adds_drops_to_flips() {
        let q = line_byte_error_rate(&Faults::line(1e-4));
        assert!((q - (8e-4 + 1e-5)).abs() < 2e-6, "{q}");
        assert_eq!(line_byte_error_rate(&Faults::default()), 0.0);
    }

    #[test]
    fn line_utilisation_is_ten_bits_a_byte_over_the_baud_rate() {
        // 300 000 B in 1 s at 3 Mbaud fill the line; half as many, half of it.
        assert!((line_utilisation(300_000, 3_000_000, 1.0) - 1.0).abs() < 1e-12);
        assert!((line_utilisation(150_000, 3_000_000, 1.0) - 0.5).abs() < 1e-12);
        assert!((line_utilisation(11_520, 115_200, 2.0) - 0.5).abs() < 1e-12);
    }
}
