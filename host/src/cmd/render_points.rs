//! `gridrt render` of a point cloud (seed 001): splat frames on the device(s), optionally
//! split sort-last over several boards, and with `--reference` the same points as disks
//! ray-traced by the device and by the f64 reference.

use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use gridrt_host::compare::compare;
use gridrt_host::grid::GridParams;
use gridrt_host::multi::render_multi;
use gridrt_host::points::{self, PointCloud, RadiusSource, SplatReport, MAX_SPLAT_WIDTH};
use gridrt_host::reference::{self, Reference, Stages};
use gridrt_host::session::{ProgressEvent, RenderedFrame};
use gridrt_host::stats::{LinkReport, ReferenceStats, RenderStats, SceneFacts};
use gridrt_shared::msg::feature;

use super::progress::CliProgress;
use super::render::{write_png, Cmd, Split};

/// Seed of the random point split (fixed: every run splits alike).
const SPLIT_SEED: u64 = 0x5EED_0001;

impl Cmd {
    /// Renders `cloud` on `ports` (see the module docs).
    pub(super) fn run_points<T: Read + Write + Send>(
        &self,
        ports: Vec<(T, String)>,
        cloud: PointCloud,
    ) -> anyhow::Result<()> {
        let total_start = Instant::now();
        let mut sessions = self.sessions(ports);
        let mut progress = CliProgress::default();
        let mut on_event = |e| progress.handle(e);
        let mut info = None;
        for s in &mut sessions {
            let name = s.config().port_name.clone();
            let i = s.hello(&mut on_event).with_context(|| format!("connecting to {name}"))?;
            if i.features & feature::SPLATS == 0 {
                bail!("{name} has no splat path (its Version lacks feature SPLATS): it cannot render point clouds");
            }
            info.get_or_insert(i);
        }
        let Some(info) = info else { bail!("no device") };
        if let Some(board) = self.port.board.filter(|&b| b != info.board) {
            bail!(
                "the device is board {} ({}), not board {board} (--board or `board` in gridrt.toml)",
                info.board,
                super::render::board_name(info.board)
            );
        }
        let params = GridParams {
            m: self.scene.grid.grid_m,
            pe_count: info.pe_count,
            pe_mem_words: self.scene.pe_mem_words.unwrap_or(info.pe_mem_words),
            mapping: self.scene.mapping.into(),
            dims_override: None,
            max_voxels: self.scene.grid.grid_max_voxels,
        };
        let whole_bounds = cloud.bounds();
        let whole = points::prepare(&cloud, &whole_bounds, &params).context("building the grid of the disks")?;
        let base = whole.scene.settings;
        let settings = base.with_size(self.width.unwrap_or(base.width), self.height.unwrap_or(base.height));
        if settings.width > MAX_SPLAT_WIDTH {
            bail!(
                "splat frames are at most {MAX_SPLAT_WIDTH} pixels wide (a 9-bit X coordinate); asked for {}",
                settings.width
            );
        }
        let n = sessions.len();
        let sort_last = n > 1 && self.split == Split::Points;
        let images: Vec<Vec<u8>> = if sort_last {
            cloud
                .split(n, SPLIT_SEED)
                .iter()
                .map(|c| points::prepare(c, &whole_bounds, &params).map(|p| p.image))
                .collect::<Result<_, _>>()
                .context("building the boards' scene images")?
        } else {
            vec![whole.image.clone(); n]
        };

        // Upload (every board its image, at once).
        let upload_start = Instant::now();
        let tx_before: u64 = sessions.iter().map(|s| s.bytes_tx()).sum();
        std::thread::scope(|sc| {
            let jobs: Vec<_> = sessions
                .iter_mut()
                .zip(&images)
                .map(|(s, image)| sc.spawn(move || s.upload_scene(image, &mut |_| {}).map_err(anyhow::Error::from)))
                .collect();
            jobs.into_iter()
                .try_for_each(|j| j.join().unwrap_or_else(|_| Err(anyhow::anyhow!("upload thread panicked"))))
        })
        .context("uploading the point cloud")?;
        let upload_ms = upload_start.elapsed().as_secs_f64() * 1e3;
        let upload_wire_bytes = sessions.iter().map(|s| s.bytes_tx()).sum::<u64>() - tx_before;

        // Splat frame.
        let mut request = settings.with_shadows(false).with_prim_ids(false).to_request(1);
        request.encoding = self.encoding.into();
        let req = points::splat_request(&request, self.pixel_depth, sort_last);
        on_event(ProgressEvent::RenderStarted { width: req.width, height: req.height });
        let (frame, devices) = if let [session] = &mut sessions[..] {
            (session.render(&req, &mut on_event).context("rendering splats")?, Vec::new())
        } else if sort_last {
            let (f, d) =
                points::render_sort_last(&mut sessions, &req, &|_, _| {}).context("rendering splats sort-last")?;
            (f, d)
        } else {
            let owned = std::mem::take(&mut sessions);
            let (multi, back) =
                render_multi(owned, &req, self.band_rows, &|_, _| {}).context("rendering splats on several boards")?;
            sessions = back;
            (multi.frame, multi.devices)
        };
        on_event(ProgressEvent::Finished);
        drop(progress);
        write_png(self.out_path(), frame.width, frame.height, frame.rgb.clone())?;

        let facts = SceneFacts {
            scene: self.scene.scene.display().to_string(),
            dropped_triangles: 0,
            scene_image_bytes: images.iter().map(|i| i.len() as u64).sum(),
            upload_wire_bytes,
            upload_ms,
        };
        let mut stats = RenderStats::new(&facts, &whole.grid, &frame);
        let baud = self.port.baud();
        let modelled_link_s = if devices.is_empty() {
            (frame.bytes_tx + frame.bytes_rx) as f64 * 10.0 / baud as f64
        } else {
            devices.iter().map(|d| d.link_seconds(baud)).fold(0.0, f64::max)
        };
        let encoding = format!("{:?}", self.encoding).to_lowercase();
        stats.link = LinkReport { encoding, baud, modelled_link_s, counters: frame.link.clone() };
        stats.devices = devices;
        let mut report = SplatReport {
            points: cloud.points.len() as u64,
            radius_from: match cloud.radius {
                RadiusSource::File => "file".into(),
                RadiusSource::Density => "density".into(),
            },
            palette: cloud.materials.len(),
            split: if sort_last { "points" } else { "rows" }.into(),
            pixel_depth: self.pixel_depth,
            ..SplatReport::default()
        };
        report.counters(&frame.stats);

        // Reference: the disks ray-traced by the device (whole cloud on board 0) and by f64.
        if self.reference || self.reference_out.is_some() {
            let session = sessions.first_mut().context("no board left for the reference")?;
            if sort_last {
                session
                    .upload_scene(&whole.image, &mut |_| {})
                    .context("uploading the whole cloud for the reference")?;
            }
            let traced = session.render(&request, &mut |_| {}).context("ray tracing the disks")?;
            let start = Instant::now();
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(2);
            let stages = Stages { shadows: false, reflections: false, textures: false, specular: false };
            let f64_ref =
                reference::render(&Reference::new(&whole.scene, &whole.grid.bounds), &settings, stages, threads);
            let reference_ms = start.elapsed().as_secs_f64() * 1e3;
            let cmp = compare(&frame.rgb, &f64_ref.rgb, None, None)?;
            stats.reference = Some(ReferenceStats::new(&cmp, reference_ms));
            report.psnr_vs_traced_disks_db = Some(compare(&frame.rgb, &traced.rgb, None, None)?.psnr_db);
            report.traced_vs_reference_psnr_db = Some(compare(&traced.rgb, &f64_ref.rgb, None, None)?.psnr_db);
            if let Some(path) = &self.reference_out {
                write_png(path, f64_ref.width, f64_ref.height, f64_ref.rgb)?;
            }
        }

        if let Some(path) = &self.stats {
            let mut json = serde_json::to_value(&stats)?;
            json["splat"] = serde_json::to_value(&report)?;
            super::output::write_bytes(path, (serde_json::to_string_pretty(&json)? + "\n").as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
        }
        print_summary(&stats, &report, &frame, self.out_path(), total_start.elapsed());
        Ok(())
    }
}

fn db(p: Option<f64>) -> String {
    p.map_or_else(|| "∞ (identical)".to_string(), |p| format!("{p:.2} dB"))
}

fn print_summary(s: &RenderStats, r: &SplatReport, frame: &RenderedFrame, out: &Path, total: Duration) {
    println!(
        "cloud      {}: {} points (radius from {}), {} colours, image {} B",
        s.scene, r.points, r.radius_from, r.palette, s.scene_image_bytes
    );
    println!("upload     {:.0} ms", s.upload_ms);
    println!(
        "splats     {}×{} in {:.0} ms: {} points, {} codewords, {} culled, {} clamped, {} fragments; split {}, {} depth",
        s.width,
        s.height,
        s.wall_ms,
        r.transformed,
        r.codewords,
        r.culled,
        r.clamped,
        r.fragments,
        r.split,
        if r.pixel_depth { "per-pixel" } else { "per-splat" }
    );
    if let Some(i) = r.instructions_per_splat {
        println!(
            "device     {i:.0} instructions per splat (code generator {}, stage {}, encode {})",
            r.codegen_instructions, r.stage_instructions, r.encode_instructions
        );
    }
    println!(
        "link       {} UART bytes ({} spans), {:.2} s modelled at {} baud",
        s.uart_bytes, frame.spans_received, s.link.modelled_link_s, s.link.baud
    );
    for d in &s.devices {
        println!("board      {}: {} B, {:.2} s link", d.port, d.bytes_tx + d.bytes_rx, d.link_seconds(s.link.baud));
    }
    if let Some(rf) = &s.reference {
        println!(
            "reference  PSNR {} against the f64 disks ({} differing pixels, {:.0} ms)",
            db(rf.psnr_db),
            rf.differing_pixels,
            rf.reference_ms
        );
    }
    if let (Some(a), Some(b)) = (r.psnr_vs_traced_disks_db, r.traced_vs_reference_psnr_db) {
        println!("traced     PSNR {} against the device's ray-traced disks (those vs f64: {})", db(a), db(b));
    }
    println!("wrote      {} ({:.1} s total)", out.display(), total.as_secs_f64());
}
