//! One frame on several boards: a work queue of row bands, dynamic load balancing, merged
//! result.
//!
//! Seed 001 (Maršík 2008, point splatting on DSP+FPGA pairs) splits the work across units
//! and merges their outputs; it distributes points at random because the camera moves. A
//! ray tracer's cost per row is just as unpredictable (empty background rows are almost
//! free, rows through the model are not), so instead of a static split every board takes
//! the next band of rows from a shared queue as soon as it has verified its previous one:
//! fast boards, or boards that drew cheap bands, simply take more. Each band is rendered
//! with [`Session::render_band`] (selective repeat, reset recovery), so a flaky board
//! costs retransmissions, not correctness. A board whose session fails puts its band back
//! in the queue and drops out; the frame fails only when no board is left.
//!
//! Every session must be connected (`hello`) and hold the scene (`upload_scene`) before
//! [`render_multi`] is called.

use std::collections::{BTreeMap, VecDeque};
use std::io::{Read, Write};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{render_flags, Region, RenderRequest};
use serde::Serialize;

use crate::session::{merge_stat, Canvas, LinkStats, ProgressEvent, RenderedFrame, Session, SessionError};

/// What one board did for a frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DeviceShare {
    /// Port name.
    pub port: String,
    /// Bands it verified.
    pub bands: u32,
    /// Rows it verified.
    pub rows: u32,
    /// Wire bytes host → device during the render.
    pub bytes_tx: u64,
    /// Wire bytes device → host during the render.
    pub bytes_rx: u64,
    /// Co-processor cycles it reported (re-renders included).
    pub coproc_cycles: u64,
    /// Retransmissions.
    pub link: LinkStats,
    /// Wall time until it ran out of work.
    pub busy_ms: f64,
    /// Why it dropped out, if it did.
    pub error: Option<String>,
}

impl DeviceShare {
    /// Modelled link time at `baud` (8N1, 10 bit times per byte): the bytes of both
    /// directions back to back (requests and answers alternate, stop-and-wait).
    pub fn link_seconds(&self, baud: u32) -> f64 {
        (self.bytes_tx + self.bytes_rx) as f64 * 10.0 / baud as f64
    }
}

/// A frame rendered on several boards.
#[derive(Debug, Clone)]
pub struct MultiFrame {
    /// The merged frame (stats and link counters summed over the boards).
    pub frame: RenderedFrame,
    /// Per board, in the order the sessions were given.
    pub devices: Vec<DeviceShare>,
    /// Rows per band.
    pub band_rows: u16,
}

impl MultiFrame {
    /// Modelled frame time at `baud`: the busiest board's link time (the boards' links run
    /// in parallel).
    pub fn link_seconds(&self, baud: u32) -> f64 {
        self.devices.iter().map(|d| d.link_seconds(baud)).fold(0.0, f64::max)
    }
}

/// Default band height for `devices` boards: about eight bands per board (balance) but no
/// band under one row or over 16 rows (per-band overhead, reset cost).
pub fn default_band_rows(height: u16, devices: usize) -> u16 {
    let bands = 8 * devices.max(1) as u32;
    (height as u32).div_ceil(bands).clamp(1, 16) as u16
}

/// What a worker thread hands back: its session, its share, its counters, the spans its
/// `RegionEnd`s reported, and the error that made it drop out.
type WorkerResult<T> = (Session<T>, DeviceShare, BTreeMap<u8, u64>, u32, Option<SessionError>);

struct Queue {
    bands: VecDeque<Region>,
    in_flight: usize,
}

/// Renders `req` on every session in `sessions` (see the module docs); `band_rows` = 0
/// picks [`default_band_rows`]. `progress(i, event)` reports board `i`'s events
/// (`RowVerified` per verified row, `Resend`, `DeviceReset`). Returns the sessions too.
pub fn render_multi<T: Read + Write + Send>(
    sessions: Vec<Session<T>>,
    req: &RenderRequest,
    band_rows: u16,
    progress: &(dyn Fn(usize, ProgressEvent) + Sync),
) -> Result<(MultiFrame, Vec<Session<T>>), SessionError> {
    let start = Instant::now();
    let (w, h) = (req.width, req.height);
    let band_rows = if band_rows == 0 { default_band_rows(h, sessions.len()) } else { band_rows.min(h).max(1) };
    let bands: VecDeque<Region> = (0..h)
        .step_by(band_rows as usize)
        .map(|y0| Region { x0: 0, y0, cols: w, rows: band_rows.min(h - y0) })
        .collect();
    let total_bands = bands.len();
    let queue = Mutex::new(Queue { bands, in_flight: 0 });
    let wake = Condvar::new();
    let want_ids = req.flags & render_flags::PRIM_IDS != 0;
    let merged = Mutex::new((Canvas::new(w, h, want_ids), 0usize));
    let n = sessions.len();

    let results: Vec<WorkerResult<T>> = std::thread::scope(|sc| {
        let handles: Vec<_> = sessions
            .into_iter()
            .enumerate()
            .map(|(i, mut s)| {
                let (queue, wake, merged) = (&queue, &wake, &merged);
                sc.spawn(move || {
                    let mut canvas = Canvas::new(w, h, want_ids);
                    let mut share = DeviceShare { port: s.config().port_name.clone(), ..Default::default() };
                    let mut stats = BTreeMap::new();
                    let mut spans = 0u32;
                    let (tx0, rx0, link0) = (s.bytes_tx(), s.bytes_rx(), s.link_stats().clone());
                    let mut failure = None;
                    loop {
                        // Next band; wait while others still hold bands they might give back.
                        let band = {
                            let mut q = queue.lock().unwrap_or_else(|e| e.into_inner());
                            loop {
                                if let Some(b) = q.bands.pop_front() {
                                    q.in_flight += 1;
                                    break Some(b);
                                }
                                if q.in_flight == 0 {
                                    break None;
                                }
                                q = wake
                                    .wait_timeout(q, Duration::from_millis(50))
                                    .map(|r| r.0)
                                    .unwrap_or_else(|e| e.into_inner().0);
                            }
                        };
                        let Some(band) = band else { break };
                        let r = s.render_band(req, band, &mut canvas, &mut |e| progress(i, e));
                        let mut q = queue.lock().unwrap_or_else(|e| e.into_inner());
                        q.in_flight -= 1;
                        match r {
                            Ok(rep) => {
                                drop(q);
                                for (k, v) in rep.stats {
                                    merge_stat(&mut stats, k, v);
                                }
                                spans += rep.spans_reported;
                                share.bands += 1;
                                share.rows += band.rows as u32;
                                let mut m = merged.lock().unwrap_or_else(|e| e.into_inner());
                                m.0.copy_region_from(&canvas, band);
                                m.1 += 1;
                                wake.notify_all();
                            }
                            Err(e) => {
                                // Give the band back; the others finish the frame.
                                q.bands.push_front(band);
                                wake.notify_all();
                                share.error = Some(e.to_string());
                                failure = Some(e);
                                break;
                            }
                        }
                    }
                    share.bytes_tx = s.bytes_tx() - tx0;
                    share.bytes_rx = s.bytes_rx() - rx0;
                    share.link = s.link_stats().since(&link0);
                    share.coproc_cycles = stats.get(&gridrt_shared::msg::stat::COPROC_CYCLES).copied().unwrap_or(0);
                    share.busy_ms = start.elapsed().as_secs_f64() * 1e3;
                    (s, share, stats, spans, failure)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    });

    let (canvas, done) = merged.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut sessions = Vec::with_capacity(n);
    let mut devices = Vec::with_capacity(n);
    let mut stats = BTreeMap::new();
    let mut link = LinkStats::default();
    let (mut spans_reported, mut bytes_tx, mut bytes_rx) = (0u32, 0u64, 0u64);
    let mut first_error = None;
    for (s, share, st, spans, err) in results {
        for (k, v) in st {
            merge_stat(&mut stats, k, v);
        }
        link.add(&share.link);
        spans_reported += spans;
        bytes_tx += share.bytes_tx;
        bytes_rx += share.bytes_rx;
        if first_error.is_none() {
            first_error = err;
        }
        devices.push(share);
        sessions.push(s);
    }
    if done < total_bands {
        return Err(first_error.unwrap_or_else(|| SessionError::BadInput {
            port: "all".into(),
            stage: crate::session::Stage::Render,
            what: format!("{} of {total_bands} bands were not rendered", total_bands - done),
        }));
    }
    let frame = RenderedFrame {
        frame: req.frame,
        width: w,
        height: h,
        image_crc: crc32(&canvas.rgb),
        rgb: canvas.rgb,
        prim_ids: canvas.prim_ids,
        stats,
        spans_reported,
        spans_received: link.spans_received as u32 * if want_ids { 2 } else { 1 },
        bytes_tx,
        bytes_rx,
        elapsed: start.elapsed(),
        link,
    };
    Ok((MultiFrame { frame, devices, band_rows }, sessions))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_rows_give_several_bands_per_board() {
        assert_eq!(default_band_rows(240, 1), 16);
        assert_eq!(default_band_rows(240, 2), 15);
        assert_eq!(default_band_rows(240, 4), 8);
        assert_eq!(default_band_rows(48, 2), 3);
        assert_eq!(default_band_rows(5, 8), 1);
    }
}
