//! `gridrt bench link`: wire bytes, payload efficiency and compression of the UART
//! link per pixel encoding, and the modelled frame time with transmission overlapped with
//! ray work, on one or several boards.
//!
//! # What is measured
//! Every frame is rendered on the loopback simulator through the real byte stream, twice:
//! once as one `RenderRegion` (the wire bytes of a frame, exactly), and once row by row (the
//! device counters and span bytes of every row, for the timing model). Nothing here is
//! timed with a clock: times are modelled.
//!
//! # The model
//! - **Line rate**: 8N1, 10 bit times per byte: `baud / 10` bytes per second each way.
//! - **Ray work** of a row = co-processor cycles the model reported ÷ 50 MHz (GridRT's PE
//!   clock, `TimingProfile::GRIDRT` charged at the kernel that runs: watertight f32, 1188
//!   cycles per test; `SimConfig::coproc`) + firmware instructions ÷ 50 MHz (a soft-core at the same
//!   clock, CPI 1). Firmware instructions are estimated from the row's counters with the
//!   per-stage costs measured on QEMU for riscv32imafc (BENCHMARKS.md, QEMU end to end: 164 raygen +
//!   279 shade per primary ray, 964 traverse per primary ray = 878 per traced ray, 620 FSL
//!   I/O per primary ray = 105 per FSL word, 369 encode per pixel); [`FirmwareModel`].
//!   The firmware waits for each ray's result (one ray in flight), so the two add up.
//! - **Overlap**: the UART sends row *i* (from a transmit buffer, by DMA or interrupt) while
//!   the device works on row *i+1*; with one row of buffering the device cannot start row
//!   *i+2* before row *i* has left: `work_end[i] = max(work_end[i−1], tx_start[i−1]) + work[i]`,
//!   `tx_start[i] = max(work_end[i], tx_end[i−1])`, `tx_end[i] = tx_start[i] + bytes[i]·10/baud`.
//!   The request, `Stats` and `RegionEnd` of the frame are added serially.
//! - **Several boards**: bands of rows go to whichever board is free first (the host's work
//!   queue, [`crate::multi`]); each band costs its request, its rows through the pipeline
//!   above and its `Stats` + `RegionEnd`; the frame ends when the last board finishes.

use std::collections::BTreeMap;
use std::time::Duration;

use gridrt_shared::msg::{stat, PixelEncoding, Region, RenderRequest};
use serde::Serialize;

use crate::scene_image::PreparedScene;
use crate::session::{Canvas, Session, SessionConfig, SessionError};

/// The modelled line rates.
pub const BAUDS: [u32; 3] = [115_200, 921_600, 3_000_000];
/// Co-processor (PE array) clock of the model.
pub const COPROC_HZ: f64 = 50e6;
/// Soft-core clock of the model.
pub const CPU_HZ: f64 = 50e6;

/// Firmware instructions per unit of work (CPI 1 at [`CPU_HZ`]); see the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FirmwareModel {
    /// Ray generation + shading, per primary ray.
    pub per_primary_ray: f64,
    /// 3D-DDA and list building, per traced ray (primary, shadow, reflection).
    pub per_ray: f64,
    /// FSL put/get, per word.
    pub per_fsl_word: f64,
    /// Span packing and frame encoding, per pixel.
    pub per_pixel: f64,
}

impl FirmwareModel {
    /// riscv32imafc on QEMU, bunny res4 320×240 (BENCHMARKS.md, QEMU end to end).
    pub const RV32IMAFC: FirmwareModel =
        FirmwareModel { per_primary_ray: 164.0 + 279.0, per_ray: 878.0, per_fsl_word: 105.0, per_pixel: 369.0 };

    /// Instructions for a region with these device counters.
    pub fn instructions(&self, s: &BTreeMap<u8, u64>) -> f64 {
        let g = |k| s.get(&k).copied().unwrap_or(0) as f64;
        let rays = g(stat::PRIMARY_RAYS) + g(stat::SHADOW_RAYS) + g(stat::REFLECTION_RAYS);
        self.per_primary_ray * g(stat::PRIMARY_RAYS)
            + self.per_ray * rays
            + self.per_fsl_word * (g(stat::FSL_WORDS_OUT) + g(stat::FSL_WORDS_IN))
            + self.per_pixel * g(stat::PIXELS)
    }
}

/// One row: its span bytes on the wire and its ray work.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RowCost {
    /// Wire bytes of the row's spans (device → host).
    pub bytes: f64,
    /// Co-processor cycles.
    pub coproc_cycles: u64,
    /// Ray work in seconds (co-processor + firmware model).
    pub work_s: f64,
}

/// Measurements of one frame in one encoding.
#[derive(Debug, Clone, Serialize)]
pub struct Measured {
    /// Scene name.
    pub scene: String,
    /// Encoding.
    pub encoding: String,
    /// Width.
    pub width: u16,
    /// Height.
    pub height: u16,
    /// Device → host wire bytes of the whole frame as one region (spans, Stats, RegionEnd).
    pub wire_rx: u64,
    /// Host → device wire bytes of the frame (the request).
    pub wire_tx: u64,
    /// Wire bytes of the colour spans alone.
    pub span_bytes: f64,
    /// Per-band overhead device → host (`Stats` + `RegionEnd`), bytes.
    pub band_overhead_rx: f64,
    /// Co-processor cycles of the frame.
    pub coproc_cycles: u64,
    /// Ray work of the frame, seconds.
    pub work_s: f64,
    /// Per row.
    pub rows: Vec<RowCost>,
    /// The decoded image (to check encodings against each other).
    #[serde(skip)]
    pub rgb: Vec<u8>,
}

impl Measured {
    /// Raw pixel payload: 3 bytes per pixel.
    pub fn raw_bytes(&self) -> u64 {
        3 * self.width as u64 * self.height as u64
    }
}

fn sim_session(prepared: &PreparedScene) -> Result<Session<gridrt_loopback::SimPort>, SessionError> {
    let mut port = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
    port.set_timeout(Duration::from_millis(20));
    let cfg = SessionConfig::new("sim").render_timeout(Duration::from_secs(600));
    let mut s = Session::new(port, cfg);
    s.hello(&mut |_| {})?;
    s.upload_scene(&prepared.image, &mut |_| {})?;
    Ok(s)
}

/// Renders `req` (in `req.encoding`) on a simulated board: once whole, once row by row.
pub fn measure(
    scene: &str,
    prepared: &PreparedScene,
    req: &RenderRequest,
    fw: &FirmwareModel,
) -> Result<Measured, SessionError> {
    let mut s = sim_session(prepared)?;
    let (w, h) = (req.width, req.height);
    // Whole frame, one region.
    let (tx0, rx0) = (s.bytes_tx(), s.bytes_rx());
    let mut canvas = Canvas::new(w, h, false);
    let whole = s.render_band(req, Region::full(w, h), &mut canvas, &mut |_| {})?;
    let (wire_tx, wire_rx) = (s.bytes_tx() - tx0, s.bytes_rx() - rx0);
    let rgb = canvas.rgb.clone();
    // Row by row.
    let mut rows = Vec::with_capacity(h as usize);
    let mut rx_rows = Vec::with_capacity(h as usize);
    let mut canvas = Canvas::new(w, h, false);
    for y in 0..h {
        let rx = s.bytes_rx();
        let r = s.render_band(req, Region { x0: 0, y0: y, cols: w, rows: 1 }, &mut canvas, &mut |_| {})?;
        rx_rows.push((s.bytes_rx() - rx) as f64);
        let cycles = r.stats.get(&stat::COPROC_CYCLES).copied().unwrap_or(0);
        rows.push(RowCost {
            bytes: 0.0,
            coproc_cycles: cycles,
            work_s: cycles as f64 / COPROC_HZ + fw.instructions(&r.stats) / CPU_HZ,
        });
    }
    if canvas.rgb != rgb {
        return Err(SessionError::BadInput {
            port: "sim".into(),
            stage: crate::session::Stage::Render,
            what: "row-by-row render differs from the whole-frame render".into(),
        });
    }
    // Each row request costs one band overhead more than the whole frame's single one.
    let sum: f64 = rx_rows.iter().sum();
    let band_overhead_rx = if h > 1 { (sum - wire_rx as f64) / (h as f64 - 1.0) } else { 0.0 };
    for (r, rx) in rows.iter_mut().zip(&rx_rows) {
        r.bytes = (rx - band_overhead_rx).max(0.0);
    }
    let work_s = rows.iter().map(|r| r.work_s).sum();
    Ok(Measured {
        scene: scene.to_string(),
        encoding: format!("{:?}", req.encoding).to_lowercase(),
        width: w,
        height: h,
        wire_rx,
        wire_tx,
        span_bytes: rows.iter().map(|r| r.bytes).sum(),
        band_overhead_rx,
        coproc_cycles: whole.stats.get(&stat::COPROC_CYCLES).copied().unwrap_or(0),
        work_s,
        rows,
        rgb,
    })
}

/// Seconds of one band of rows on one board: request, rows through the one-row-buffered
/// pipeline, then the band's `Stats` + `RegionEnd`.
pub fn band_seconds(rows: &[RowCost], request_bytes: f64, end_bytes: f64, baud: u32) -> f64 {
    let byte_s = 10.0 / baud as f64;
    let (mut work_end, mut tx_start, mut tx_end) = (0.0f64, 0.0f64, 0.0f64);
    for r in rows {
        work_end = work_end.max(tx_start) + r.work_s;
        tx_start = work_end.max(tx_end);
        tx_end = tx_start + r.bytes * byte_s;
    }
    request_bytes * byte_s + tx_end + end_bytes * byte_s
}

/// Seconds of the same band without overlap (work, then transmission).
pub fn serial_seconds(rows: &[RowCost], request_bytes: f64, end_bytes: f64, baud: u32) -> f64 {
    let byte_s = 10.0 / baud as f64;
    rows.iter().map(|r| r.work_s + r.bytes * byte_s).sum::<f64>() + (request_bytes + end_bytes) * byte_s
}

/// Modelled frame on `devices` boards with bands of `band_rows` rows, greedy to the board
/// that is free first: (frame seconds, most co-processor cycles on one board).
pub fn multi_seconds(m: &Measured, devices: usize, band_rows: u16, baud: u32) -> (f64, u64) {
    let devices = devices.max(1);
    let mut free = vec![0.0f64; devices];
    let mut cycles = vec![0u64; devices];
    for band in m.rows.chunks(band_rows.max(1) as usize) {
        let (k, _) = free.iter().enumerate().fold((0, f64::INFINITY), |b, (i, &t)| if t < b.1 { (i, t) } else { b });
        free[k] += band_seconds(band, m.wire_tx as f64, m.band_overhead_rx, baud);
        cycles[k] += band.iter().map(|r| r.coproc_cycles).sum::<u64>();
    }
    (free.iter().copied().fold(0.0, f64::max), cycles.into_iter().max().unwrap_or(0))
}

/// One CSV row of `link.csv`.
#[derive(Debug, Clone, Serialize)]
pub struct LinkRow {
    /// Scene.
    pub scene: String,
    /// Encoding.
    pub encoding: String,
    /// Line rate.
    pub baud: u32,
    /// Frame size.
    pub width: u16,
    /// Frame size.
    pub height: u16,
    /// Device → host wire bytes per frame.
    pub wire_bytes_rx: u64,
    /// Host → device wire bytes per frame.
    pub wire_bytes_tx: u64,
    /// 3 bytes per pixel.
    pub raw_pixel_bytes: u64,
    /// raw pixel bytes ÷ wire bytes: the share of the line rate that carries pixels (> 1
    /// when compressed).
    pub payload_efficiency: f64,
    /// Rgb888 wire bytes ÷ this encoding's wire bytes: how many times the raw pixel rate.
    pub pixel_rate_vs_raw: f64,
    /// Pixels per second the line carries.
    pub link_pixels_per_s: f64,
    /// Device → host wire time of the frame.
    pub link_s: f64,
    /// Ray work of the frame.
    pub work_s: f64,
    /// Modelled frame time, transmission overlapped with ray work.
    pub frame_s: f64,
    /// Without overlap.
    pub frame_serial_s: f64,
    /// `link` or `ray work`: what bounds the overlapped frame.
    pub bound: String,
}

/// The rows of `link.csv` for one measurement; `raw_wire` = the Rgb888 wire bytes of the
/// same frame.
pub fn link_rows(m: &Measured, raw_wire: u64) -> Vec<LinkRow> {
    BAUDS
        .iter()
        .map(|&baud| {
            let byte_s = 10.0 / baud as f64;
            let link_s = m.wire_rx as f64 * byte_s;
            let frame_s = band_seconds(&m.rows, m.wire_tx as f64, m.band_overhead_rx, baud);
            LinkRow {
                scene: m.scene.clone(),
                encoding: m.encoding.clone(),
                baud,
                width: m.width,
                height: m.height,
                wire_bytes_rx: m.wire_rx,
                wire_bytes_tx: m.wire_tx,
                raw_pixel_bytes: m.raw_bytes(),
                payload_efficiency: m.raw_bytes() as f64 / m.wire_rx as f64,
                pixel_rate_vs_raw: raw_wire as f64 / m.wire_rx as f64,
                link_pixels_per_s: (m.width as f64 * m.height as f64) / link_s,
                link_s,
                work_s: m.work_s,
                frame_s,
                frame_serial_s: serial_seconds(&m.rows, m.wire_tx as f64, m.band_overhead_rx, baud),
                bound: if link_s > m.work_s { "link".into() } else { "ray work".into() },
            }
        })
        .collect()
}

/// Encodings compared.
pub const ENCODINGS: [PixelEncoding; 3] = [PixelEncoding::Rgb888, PixelEncoding::Rgb565, PixelEncoding::Rle];

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(work: f64, bytes: f64, n: usize) -> Vec<RowCost> {
        vec![RowCost { bytes, coproc_cycles: 1, work_s: work }; n]
    }

    #[test]
    fn pipeline_is_bounded_by_the_slower_stage_plus_one_row_of_the_other() {
        // 10 rows; work 1 s, transmission 2 s per row (bytes 2 at 10 baud = 1 byte/s).
        let r = rows(1.0, 2.0, 10);
        let t = band_seconds(&r, 0.0, 0.0, 10);
        assert!((t - (1.0 + 20.0)).abs() < 1e-9, "{t}");
        assert!((serial_seconds(&r, 0.0, 0.0, 10) - 30.0).abs() < 1e-9);
        // Work-bound: 2 s work, 1 s tx per row.
        let r = rows(2.0, 1.0, 10);
        assert!((band_seconds(&r, 0.0, 0.0, 10) - 21.0).abs() < 1e-9);
    }

    #[test]
    fn two_boards_halve_a_balanced_frame() {
        let m = Measured {
            scene: "t".into(),
            encoding: "rgb888".into(),
            width: 1,
            height: 40,
            wire_rx: 0,
            wire_tx: 0,
            span_bytes: 0.0,
            band_overhead_rx: 0.0,
            coproc_cycles: 40,
            work_s: 40.0,
            rows: rows(1.0, 1.0, 40),
            rgb: vec![],
        };
        let (one, c1) = multi_seconds(&m, 1, 4, 10);
        let (two, c2) = multi_seconds(&m, 2, 4, 10);
        assert!((one / two - 2.0).abs() < 0.2, "{one} {two}");
        assert_eq!((c1, c2), (40, 20));
    }
}
