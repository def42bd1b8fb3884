//! `gridrt bench splat`: seed 001's splat path natively over 10³…10⁶ points and several
//! shape tables (splats/s, error against the f64 disks with the device's and the seed's
//! table keying, per-pixel depth), optionally soft-core instructions per splat from a device
//! (QEMU: `--port`); writes `splat.csv`, `splat.svg` and `splat.json` to --out-dir.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{anyhow, Context};
use gridrt_firmware::splat::table::TableConfig;
use gridrt_host::bench::splat::{self, SplatRow};
use gridrt_host::grid::GridParams;
use gridrt_host::points::{self, synthetic, PointCloud, SplatReport};
use gridrt_host::session::{Session, SessionConfig};

/// Seed 001's estimate for its XC2V250 stage (thesis ch. 7: 2 + 4 clocks of 10 ns).
const SEED_NS_PER_SPLAT: f64 = 60.0;

/// `bench splat` arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder (created).
    #[arg(long = "out-dir", alias = "out", value_name = "DIR")]
    out: PathBuf,
    /// Cloud sizes.
    #[arg(long, value_delimiter = ',', default_values_t = [1_000usize, 10_000, 100_000, 1_000_000])]
    points: Vec<usize>,
    /// Image width and height.
    #[arg(long, default_value_t = 320)]
    width: u16,
    /// Image height.
    #[arg(long, default_value_t = 240)]
    height: u16,
    /// Timed runs per row (the best is reported).
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// Also measure soft-core instructions per splat on this device (e.g. QEMU's pty from
    /// `cargo xtask qemu`), for the clouds it can hold (≤ 10⁴ points).
    #[arg(long, value_name = "PATH")]
    port: Option<String>,
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        std::fs::create_dir_all(&self.out).with_context(|| format!("creating {}", self.out.display()))?;
        let tables = [
            TableConfig { normal_bins: 16, steps_per_px: 2, max_radius_px: 8 },
            TableConfig::DEVICE,
            TableConfig { normal_bins: 64, steps_per_px: 8, max_radius_px: 8 },
        ];
        let (counts, size, runs) = (self.points.clone(), (self.width, self.height), self.runs);
        // The engine holds 10⁶ points (≈ 70 MB): build it on a thread with room for it.
        let rows = std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn(move || {
                splat::run(&counts, &tables, size, runs, &mut |r: &SplatRow| {
                    eprintln!(
                        "{:>8} points, table {}×{} /{} px: {:>7.1} ns/splat, {:.2} M splats/s, PSNR {} (seed keying {}, per-pixel depth {})",
                        r.points,
                        r.normal_bins,
                        r.normal_bins,
                        r.steps_per_px,
                        r.ns_per_splat,
                        r.splats_per_s / 1e6,
                        db(r.psnr_db),
                        db(r.psnr_seed_affine_db),
                        db(r.psnr_pixel_depth_db)
                    )
                })
            })?
            .join()
            .map_err(|_| anyhow!("bench thread panicked"))?
            .map_err(|e| anyhow!(e))?;
        let device: Vec<(usize, SplatReport)> = match &self.port {
            Some(port) => self.device_counts(port)?,
            None => Vec::new(),
        };
        let mut csv = csv::Writer::from_writer(Vec::new());
        csv.write_record("points,normal_bins,steps_per_px,table_words,frame_ms,splats_per_s,ns_per_splat,seed_ns_per_splat,codewords,psnr_db,psnr_seed_affine_db,psnr_pixel_depth_db,device_instructions_per_splat".split(','))?;
        for r in &rows {
            let ipc = device.iter().find(|(n, _)| *n == r.points).and_then(|(_, d)| d.instructions_per_splat);
            let opt = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:.3}"));
            csv.write_record([
                r.points.to_string(),
                r.normal_bins.to_string(),
                r.steps_per_px.to_string(),
                r.table_words.to_string(),
                format!("{:.3}", r.frame_ms),
                format!("{:.0}", r.splats_per_s),
                format!("{:.1}", r.ns_per_splat),
                SEED_NS_PER_SPLAT.to_string(),
                r.codewords.to_string(),
                opt(r.psnr_db),
                opt(r.psnr_seed_affine_db),
                opt(r.psnr_pixel_depth_db),
                opt(ipc),
            ])?;
        }
        let csv = csv.into_inner().map_err(|e| anyhow!("{e}"))?;
        crate::cmd::output::write_bytes(&self.out.join("splat.csv"), &csv)?;
        let json = serde_json::json!({
            "command": format!("gridrt bench splat --out-dir {} --points {} --width {} --height {}{}", self.out.display(),
                self.points.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(","), self.width, self.height,
                self.port.as_ref().map_or(String::new(), |p| format!(" --port {p}"))),
            "seed_ns_per_splat": SEED_NS_PER_SPLAT,
            "rows": rows,
            "device": device.iter().map(|(n, d)| serde_json::json!({"points": n, "splat": d})).collect::<Vec<_>>(),
        });
        std::fs::write(self.out.join("splat.json"), serde_json::to_string_pretty(&json)? + "\n")?;
        plot(&self.out.join("splat.svg"), &rows)?;
        println!("wrote {}/splat.csv, splat.svg, splat.json", self.out.display());
        Ok(())
    }

    /// One splat frame per cloud size ≤ 10⁴ on the device at `port`; its counters.
    fn device_counts(&self, port: &str) -> anyhow::Result<Vec<(usize, SplatReport)>> {
        let serial = serialport::new(port, 115_200).timeout(Duration::from_millis(50)).open()?;
        let mut s = Session::new(serial, SessionConfig::new(port.to_string()).render_timeout(Duration::from_secs(300)));
        let info = s.hello(&mut |_| {})?;
        let params = GridParams {
            m: 1.0,
            pe_count: info.pe_count,
            pe_mem_words: info.pe_mem_words,
            mapping: gridrt_host::grid::PeMapping::Interleaved,
            dims_override: None,
            max_voxels: gridrt_host::grid::MAX_VOXELS,
        };
        let mut out = Vec::new();
        for &n in self.points.iter().filter(|&&n| n <= 10_000) {
            let v = synthetic::torus_and_sphere(n, 0xBE_0001 ^ n as u64);
            let cloud = PointCloud::from_ply(Path::new("synthetic"), v)?;
            let prepared = points::prepare(&cloud, &cloud.bounds(), &params)?;
            s.upload_scene(&prepared.image, &mut |_| {})?;
            let req = prepared.scene.settings.with_size(self.width, self.height).with_shadows(false).to_request(1);
            let frame = s.render(&points::splat_request(&req, false, false), &mut |_| {})?;
            let mut r = SplatReport::default();
            r.counters(&frame.stats);
            eprintln!("device: {n} points: {:?} instructions per splat", r.instructions_per_splat);
            out.push((n, r));
        }
        Ok(out)
    }
}

fn db(p: Option<f64>) -> String {
    p.map_or_else(|| "∞".into(), |p| format!("{p:.2} dB"))
}

fn plot(path: &Path, rows: &[SplatRow]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let max_n = rows.iter().map(|r| r.points).max().unwrap_or(10) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption("Splats: PSNR against the ray-traced disks (f64) per cloud size and table", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d((100f64..max_n * 2.0).log_scale(), 0.0f64..50.0f64)
        .map_err(|e| anyhow!("{e}"))?;
    chart.configure_mesh().x_desc("points").y_desc("PSNR (dB)").draw().map_err(|e| anyhow!("{e}"))?;
    let colours = [RED, BLUE, GREEN, MAGENTA, CYAN];
    let mut tables: Vec<(u16, u16)> = rows.iter().map(|r| (r.normal_bins, r.steps_per_px)).collect();
    tables.dedup();
    for (k, t) in tables.iter().enumerate() {
        let c = colours[k % colours.len()];
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| (r.normal_bins, r.steps_per_px) == *t)
            .map(|r| (r.points as f64, r.psnr_db.unwrap_or(50.0)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(2)))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("table {}×{} normals, 1/{} px", t.0, t.0, t.1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c));
    }
    let seed: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| (r.normal_bins, r.steps_per_px) == (32, 4))
        .map(|r| (r.points as f64, r.psnr_seed_affine_db.unwrap_or(50.0)))
        .collect();
    chart
        .draw_series(LineSeries::new(seed, BLACK.stroke_width(1)))
        .map_err(|e| anyhow!("{e}"))?
        .label("device table, seed 001's keying")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
    super::plot::legend_and_present(&mut chart, &root)
}
