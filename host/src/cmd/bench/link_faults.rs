//! `gridrt bench link --faults`: whole sessions — hello, scene upload, one frame — over a
//! paced pseudo-terminal relay with bit flips, byte drops and garbage bursts in both
//! directions ([`gridrt_host::faults`]), to the simulated board (the loop `gridrt device`
//! runs), at each bit error rate of --bers. Reports time to the frame and its ratio to the
//! clean run, goodput of the upload and of the frame against the selective-repeat bound
//! ([`gridrt_host::bench::link_faults`]), the line utilisation of each phase in its direction,
//! and checks that every frame is the clean run's, byte for byte.
//!
//! Outputs in `--out-dir DIR`: `link_faults.csv`, `link_faults.svg` (goodput / line rate against
//! BER with the bounds) and `link_faults.json`.

use std::path::Path;
use std::time::Duration;

use anyhow::{anyhow, ensure, Context};
use gridrt_host::bench::link_faults::{csv, fault_row, FaultRow};
use gridrt_host::faults::relay::RelayConfig;
use gridrt_host::faults::run::{run_session, LineRun};
use gridrt_host::faults::Faults;
use gridrt_host::grid::GridParams;
use gridrt_host::plan::Plan;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{ProgressEvent, SessionConfig, Stage};
use gridrt_shared::msg::{PixelEncoding, RenderRequest};

use crate::cmd::progress::CliProgress;

/// Options of the faulty-line measurement.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Faulty line (--faults)")]
pub struct LineArgs {
    /// Scene of the session (relative to --scenes).
    #[arg(long, default_value = "bun_zipper_res4.obj", value_name = "FILE")]
    scene: String,
    /// Line rate of the relay, both directions (8N1).
    #[arg(long, default_value_t = 115_200, value_name = "BAUD")]
    baud: u32,
    /// Bit error rates; the first should be 0 (the reference run). Each also gets byte drops
    /// at BER/10 and 1..=16-byte garbage bursts at BER/100 per byte, in both directions.
    #[arg(long, value_delimiter = ',', default_value = "0,1e-6,1e-5,1e-4,1e-3", value_name = "BERS")]
    bers: Vec<f64>,
    /// Pixel encoding of the frame.
    #[arg(long, value_enum, default_value_t = crate::cmd::render::Encoding::Rle)]
    encoding: crate::cmd::render::Encoding,
    /// Seed of the relay's faults.
    #[arg(long, default_value_t = 13)]
    seed: u64,
    /// Fail unless the time to the frame is at most this many times the clean run's at BER
    /// 1e-4 and at 1e-3 (0 = no check).
    #[arg(long, value_delimiter = ',', default_value = "1.25,3", value_name = "R4,R3")]
    max_ratio: Vec<f64>,
}

/// Runs the measurement (module docs).
pub fn run(out: &Path, scenes: &Path, width: u16, height: u16, a: &LineArgs) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    ensure!(a.bers.first() == Some(&0.0), "--bers must start with 0: the clean run every ratio refers to");
    let path = scenes.join(&a.scene);
    let loaded = gridrt_host::scene::load(&path).with_context(|| format!("loading {}", path.display()))?;
    let sim = gridrt_loopback::SimConfig::default();
    let params = GridParams { pe_count: sim.pe_count, pe_mem_words: sim.pe_mem_words, ..Default::default() };
    let prepared = PreparedScene::new(loaded, &params).context("building the grid")?;
    let plan = Plan::derive(&prepared.scene);
    let settings = prepared.scene.settings.with_size(width, height).with_shadows(plan.shadows);
    let mut req: RenderRequest = settings.to_request(1);
    req.flags |= plan.flags();
    req.encoding = PixelEncoding::from(a.encoding);
    println!(
        "{}: scene image {} B, frame {width}×{height} {:?}, relay at {} baud (8N1), seed {}",
        a.scene,
        prepared.image.len(),
        req.encoding,
        a.baud,
        a.seed
    );

    let mut rows: Vec<FaultRow> = Vec::new();
    let mut clean: Option<LineRun> = None;
    for (i, &ber) in a.bers.iter().enumerate() {
        let f = if ber > 0.0 { Faults::line(ber) } else { Faults::default() };
        let relay = RelayConfig { baud: Some(a.baud), up: f, down: f, seed: a.seed.wrapping_add(i as u64) };
        let session =
            SessionConfig::new(format!("relay@{ber:e}")).baud(a.baud).render_timeout(Duration::from_secs(120));
        println!("== BER {ber:e}: drops {:e}/byte, bursts {:e}/byte, both directions", f.drop, f.burst);
        let mut chunk = 0usize;
        let mut progress = CliProgress::default();
        let run = run_session(&prepared.image, &req, relay, sim, session, &mut |e| {
            if let ProgressEvent::Activity(act) = &e {
                if act.stage == Stage::Upload {
                    chunk = act.chunk;
                }
            }
            progress.handle(e)
        })
        .map_err(|e| anyhow!("BER {ber:e}: {e}"))?;
        drop(progress);
        let reference = clean.get_or_insert_with(|| run.clone()).clone();
        let row = fault_row(&f, &run, &reference, prepared.image.len(), a.baud, chunk);
        println!(
            "   upload {:.2} s ({:.2}×), frame {:.2} s ({:.2}×), total {:.2} s ({:.2}×); line utilisation host → device in the upload {:.3} ({} B), device → host in the frame {:.3} ({} B); goodput: scene image B / line {:.3} (bound {:.3}), frame span B / line {:.3} (bound {:.3}); {} chunks resent, {} runs re-requested; identical: {}",
            row.upload_s,
            row.upload_ratio,
            row.frame_s,
            row.frame_ratio,
            row.total_s,
            row.total_ratio,
            row.upload_line_utilisation,
            row.upload_line_bytes[0],
            row.frame_line_utilisation,
            row.frame_line_bytes[1],
            row.upload_goodput,
            row.upload_bound,
            row.frame_goodput,
            row.frame_bound,
            row.chunks_resent,
            row.runs_rerequested,
            row.identical
        );
        rows.push(row);
    }
    crate::cmd::output::write_bytes(&out.join("link_faults.csv"), csv(&rows).as_bytes())?;
    plot(&out.join("link_faults.svg"), &rows, &a.scene, a.baud)?;
    let json = serde_json::json!({
        "scene": a.scene, "width": width, "height": height, "baud": a.baud, "seed": a.seed,
        "encoding": format!("{:?}", req.encoding), "scene_image_bytes": prepared.image.len(),
        "faults": "flips at BER on the 8 data bits; drops BER/10 per byte; 1..=16-byte bursts BER/100 per byte; both directions",
        "rows": rows,
    });
    std::fs::write(out.join("link_faults.json"), serde_json::to_string_pretty(&json)? + "\n")?;

    println!("\n| BER | upload s | frame s | total s | × clean | line utilisation: upload ↑, frame ↓ | scene image B / line (bound) | frame span B / line (bound) |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {:e} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3}, {:.3} | {:.3} ({:.3}) | {:.3} ({:.3}) |",
            r.ber,
            r.upload_s,
            r.frame_s,
            r.total_s,
            r.total_ratio,
            r.upload_line_utilisation,
            r.frame_line_utilisation,
            r.upload_goodput,
            r.upload_bound,
            r.frame_goodput,
            r.frame_bound
        );
    }
    println!("wrote {}/{{link_faults.csv, link_faults.svg, link_faults.json}}", out.display());
    for r in &rows {
        ensure!(r.identical, "BER {:e}: the frame differs from the clean run's", r.ber);
    }
    for (ber, limit) in [1e-4, 1e-3].into_iter().zip(a.max_ratio.iter().copied()) {
        if let Some(r) = rows.iter().find(|r| r.ber == ber).filter(|_| limit > 0.0) {
            ensure!(r.total_ratio <= limit, "BER {ber:e}: {:.2}× the clean time (limit {limit}×)", r.total_ratio);
        }
    }
    Ok(())
}

fn plot(path: &Path, rows: &[FaultRow], scene: &str, baud: u32) -> anyhow::Result<()> {
    use plotters::prelude::*;
    // BER 0 is drawn at 1e-7 on the log axis.
    let x = |b: f64| if b > 0.0 { b } else { 1e-7 };
    // The compact upload's goodput (decoded bytes) may pass 1: the axis grows to show it.
    let top = rows.iter().map(|r| r.upload_goodput.max(r.frame_goodput)).fold(1.0f64, f64::max) * 1.05;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Goodput on a faulty line, {scene} at {baud} baud (measured vs selective-repeat bound)"),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((5e-8f64..2e-3f64).log_scale(), 0f64..top)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_label_formatter(&|x| super::plot::short_number(*x))
        .x_desc("bit error rate, both directions (+ drops BER/10, bursts BER/100 per byte; 0 drawn at 1e-7)")
        .y_desc("payload or line bytes / line rate")
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    type Pick = fn(&FaultRow) -> f64;
    let series: [(&str, Pick, RGBColor, bool); 8] = [
        ("line utilisation host → device, upload", |r| r.upload_line_utilisation, GREEN, true),
        ("line utilisation device → host, frame", |r| r.frame_line_utilisation, BLACK, true),
        ("upload (scene image B), measured", |r| r.upload_goodput, BLUE, true),
        ("upload bound, best chunk", |r| r.upload_bound, BLUE, false),
        ("upload bound, chunk in use", |r| r.upload_bound_in_use, CYAN, false),
        ("frame (span B), measured", |r| r.frame_goodput, RED, true),
        ("frame bound, best span", |r| r.frame_bound, RED, false),
        ("frame bound, spans in use", |r| r.frame_bound_in_use, MAGENTA, false),
    ];
    for (name, pick, colour, measured) in series {
        let pts: Vec<(f64, f64)> = rows.iter().map(|r| (x(r.ber), pick(r))).collect();
        let style = if measured { colour.stroke_width(3) } else { colour.stroke_width(1) };
        chart
            .draw_series(LineSeries::new(pts.clone(), style))
            .map_err(|e| anyhow!("{e}"))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        if measured {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled()))).map_err(|e| anyhow!("{e}"))?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}
