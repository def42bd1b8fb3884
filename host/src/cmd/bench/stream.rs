//! `gridrt bench stream`: frame rate and link goodput of a frame stream for a scene × baud ×
//! encoding (model: [`gridrt_host::bench::stream`]), on the loopback simulator with its line
//! paced at each baud rate, and once unpaced per encoding (the device's own frame rate).
//!
//! Outputs in `--out-dir DIR`: `stream.csv`, `stream.svg` (fps against baud per encoding,
//! measured, and the line-alone bound) and `stream.json`.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, ensure, Context};
use gridrt_host::bench::stream::{csv, row, run, StreamRow};
use gridrt_host::camera_path::CameraPath;
use gridrt_host::grid::GridParams;
use gridrt_host::plan::Plan;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::msg::{PixelEncoding, RenderRequest};

use crate::cmd::render::Encoding;

/// Arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created).
    #[arg(long = "out-dir", value_name = "DIR")]
    out: PathBuf,
    /// Scene [default: the bundled bun_zipper_res4.obj].
    #[arg(long, value_name = "PATH")]
    scene: Option<PathBuf>,
    /// Line rates (8N1), each paced on the simulator's device → host line.
    #[arg(long, value_delimiter = ',', default_value = "115200,921600,3000000", value_name = "BAUDS", value_parser = clap::value_parser!(u32).range(300..=100_000_000))]
    bauds: Vec<u32>,
    /// Pixel encodings.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "rgb888,rle", value_name = "ENCODINGS")]
    encodings: Vec<Encoding>,
    /// Frames per stream (an orbit of --orbit degrees).
    #[arg(long, default_value_t = 8, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    frames: u32,
    /// Degrees the camera turns over the stream.
    #[arg(long, default_value_t = 360.0, value_name = "DEGREES", allow_negative_numbers = true)]
    orbit: f64,
    /// Frame width.
    #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u16).range(1..=4096))]
    width: u16,
    /// Frame height.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u16).range(1..=4096))]
    height: u16,
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        ensure!(self.orbit.is_finite() && self.orbit.abs() <= 3600.0, "--orbit {} is not in -3600..=3600", self.orbit);
        crate::cmd::output::check_dir(&self.out, "--out-dir")?;
        let scenes;
        let path = match &self.scene {
            Some(p) => p.clone(),
            None => {
                scenes = crate::cmd::scenes::Bundled::or_extract(None)?;
                scenes.join("bun_zipper_res4.obj")
            }
        };
        let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
        let loaded = gridrt_host::scene::load(&path).with_context(|| format!("loading {}", path.display()))?;
        let sim = gridrt_loopback::SimConfig::default();
        let params = GridParams { pe_count: sim.pe_count, pe_mem_words: sim.pe_mem_words, ..Default::default() };
        let prepared = PreparedScene::new(loaded, &params).context("building the grid")?;
        let plan = Plan::derive(&prepared.scene);
        let settings = prepared.scene.settings.with_size(self.width, self.height).with_shadows(plan.shadows);
        let mut base: RenderRequest = settings.to_request(1);
        base.flags |= plan.flags();
        let centre = prepared.scene.bounds().map_or([0.0; 3], |b| b.center());
        let camera_path = CameraPath::Orbit { degrees: self.orbit, centre };
        let camera = prepared.scene.settings.camera;
        println!(
            "{name}: {} frames {}×{}, orbit {}°, scene image {} B, simulator with {} PEs",
            self.frames,
            self.width,
            self.height,
            self.orbit,
            prepared.image.len(),
            sim.pe_count
        );
        let mut rows: Vec<StreamRow> = Vec::new();
        for enc in &self.encodings {
            let enc = PixelEncoding::from(*enc);
            let req = RenderRequest { encoding: enc, ..base };
            let go = |baud: Option<u32>| {
                run(&prepared.image, &req, camera, &camera_path, self.frames, baud, sim).map_err(|e| {
                    anyhow!("{enc:?} at {}: {e:#}", baud.map_or("no pacing".into(), |b| format!("{b} baud")))
                })
            };
            let unpaced = go(None)?;
            let reference = unpaced.frames.clone();
            for baud in std::iter::once(None).chain(self.bauds.iter().copied().map(Some)) {
                let r = if baud.is_none() { unpaced.clone() } else { go(baud)? };
                let row = row(&name, enc, baud, &r, &reference);
                println!(
                    "  {:<7} {:>9}: {:6.2} fps, {:7.0} B/frame, line {:5.1} %, goodput {:8.0} B/s ({:5.1} % of the line), line alone {:6.2} fps",
                    row.encoding,
                    baud.map_or("unpaced".into(), |b| b.to_string()),
                    row.fps,
                    row.wire_per_frame,
                    100.0 * row.line_utilisation,
                    row.goodput_bytes_per_s,
                    100.0 * row.goodput_ratio,
                    row.link_bound_fps
                );
                rows.push(row);
            }
        }
        crate::cmd::output::write_bytes(&self.out.join("stream.csv"), csv(&rows).as_bytes())?;
        plot(&self.out.join("stream.svg"), &rows, &name)?;
        let json = serde_json::json!({
            "scene": name, "width": self.width, "height": self.height, "frames": self.frames,
            "orbit_degrees": self.orbit, "pes": sim.pe_count,
            "note": "loopback simulator, device → host line paced at the baud rate (8N1); baud 0 = unpaced (the device's own frame rate)",
            "rows": rows,
        });
        crate::cmd::output::write_bytes(
            &self.out.join("stream.json"),
            (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
        )?;
        println!("wrote {}/{{stream.csv, stream.svg, stream.json}}", self.out.display());
        for r in &rows {
            ensure!(r.identical, "{} at {} baud: a frame differs from the unpaced run's", r.encoding, r.baud);
        }
        Ok(())
    }
}

fn plot(path: &Path, rows: &[StreamRow], scene: &str) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let paced: Vec<&StreamRow> = rows.iter().filter(|r| r.baud > 0).collect();
    let (lo, hi) =
        paced.iter().fold((f64::MAX, 0f64), |(lo, hi), r| (lo.min(f64::from(r.baud)), hi.max(f64::from(r.baud))));
    let (lo, hi) = if paced.is_empty() { (1e5, 1e7) } else { (lo / 1.5, hi * 1.5) };
    let top = rows.iter().map(|r| r.fps.max(r.link_bound_fps)).fold(0.0f64, f64::max).max(1e-3) * 1.5;
    let bottom = rows.iter().map(|r| r.fps).filter(|v| *v > 0.0).fold(top, f64::min) / 1.5;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Frame stream: fps against line rate, {scene} (loopback, paced line)"), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((lo..hi).log_scale(), (bottom.max(1e-4)..top).log_scale())
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_label_formatter(&|x| super::plot::short_number(*x))
        .y_label_formatter(&|y| super::plot::short_number(*y))
        .x_desc("baud (8N1)")
        .y_desc("frames per second")
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    let colours = [BLUE, RED, GREEN, MAGENTA];
    let mut encodings: Vec<&str> = rows.iter().map(|r| r.encoding.as_str()).collect();
    encodings.dedup();
    for (k, enc) in encodings.iter().enumerate() {
        let colour = colours[k % colours.len()];
        let of: Vec<&&StreamRow> = paced.iter().filter(|r| r.encoding == *enc).collect();
        let measured: Vec<(f64, f64)> = of.iter().map(|r| (f64::from(r.baud), r.fps)).collect();
        let bound: Vec<(f64, f64)> = of.iter().map(|r| (f64::from(r.baud), r.link_bound_fps)).collect();
        let device = rows.iter().find(|r| r.baud == 0 && r.encoding == *enc).map_or(0.0, |r| r.fps);
        let thick = colour.stroke_width(3);
        chart
            .draw_series(LineSeries::new(measured.clone(), thick))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("{enc}, measured"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], thick));
        chart.draw_series(measured.iter().map(|&p| Circle::new(p, 4, colour.filled()))).map_err(|e| anyhow!("{e}"))?;
        let thin = colour.stroke_width(1);
        chart
            .draw_series(LineSeries::new(bound, thin))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("{enc}, line alone (baud/10 ÷ bytes per frame)"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], thin));
        if device > 0.0 {
            let dashed = colour.mix(0.5).stroke_width(1);
            chart
                .draw_series(DashedLineSeries::new(vec![(lo, device), (hi, device)], 6, 4, dashed))
                .map_err(|e| anyhow!("{e}"))?
                .label(format!("{enc}, device unpaced ({device:.2} fps)"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], dashed));
        }
    }
    super::plot::legend_and_present(&mut chart, &root)
}
