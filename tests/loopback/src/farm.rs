//! The simulated board's row farm: a frame's rows traced on rayon's threads, each band of
//! rows through a ray port of its own onto the co-processor model's PE memories
//! (`Coprocessor::ray_port`), handed back to the device thread in row order.
//!
//! A ray's answer is a function of its packet and the loaded PEs alone (no state carries
//! from one ray to the next), and every counter the frame reports is a sum, so the device
//! sends the bytes its own loop would: `host/tests/sim_farm.rs` pins that against `threads: 1`.

use std::collections::BTreeMap;
use std::ops::{ControlFlow, Range};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;

use gridrt_firmware::device::{FrameStats, RowDone, RowFarm, RowFault, RowTracer, Rows};
use gridrt_firmware::interp::Sample;

use crate::link::SimLink;

/// Pixels per band: enough to make a task worth scheduling, few enough that the bands of a
/// frame keep every thread busy and the device thread streams rows out as they come.
const BAND_PIXELS: usize = 4096;

/// Frames whose rows a farm traced, in this process.
pub(crate) static FARMED_FRAMES: AtomicU64 = AtomicU64::new(0);

/// The rows a band traced (it stops at the first fault).
struct Band {
    /// Samples, row after row.
    samples: Vec<Sample>,
    /// Counters of each traced row.
    stats: Vec<FrameStats>,
    /// The row that failed and its fault (the band's last traced row).
    fault: Option<RowFault>,
}

/// Traces frames on `threads` threads (0: rayon's global pool); 1 declines every frame, so
/// the device renders them on its own thread.
pub(crate) struct SimFarm {
    threads: u16,
    /// The pool of an explicit thread count, made at the first frame.
    pool: Option<rayon::ThreadPool>,
}

impl SimFarm {
    pub(crate) fn new(threads: u16) -> Self {
        Self { threads, pool: None }
    }
}

/// Bands of `ys`, `per` rows each (the last may be shorter).
fn bands(ys: Range<u16>, per: u16) -> Vec<Range<u16>> {
    let mut out = Vec::new();
    let mut y = ys.start;
    while y < ys.end {
        let end = y.saturating_add(per).min(ys.end);
        out.push(y..end);
        y = end;
    }
    out
}

/// Traces the rows of `band` on a fresh port; stops at the first fault or when `cancel` is
/// set (the device stopped the frame).
fn trace_band<const N: usize>(
    model: &gridrt_coproc::Coprocessor<'_>,
    rows: &Rows<'_, N>,
    band: Range<u16>,
    cancel: &AtomicBool,
) -> Band {
    let w = rows.width();
    let mut tracer = RowTracer::new(rows, model.ray_port());
    let mut out = Band { samples: vec![Sample::default(); w * band.len()], stats: Vec::new(), fault: None };
    for (y, row) in band.zip(out.samples.chunks_exact_mut(w.max(1))) {
        if cancel.load(Ordering::Relaxed) {
            break;
        }
        let r = tracer.row(rows, y, row);
        out.stats.push(tracer.take_stats());
        if let Err(f) = r {
            out.fault = Some(f);
            break;
        }
    }
    out
}

impl<'m> RowFarm<SimLink<'m>> for SimFarm {
    fn render<const N: usize>(
        &mut self,
        link: &SimLink<'m>,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool {
        let SimLink::Model(coproc) = link else { return false };
        if self.threads == 1 {
            return false;
        }
        if self.threads > 1 && self.pool.is_none() {
            let Ok(pool) = rayon::ThreadPoolBuilder::new()
                .num_threads(self.threads as usize)
                .thread_name(|i| format!("gridrt-sim-rows-{i}"))
                .build()
            else {
                return false;
            };
            self.pool = Some(pool);
        }
        let model = &coproc.model;
        let w = rows.width();
        let per = (BAND_PIXELS / w.max(1)).clamp(1, 32) as u16;
        let bands = bands(rows.ys(), per);
        FARMED_FRAMES.fetch_add(1, Ordering::Relaxed);
        let cancel = AtomicBool::new(false);
        let job = Job { model, rows, bands: &bands, cancel: &cancel };
        match &self.pool {
            Some(pool) => pool.in_place_scope(|s| job.run(s, sink)),
            None => rayon::in_place_scope(|s| job.run(s, sink)),
        }
        true
    }
}

/// One frame's bands on the pool.
struct Job<'a, 'm, 'r, const N: usize> {
    model: &'a gridrt_coproc::Coprocessor<'m>,
    rows: &'a Rows<'r, N>,
    bands: &'a [Range<u16>],
    cancel: &'a AtomicBool,
}

impl<'a, const N: usize> Job<'a, '_, '_, N> {
    /// Spawns every band, then hands the rows to `sink` in order as bands finish; sets
    /// `cancel` when the frame stops early.
    fn run(&self, s: &rayon::Scope<'a>, sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>) {
        let (tx, rx) = mpsc::channel::<(usize, Band)>();
        let w = self.rows.width();
        for (i, band) in self.bands.iter().enumerate() {
            let (tx, band) = (tx.clone(), band.clone());
            let (model, rows, cancel) = (self.model, self.rows, self.cancel);
            s.spawn(move |_| {
                if !cancel.load(Ordering::Relaxed) {
                    let _ = tx.send((i, trace_band(model, rows, band, cancel)));
                }
            });
        }
        drop(tx);
        // Bands finish in any order; the device gets them in row order.
        let mut waiting = BTreeMap::new();
        for (next, ys) in self.bands.iter().enumerate() {
            let band = loop {
                if let Some(b) = waiting.remove(&next) {
                    break b;
                }
                match rx.recv() {
                    Ok((i, b)) => {
                        waiting.insert(i, b);
                    }
                    // Every task ended without this band: only if one panicked, which rayon
                    // raises again when the scope ends.
                    Err(_) => return,
                }
            };
            if !hand_over(&band, ys, w, sink) {
                self.cancel.store(true, Ordering::Relaxed);
                return;
            }
        }
    }
}

/// Hands `band`'s rows to the device; `false` when the frame stops (a fault, or the device
/// broke off).
fn hand_over(band: &Band, ys: &Range<u16>, w: usize, sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>) -> bool {
    let traced = band.stats.len();
    for (k, (y, stats)) in ys.clone().zip(&band.stats).enumerate() {
        let last = k + 1 == traced;
        let fault = if last { band.fault } else { None };
        let samples = band.samples.get(k * w..(k + 1) * w).unwrap_or(&[]);
        if sink(RowDone { y, samples, fault, stats: *stats }).is_break() || fault.is_some() {
            return false;
        }
    }
    // A band cut short by `cancel` never reaches here: the frame had already stopped.
    traced == ys.len()
}
