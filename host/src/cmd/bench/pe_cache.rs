//! `gridrt bench pe-cache`: sizes a per-PE cache for PE images kept in SDRAM (model:
//! [`gridrt_host::bench::pe_cache`]). Renders one frame per scene through the co-processor
//! model with the RTL's kernel, format and timing, records every PE's memory reads, and
//! replays them through each cache size × line × ways.
//!
//! Outputs in `--out-dir DIR`: `pe-cache.csv`, `pe-cache.json` and `pe-cache.svg` (hit rate
//! against cache size, one panel per scene, one line per line size × ways).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, ensure, Context};
use gridrt_host::bench::pe_cache::{
    self, board, kind_name, replay, row, trace_frame, words_needed, CacheConfig, CacheRow, MissModel, KINDS,
};
use gridrt_host::grid::GridParams;
use gridrt_host::plan::Plan;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::msg::RenderRequest;

/// Arguments.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
What is measured and what is modelled:
  measured  the hit rates: the model's PE-memory reads of a whole frame (camera and shadow rays,
            the RTL's order: voxel-table probes, ref words, 10-word records, the winner's words)
            replayed through an LRU cache per PE, cold at the frame's start
  modelled  cycles per ray = the `rtl` profile's cycles + misses per ray × miss penalty, with
            penalty = --miss-latency + line bytes ÷ --beat-bytes (LiteDRAM's GENSDRPHY on the
            ULX3S's 16-bit SDRAM at 50 MHz; see `MissModel` in host/src/bench/pe_cache.rs);
            `overlapped` counts only the busiest PE's misses of each ray
  block RAMs: DP16KD (18 kbit) per PE: data in 4 banks of 32 bits, tags + valid + LRU per set

Example:
  gridrt bench pe-cache --scene tests/scenes/bun_zipper_res4.obj --scene tests/scenes/stanford-bunny.obj --out-dir out/pe-cache")]
pub struct Args {
    /// Output directory (created).
    #[arg(long = "out-dir", value_name = "DIR")]
    out: PathBuf,
    /// Scenes, one trace each (repeat the flag) [default: the bundled bun_zipper_res4.obj].
    #[arg(long = "scene", value_name = "PATH")]
    scenes: Vec<PathBuf>,
    /// Frame width.
    #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u16).range(1..=4096))]
    width: u16,
    /// Frame height.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u16).range(1..=4096))]
    height: u16,
    /// Processing elements (each with its own cache).
    #[arg(long, default_value_t = 4, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=255))]
    pes: u16,
    /// Words of each PE's (external) memory: the image and the 10-word record table must fit.
    #[arg(long, default_value_t = 1 << 20, value_name = "W", value_parser = clap::value_parser!(u32).range(1..=1 << 24))]
    pe_mem_words: u32,
    /// The grid's resolution.
    #[command(flatten)]
    grid: crate::cmd::common::GridResolution,
    /// Cache sizes per PE, KiB (powers of two).
    #[arg(long, value_delimiter = ',', default_value = "2,4,8,16,32", value_name = "KIB", value_parser = clap::value_parser!(u32).range(1..=1 << 16))]
    sizes: Vec<u32>,
    /// Line sizes, bytes (powers of two, ≥ 4).
    #[arg(long, value_delimiter = ',', default_value = "16,32,64", value_name = "BYTES", value_parser = clap::value_parser!(u32).range(4..=4096))]
    lines: Vec<u32>,
    /// Associativities (1 = direct-mapped; LRU within a set).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4", value_name = "WAYS", value_parser = clap::value_parser!(u32).range(1..=64))]
    ways: Vec<u32>,
    /// Modelled cycles (50 MHz) from a miss to the line's first SDRAM beat.
    #[arg(long, default_value_t = MissModel::LITEDRAM_ULX3S.latency, value_name = "CYCLES")]
    miss_latency: u32,
    /// Bytes per SDRAM beat, one beat per cycle (the ULX3S's SDRAM is 16 bits wide).
    #[arg(long, default_value_t = MissModel::LITEDRAM_ULX3S.bytes_per_cycle, value_name = "BYTES", value_parser = clap::value_parser!(u32).range(1..=64))]
    beat_bytes: u32,
}

/// What one scene's trace was.
#[derive(Debug, serde::Serialize)]
struct SceneFacts {
    scene: String,
    triangles: u32,
    grid: [u16; 3],
    /// The fullest PE's image and record table, words.
    pe_words_needed: usize,
    coproc_rays: u64,
    tests: u64,
    rtl_cycles_per_ray: f64,
    reads_per_pe: Vec<usize>,
    /// Per kind: (reads, words).
    reads_by_kind: Vec<(String, u64, u64)>,
    trace_s: f64,
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        crate::cmd::output::check_dir(&self.out, "--out-dir")?;
        let configs = self.configs()?;
        let model = MissModel { latency: self.miss_latency, bytes_per_cycle: self.beat_bytes };
        let bundled;
        let scenes = if self.scenes.is_empty() {
            bundled = crate::cmd::scenes::Bundled::extract()?;
            vec![bundled.join("bun_zipper_res4.obj")]
        } else {
            self.scenes.clone()
        };
        for s in &scenes {
            ensure!(s.is_file(), "--scene {}: no such file", s.display());
        }
        let config = board(self.pes, self.pe_mem_words);
        let mut rows: Vec<CacheRow> = Vec::new();
        let mut facts = Vec::new();
        for path in &scenes {
            let name =
                path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
            let loaded = gridrt_host::scene::load(path).with_context(|| format!("loading {}", path.display()))?;
            let params = GridParams {
                pe_count: self.pes,
                pe_mem_words: self.pe_mem_words,
                m: self.grid.grid_m,
                max_voxels: self.grid.grid_max_voxels,
                ..GridParams::default()
            };
            let prepared = PreparedScene::new(loaded, &params).with_context(|| {
                format!("{name}: building the grid for {} PEs of {} words", self.pes, self.pe_mem_words)
            })?;
            let need = words_needed(&prepared, &config);
            if need > self.pe_mem_words as usize {
                bail!("{name}: its fullest PE needs {need} words with the 10-word records; pass --pe-mem-words {need} or more");
            }
            let plan = Plan::derive(&prepared.scene);
            let settings = prepared.scene.settings.with_size(self.width, self.height).with_shadows(plan.shadows);
            let mut req: RenderRequest = settings.to_request(1);
            req.flags |= plan.flags();
            eprintln!(
                "{name}: tracing a {}×{} frame ({} triangles, {} PEs, fullest PE {need} words) …",
                self.width, self.height, prepared.grid.triangle_count, self.pes
            );
            let start = Instant::now();
            let (_, trace) =
                trace_frame(&prepared, &req, config).with_context(|| format!("{name}: tracing the frame"))?;
            let trace_s = start.elapsed().as_secs_f64();
            let rtl = trace.cycles as f64 / trace.rays.max(1) as f64;
            eprintln!(
                "{name}: {} co-processor rays, {:.2} cycles/ray (rtl profile), {} reads in {trace_s:.1} s",
                trace.rays,
                rtl,
                trace.total_reads()
            );
            facts.push(SceneFacts {
                scene: name.clone(),
                triangles: prepared.grid.triangle_count,
                grid: prepared.grid.dims,
                pe_words_needed: need,
                coproc_rays: trace.rays,
                tests: trace.tests,
                rtl_cycles_per_ray: rtl,
                reads_per_pe: (0..self.pes as usize).map(|p| trace.reads_of(p)).collect(),
                reads_by_kind: KINDS
                    .iter()
                    .zip(trace.by_kind())
                    .map(|(&k, (n, w))| (kind_name(k).to_string(), n, w))
                    .collect(),
                trace_s,
            });
            println!(
                "{name} ({}×{}, {} rays, rtl profile {rtl:.2} cycles/ray): hit rate measured, cycles/ray modelled",
                self.width, self.height, trace.rays
            );
            let start = Instant::now();
            let mut scene_rows = Vec::new();
            let tty = std::io::stderr().is_terminal();
            for (i, &c) in configs.iter().enumerate() {
                if tty {
                    eprint!("\r{name}: replaying {}/{} ({}) …\x1b[K", i + 1, configs.len(), c.label());
                }
                scene_rows.push(row(&name, &trace, c, &replay(&trace, c), model));
            }
            let done =
                format!("{name}: {} configurations replayed in {:.1} s", configs.len(), start.elapsed().as_secs_f64());
            if tty {
                eprintln!("\r{done}\x1b[K");
            } else {
                eprintln!("{done}");
            }
            println!(
                "  {:>8} {:>5} {:>6} {:>9} {:>10} {:>8} {:>12} {:>11} {:>9}",
                "size", "line", "ways", "hit rate", "misses/ray", "penalty", "cycles/ray", "overlapped", "DP16KD/PE"
            );
            for r in scene_rows {
                let c = r.cache;
                println!(
                    "  {:>5} KiB {:>3} B {:>6} {:>8.2}% {:>10.2} {:>8} {:>12.2} {:>11.2} {:>9}",
                    c.size_bytes / 1024,
                    c.line_bytes,
                    if c.ways == 1 { "direct".to_string() } else { format!("{}-way", c.ways) },
                    100.0 * r.hit_rate,
                    r.misses_per_ray,
                    r.miss_penalty,
                    r.cycles_per_ray,
                    r.cycles_per_ray_overlapped,
                    r.brams_per_pe
                );
                rows.push(r);
            }
        }
        crate::cmd::output::write_bytes(&self.out.join("pe-cache.csv"), pe_cache::csv(&rows).as_bytes())?;
        plot(&self.out.join("pe-cache.svg"), &rows, self.width, self.height)?;
        let json = serde_json::json!({
            "command": std::env::args().collect::<Vec<_>>().join(" "),
            "width": self.width, "height": self.height, "pes": self.pes, "pe_mem_words": self.pe_mem_words,
            "coproc": "model: watertight, fixed64-q23, timing rtl (the RTL's RESULT words and cycles)",
            "hit_rate": "measured: the model's PE-memory reads of the frame, replayed through a cold LRU cache per PE",
            "miss_model": {
                "latency_cycles": model.latency, "bytes_per_cycle": model.bytes_per_cycle,
                "note": "modelled, not measured: LiteDRAM GENSDRPHY (1:1, CL 2) on the ULX3S's 16-bit SDRAM at 50 MHz; penalty = latency + line bytes / bytes_per_cycle",
            },
            "cycles_per_ray": "modelled: rtl profile cycles + misses per ray × penalty (every miss in turn); cycles_per_ray_overlapped: only the busiest PE's misses of each ray",
            "brams": "DP16KD (18 kbit) per PE: data in 4 banks of 32 bits, tags (tag + valid per way, LRU per set) one row per set, for 32 MiB of SDRAM shared by the PEs",
            "scenes": facts,
            "rows": rows,
        });
        crate::cmd::output::write_bytes(
            &self.out.join("pe-cache.json"),
            (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
        )?;
        println!("wrote {}/{{pe-cache.csv, pe-cache.svg, pe-cache.json}}", self.out.display());
        Ok(())
    }

    /// Every size × line × ways, each checked.
    fn configs(&self) -> anyhow::Result<Vec<CacheConfig>> {
        let mut out = Vec::new();
        for &kib in &self.sizes {
            for &line in &self.lines {
                for &ways in &self.ways {
                    let c = CacheConfig { size_bytes: kib * 1024, line_bytes: line, ways };
                    c.check().map_err(|e| anyhow!("--sizes/--lines/--ways: {e}"))?;
                    out.push(c);
                }
            }
        }
        Ok(out)
    }
}

/// Hit rate against cache size: one panel per scene, a line per line size (colour) × ways
/// (dashed direct-mapped, thin 2-way, thick 4-way and more).
fn plot(path: &Path, rows: &[CacheRow], width: u16, height: u16) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    // x = log₂ KiB, so every size of the sweep gets its tick.
    let kib = |r: &CacheRow| (f64::from(r.cache.size_bytes) / 1024.0).log2();
    let (lo, hi) = rows.iter().fold((f64::MAX, f64::MIN), |(lo, hi), r| (lo.min(kib(r)), hi.max(kib(r))));
    let (lo, hi) = if rows.is_empty() { (0.0, 6.0) } else { (lo - 0.3, hi + 0.3) };
    let floor = rows.iter().map(|r| 100.0 * r.hit_rate).fold(100.0f64, f64::min);
    let bottom = ((floor - 5.0) / 10.0).floor().max(0.0) * 10.0;
    let panel_w = 520u32;
    let root = SVGBackend::new(path, (panel_w * scenes.len().max(1) as u32, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let panels = root.split_evenly((1, scenes.len().max(1)));
    let colours = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
    let mut lines: Vec<u32> = rows.iter().map(|r| r.cache.line_bytes).collect();
    lines.sort_unstable();
    lines.dedup();
    for (scene, panel) in scenes.iter().zip(&panels) {
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{scene}, {width}×{height}: per-PE cache hit rate (measured)"), ("sans-serif", 15))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(lo..hi, bottom..100.5)
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_labels(((hi - lo).ceil() as usize + 1) * 2)
            .x_label_formatter(&|x| {
                if (x - x.round()).abs() < 1e-6 {
                    super::plot::short_number(x.round().exp2())
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|y| format!("{y:.0}"))
            .x_desc("cache per PE, KiB")
            .y_desc("hit rate, %")
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        let mut ways: Vec<u32> = rows.iter().map(|r| r.cache.ways).collect();
        ways.sort_unstable();
        ways.dedup();
        for (k, &line) in lines.iter().enumerate() {
            let colour = colours[k % colours.len()];
            for &w in &ways {
                let pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.scene == *scene && r.cache.line_bytes == line && r.cache.ways == w)
                    .map(|r| (kib(r), 100.0 * r.hit_rate))
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let label = if w == 1 { format!("{line} B, direct (dashed)") } else { format!("{line} B, {w}-way") };
                let style = colour.stroke_width(if w >= 4 { 3 } else { 1 });
                let series = if w == 1 {
                    chart.draw_series(DashedLineSeries::new(pts.clone(), 5, 4, style))
                } else {
                    chart.draw_series(LineSeries::new(pts.clone(), style))
                }
                .map_err(|e| anyhow!("{e}"))?;
                series.label(label).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(|e| anyhow!("{e}"))?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
    }
    root.present().map_err(|e| anyhow!("{e}"))
}
