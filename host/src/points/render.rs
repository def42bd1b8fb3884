//! Splat frames on one board or several: the request, and sort-last (point splatting) — every
//! board renders its random subset of the points over the whole frame and returns colour and
//! depth, and the host keeps, per pixel, the nearest (depth, colour); boards break depth ties
//! by colour exactly like the splat stage does, so the composite is the one-board image.

use std::io::{Read, Write};
use std::time::Instant;

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{render_flags, stat, RenderRequest};
use serde::Serialize;

use crate::multi::DeviceShare;
use crate::session::{merge_stat, LinkStats, ProgressEvent, RenderedFrame, Session, SessionError};

/// Widest splat frame: 504 columns (9-bit X with 4 guard columns each side, SPEC.md §6).
pub const MAX_SPLAT_WIDTH: u16 = 504;

/// The splat version of a render request: `SPLATS` (+ `SPLAT_PIXEL_DEPTH`), depth as the
/// auxiliary word when `depth`, and no ray-stage or interpolation bits.
pub fn splat_request(base: &RenderRequest, pixel_depth: bool, depth: bool) -> RenderRequest {
    let mut flags = render_flags::SPLATS;
    if pixel_depth {
        flags |= render_flags::SPLAT_PIXEL_DEPTH;
    }
    if depth {
        flags |= render_flags::PRIM_IDS;
    }
    RenderRequest { flags, ..*base }
}

/// Per pixel the nearest (depth, colour) over `frames` (each with depths as `prim_ids`);
/// returns the composite colours and depths.
pub fn composite(frames: &[RenderedFrame]) -> Option<(Vec<u8>, Vec<u32>)> {
    let first = frames.first()?;
    let n = first.width as usize * first.height as usize;
    let mut rgb = first.rgb.clone();
    let mut depth = first.prim_ids.clone()?;
    for f in &frames[1..] {
        let d = f.prim_ids.as_ref()?;
        if f.rgb.len() != 3 * n || d.len() != n {
            return None;
        }
        for i in 0..n {
            let (c, c0) = (&f.rgb[3 * i..3 * i + 3], &rgb[3 * i..3 * i + 3]);
            if (d[i], c) < (depth[i], c0) {
                depth[i] = d[i];
                rgb[3 * i..3 * i + 3].copy_from_slice(&f.rgb[3 * i..3 * i + 3]);
            }
        }
    }
    Some((rgb, depth))
}

/// Renders `req` (a splat request with depth) on every session at once, each holding its own
/// subset of the cloud, and composites.
pub fn render_sort_last<T: Read + Write + Send>(
    sessions: &mut [Session<T>],
    req: &RenderRequest,
    progress: &(dyn Fn(usize, ProgressEvent) + Sync),
) -> Result<(RenderedFrame, Vec<DeviceShare>), SessionError> {
    let start = Instant::now();
    let results: Vec<Result<(RenderedFrame, f64), SessionError>> = std::thread::scope(|sc| {
        let handles: Vec<_> = sessions
            .iter_mut()
            .enumerate()
            .map(|(i, s)| {
                sc.spawn(move || {
                    let f = s.render(req, &mut |e| progress(i, e))?;
                    Ok((f, start.elapsed().as_secs_f64() * 1e3))
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    });
    let mut frames = Vec::new();
    let mut devices = Vec::new();
    for (s, r) in sessions.iter().zip(results) {
        let (f, busy_ms) = r?;
        devices.push(DeviceShare {
            port: s.config().port_name.clone(),
            bands: 1,
            rows: f.height as u32,
            bytes_tx: f.bytes_tx,
            bytes_rx: f.bytes_rx,
            coproc_cycles: 0,
            link: f.link.clone(),
            busy_ms,
            error: None,
        });
        frames.push(f);
    }
    let (rgb, depth) = composite(&frames).ok_or_else(|| SessionError::BadInput {
        port: "all".into(),
        stage: crate::session::Stage::Render,
        what: "the boards' frames differ in size or lack depth".into(),
    })?;
    let mut stats = std::collections::BTreeMap::new();
    let mut link = LinkStats::default();
    for f in &frames {
        for (&k, &v) in &f.stats {
            merge_stat(&mut stats, k, v);
        }
        link.add(&f.link);
    }
    let first = &frames[0];
    let frame = RenderedFrame {
        frame: first.frame,
        width: first.width,
        height: first.height,
        image_crc: crc32(&rgb),
        rgb,
        prim_ids: Some(depth),
        stats,
        spans_reported: frames.iter().map(|f| f.spans_reported).sum(),
        spans_received: frames.iter().map(|f| f.spans_received).sum(),
        bytes_tx: frames.iter().map(|f| f.bytes_tx).sum(),
        bytes_rx: frames.iter().map(|f| f.bytes_rx).sum(),
        elapsed: start.elapsed(),
        link,
    };
    Ok((frame, devices))
}

/// The splat part of a render's statistics (the `splat` object of the stats JSON).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SplatReport {
    /// Points in the cloud.
    pub points: u64,
    /// Where the radii came from: `file` or `density` (k nearest neighbours).
    pub radius_from: String,
    /// Colours of the palette (materials).
    pub palette: usize,
    /// `rows` (row bands) or `points` (sort-last).
    pub split: String,
    /// One Z per splat (`false`, as in the seed) or per pixel.
    pub pixel_depth: bool,
    /// Points transformed by the code generators (summed over boards and bands).
    pub transformed: u64,
    /// Splat codewords sent to the splat stages.
    pub codewords: u64,
    /// Points culled.
    pub culled: u64,
    /// Points clamped to the shape table's largest size.
    pub clamped: u64,
    /// Box pixels the stages depth-tested.
    pub fragments: u64,
    /// Code-generator instructions (devices with counters; 0 on the simulator).
    pub codegen_instructions: u64,
    /// Splat-stage instructions.
    pub stage_instructions: u64,
    /// Span-encoding instructions.
    pub encode_instructions: u64,
    /// All three divided by the points transformed.
    pub instructions_per_splat: Option<f64>,
    /// PSNR of the splat image against the same points as disks ray-traced by the device
    /// (grid + co-processor), with `--reference`; `null` when identical.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub psnr_vs_traced_disks_db: Option<Option<f64>>,
    /// PSNR of the device's ray-traced disks against the f64 reference (checks the
    /// reference itself).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub traced_vs_reference_psnr_db: Option<Option<f64>>,
}

impl SplatReport {
    /// The device counters of a splat frame.
    pub fn counters(&mut self, stats: &std::collections::BTreeMap<u8, u64>) {
        let g = |k: u8| stats.get(&k).copied().unwrap_or(0);
        self.transformed = g(stat::SPLAT_POINTS);
        self.codewords = g(stat::SPLAT_CODEWORDS);
        self.culled = g(stat::SPLAT_CULLED);
        self.clamped = g(stat::SPLAT_CLAMPED);
        self.fragments = g(stat::SPLAT_FRAGMENTS);
        self.codegen_instructions = g(stat::STAGE_SPLAT_CODEGEN);
        self.stage_instructions = g(stat::STAGE_SPLAT_STAGE);
        self.encode_instructions = g(stat::STAGE_BASE + 8);
        let all = self.codegen_instructions + self.stage_instructions + self.encode_instructions;
        self.instructions_per_splat = (all > 0 && self.transformed > 0).then(|| all as f64 / self.transformed as f64);
    }
}
