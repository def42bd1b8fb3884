//! `gridrt bench skip`: what the pipeline plan and row interpolation save.
//!
//! Everything runs on the loopback simulator through the real byte stream. Outputs in
//! `--out-dir DIR`: `skip.csv` (rays, FSL words per ray kind, co-processor cycles and modeled
//! time with each stage on/off, plus the grid-box cull), `interp.csv` and `interp.svg`
//! (traced pixels against PSNR over a grid of (l, EPS)), `viray.json` (the 1920×1080 demo
//! frame: modeled time at ViRAY's 320 MHz and native simulation wall time on every core and on
//! one thread, with the load average at the time).
//!
//! Modeled time, two models:
//! - `viray_model_ms`: rays ÷ ViRAY's throughput (158.29 M rays/s at 320 MHz, seed 000 §5:
//!   4 rays per pixel at 1920×1080 in 52.4 ms). A fixed-function ViRAY pays for 4 rays per
//!   pixel whatever the scene; the plan pays only for the rays it traces.
//! - `coproc_model_ms`: the co-processor model's cycles (pipelined PE profile, one ray in
//!   flight) at 320 MHz.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Context};
use gridrt_coproc::TimingProfile;
use gridrt_host::compare::compare;
use gridrt_host::grid::GridParams;
use gridrt_host::plan::{Interp, Plan};
use gridrt_host::reference::{render as reference_render, Reference, Stages};
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::RenderedFrame;
use gridrt_host::sim_board::SimBoard;
use gridrt_shared::msg::{render_flags, stat};

/// ViRAY's ray throughput (seed 000 §5): 4·1920·1080 rays in 52.4 ms.
pub const VIRAY_RAYS_PER_S: f64 = 4.0 * 1920.0 * 1080.0 / 0.0524;
/// ViRAY's clock.
pub const VIRAY_HZ: f64 = 320e6;
/// ViRAY's frame time at 1920×1080 (the anchor).
pub const VIRAY_FRAME_MS: f64 = 52.4;
/// ViRAY's single-threaded HLS C simulation time per frame (seed 000 §5).
pub const VIRAY_CSIM_S: f64 = 67.6;
/// FSL words a culled ray would cost if it were sent anyway: an 8-word request with an empty
/// list and the 8-word RESULT.
const CULLED_RAY_WORDS: u64 = 16;

/// Arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created).
    #[arg(long = "out-dir", alias = "out", value_name = "DIR")]
    out: PathBuf,
    /// Frame size of the skip table and the interpolation grid.
    #[arg(long, default_value_t = 320)]
    width: u16,
    /// Frame height.
    #[arg(long, default_value_t = 240)]
    height: u16,
    /// Also render the demo at 1920×1080 (a few seconds), on every core and then on one
    /// thread.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    full_hd: bool,
}

fn sim_config() -> gridrt_loopback::SimConfig {
    gridrt_loopback::SimConfig { timing: TimingProfile::PIPELINED, ..gridrt_loopback::SimConfig::default() }
}

fn params() -> GridParams {
    GridParams { pe_count: 4, pe_mem_words: 1 << 20, ..GridParams::default() }
}

struct Row {
    scene: String,
    config: String,
    frame: RenderedFrame,
    psnr: Option<f64>,
    wall_ms: f64,
}

fn g(f: &RenderedFrame, k: u8) -> u64 {
    f.stats.get(&k).copied().unwrap_or(0)
}

fn rays(f: &RenderedFrame) -> u64 {
    g(f, stat::PRIMARY_RAYS) + g(f, stat::SHADOW_RAYS) + g(f, stat::REFLECTION_RAYS)
}

fn coproc_ms(f: &RenderedFrame) -> f64 {
    g(f, stat::COPROC_CYCLES) as f64 / VIRAY_HZ * 1e3
}

fn psnr_of(a: &[u8], b: &[u8]) -> anyhow::Result<Option<f64>> {
    Ok(compare(a, b, None, None)?.psnr_db)
}

fn fmt_psnr(p: Option<f64>) -> String {
    p.map_or_else(|| "inf".to_string(), |v| format!("{v:.2}"))
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        std::fs::create_dir_all(&self.out).with_context(|| format!("creating {}", self.out.display()))?;
        let (w, h) = (self.width, self.height);
        // The bundled scenes travel inside the binary: the bench runs from any folder.
        let bundled = crate::cmd::scenes::Bundled::extract()?;
        let scenes_dir = || bundled.dir().to_path_buf();

        // ---------------------------------------------------------------- skip table
        let demo_path = scenes_dir().join("viray_demo.toml");
        let demo = gridrt_host::scene::load(&demo_path)?;
        let prepared = PreparedScene::new(demo.clone(), &params())?;
        let mut board = SimBoard::new(sim_config(), &prepared)?;
        let settings = demo.settings.with_size(w, h);
        let plan = Plan::derive(&demo);
        let reference = reference_render(&Reference::new(&demo, &prepared.grid.bounds), &settings, Stages::ALL, 2);
        let mut rows: Vec<Row> = Vec::new();
        let variants: [(&str, u16); 5] = [
            ("plan (all stages needed)", 0),
            ("without shadows", render_flags::SHADOWS),
            ("without reflections", render_flags::REFLECTIONS),
            ("without textures", render_flags::TEXTURES),
            ("without specular", render_flags::SPECULAR),
        ];
        for (name, drop) in variants {
            let mut req = settings.with_shadows(plan.shadows).to_request(1);
            req.flags = (req.flags | plan.flags()) & !drop;
            let start = Instant::now();
            let frame = board.render(&req)?;
            let wall_ms = start.elapsed().as_secs_f64() * 1e3;
            eprintln!("skip       viray_demo {w}×{h}, {name}: {} rays in {wall_ms:.0} ms", rays(&frame));
            let psnr = psnr_of(&frame.rgb, &reference.rgb)?;
            rows.push(Row { scene: "viray_demo".into(), config: name.into(), frame, psnr, wall_ms });
        }
        // A scene that needs no light, no reflection, no texture, no specular: the demo's
        // geometry in plain grey without a light; the plan skips every stage. Without the
        // plan (every bit set) the device still finds no light and no reflective material.
        let plain_text = std::fs::read_to_string(&demo_path)?;
        let plain_text = strip_for_plain(&plain_text);
        let plain = gridrt_host::scene::parse_scene_file(&demo_path, &plain_text, &|p| {
            gridrt_host::scene::load_mesh(&scenes_dir().join(p))
        })?;
        let pp = PreparedScene::new(plain.clone(), &params())?;
        let mut pboard = SimBoard::new(sim_config(), &pp)?;
        for (name, flags) in [
            ("plain: plan (nothing needed)", Plan::derive(&plain).flags()),
            ("plain: no skip (all plan bits)", Plan::ALL.flags()),
        ] {
            let mut req = plain.settings.with_size(w, h).to_request(1);
            req.flags = flags;
            let start = Instant::now();
            let frame = pboard.render(&req)?;
            let wall_ms = start.elapsed().as_secs_f64() * 1e3;
            rows.push(Row { scene: "viray_plain".into(), config: name.into(), frame, psnr: None, wall_ms });
        }
        let mut csv = csv::Writer::from_writer(Vec::new());
        csv.write_record("scene,config,plan,primary_rays,shadow_rays,reflection_rays,rays,culled_rays,fsl_words,fsl_words_primary,fsl_words_shadow,fsl_words_reflection,fsl_words_if_culled_were_sent,coproc_cycles,coproc_model_ms_320mhz,viray_model_ms,psnr_db_vs_reference,sim_wall_ms".split(','))?;
        for r in &rows {
            let f = &r.frame;
            let words = g(f, stat::FSL_WORDS_OUT) + g(f, stat::FSL_WORDS_IN);
            csv.write_record([
                r.scene.clone(),
                r.config.clone(),
                format!("{:#06x}", g(f, stat::PLAN)),
                g(f, stat::PRIMARY_RAYS).to_string(),
                g(f, stat::SHADOW_RAYS).to_string(),
                g(f, stat::REFLECTION_RAYS).to_string(),
                rays(f).to_string(),
                g(f, stat::CULLED_RAYS).to_string(),
                words.to_string(),
                g(f, stat::FSL_WORDS_PRIMARY).to_string(),
                g(f, stat::FSL_WORDS_SHADOW).to_string(),
                g(f, stat::FSL_WORDS_REFLECTION).to_string(),
                (words + CULLED_RAY_WORDS * g(f, stat::CULLED_RAYS)).to_string(),
                g(f, stat::COPROC_CYCLES).to_string(),
                format!("{:.3}", coproc_ms(f)),
                format!("{:.3}", rays(f) as f64 / VIRAY_RAYS_PER_S * 1e3),
                fmt_psnr(r.psnr),
                format!("{:.1}", r.wall_ms),
            ])?;
        }
        let csv = csv_text(csv)?;
        crate::cmd::output::write_bytes(&self.out.join("skip.csv"), csv.as_bytes())?;
        println!("skip table ({w}×{h}):\n{csv}");

        // ---------------------------------------------------------------- interpolation grid
        let steps = [1u8, 2, 3, 5, 7];
        let epss = [2u8, 4, 8, 16, 31];
        let mut icsv = csv::Writer::from_writer(Vec::new());
        icsv.write_record(
            "scene,l,eps,mode,traced_pixels,pixels,traced_fraction,rays,rays_saved_fraction,psnr_db_vs_full".split(','),
        )?;
        let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        let meshes = [("bunny", "bun_zipper_res4.obj"), ("teapot", "teapot.obj")];
        let mut boards: Vec<(String, SimBoard, RenderSettings, Option<Plan>)> = Vec::new();
        for (name, file) in meshes {
            let scene = gridrt_host::scene::load(&scenes_dir().join(file))?;
            let p = PreparedScene::new(scene, &params())?;
            let s = RenderSettings::default_for(&p.grid.mesh_bounds).with_size(w, h);
            boards.push((name.into(), SimBoard::new(sim_config(), &p)?, s, None));
        }
        boards.push(("viray_demo".into(), board, settings, Some(plan)));
        for (name, board, s, plan) in &mut boards {
            let base_flags = plan.map_or(render_flags::SHADOWS, |p| p.flags());
            let mut req = s.to_request(1);
            req.flags = base_flags;
            let full = board.render(&req)?;
            let full_rays = rays(&full);
            eprintln!(
                "interp     {name} {}×{}: the (l, EPS) grid, {} frames …",
                s.width,
                s.height,
                steps.len() * (epss.len() + 1)
            );
            let mut pts = Vec::new();
            for &l in &steps {
                for &e in &epss {
                    for adaptive in [false, true] {
                        if adaptive && e != 8 {
                            continue;
                        }
                        let i = Interp { step: l, eps: e, adaptive };
                        req.flags = base_flags | i.flags();
                        let f = board.render(&req)?;
                        let traced = g(&f, stat::PRIMARY_RAYS);
                        let pixels = traced + g(&f, stat::INTERPOLATED_PIXELS);
                        let psnr = psnr_of(&f.rgb, &full.rgb)?;
                        let frac = traced as f64 / pixels.max(1) as f64;
                        icsv.write_record([
                            name.clone(),
                            l.to_string(),
                            e.to_string(),
                            (if adaptive { "adaptive" } else { "fixed" }).to_string(),
                            traced.to_string(),
                            pixels.to_string(),
                            format!("{frac:.4}"),
                            rays(&f).to_string(),
                            format!("{:.4}", 1.0 - rays(&f) as f64 / full_rays.max(1) as f64),
                            fmt_psnr(psnr),
                        ])?;
                        if !adaptive {
                            pts.push((frac, psnr.unwrap_or(99.0).min(99.0)));
                        }
                    }
                }
            }
            series.push((name.clone(), pts));
        }
        let icsv = csv_text(icsv)?;
        crate::cmd::output::write_bytes(&self.out.join("interp.csv"), icsv.as_bytes())?;
        plot(&self.out.join("interp.svg"), &series)?;
        println!("interpolation grid:\n{icsv}");

        // ---------------------------------------------------------------- 1920×1080 demo
        if self.full_hd {
            let (_, board, _, _) = boards.last_mut().ok_or_else(|| anyhow!("no demo board"))?;
            let s = demo.settings.with_size(1920, 1080);
            let mut req = s.to_request(1);
            req.flags = plan.flags();
            eprintln!("full-hd    viray_demo 1920×1080 on every core, then on one thread …");
            let start = Instant::now();
            let f = board.render(&req)?;
            let wall = start.elapsed().as_secs_f64();
            eprintln!("full-hd    {} rays in {wall:.1} s on every core", rays(&f));
            // The same frame on a board that traces on its device thread alone, right after.
            let mut one = SimBoard::new(gridrt_loopback::SimConfig { threads: 1, ..sim_config() }, &prepared)?;
            let start = Instant::now();
            let f1 = one.render(&req)?;
            let wall_one = start.elapsed().as_secs_f64();
            let identical = f1.rgb == f.rgb && f1.stats == f.stats;
            let mut req_i = req;
            req_i.flags |= Interp { step: 3, eps: 8, adaptive: false }.flags();
            let fi = board.render(&req_i)?;
            let psnr_i = psnr_of(&fi.rgb, &f.rgb)?;
            let summary = serde_json::json!({
                "scene": "tests/scenes/viray_demo.toml",
                "width": 1920, "height": 1080,
                "plan": plan.names(),
                "primary_rays": g(&f, stat::PRIMARY_RAYS),
                "shadow_rays": g(&f, stat::SHADOW_RAYS),
                "reflection_rays": g(&f, stat::REFLECTION_RAYS),
                "rays": rays(&f),
                "rays_per_pixel": rays(&f) as f64 / (1920.0 * 1080.0),
                "viray_rays_per_pixel": 4,
                "viray_frame_ms_anchor": VIRAY_FRAME_MS,
                "viray_model_ms": rays(&f) as f64 / VIRAY_RAYS_PER_S * 1e3,
                "coproc_model_ms_320mhz": coproc_ms(&f),
                "native_sim_wall_s": wall,
                "native_sim_threads": rayon::current_num_threads(),
                "native_sim_wall_s_one_thread": wall_one,
                "native_sim_thread_speedup": wall_one / wall,
                "native_sim_identical_to_one_thread": identical,
                "load_average_1min": load_average(),
                "viray_hls_csim_s": VIRAY_CSIM_S,
                "interp_3_8": {
                    "traced_fraction": g(&fi, stat::PRIMARY_RAYS) as f64 / (1920.0 * 1080.0),
                    "rays": rays(&fi),
                    "viray_model_ms": rays(&fi) as f64 / VIRAY_RAYS_PER_S * 1e3,
                    "psnr_db_vs_full": psnr_i,
                },
            });
            crate::cmd::output::write_bytes(
                &self.out.join("viray.json"),
                (serde_json::to_string_pretty(&summary)? + "\n").as_bytes(),
            )?;
            println!("viray demo 1920×1080: {}", serde_json::to_string_pretty(&summary)?);
        }
        Ok(())
    }
}

/// The CSV a writer holds, as text.
fn csv_text(w: csv::Writer<Vec<u8>>) -> anyhow::Result<String> {
    let bytes = w.into_inner().map_err(|e| anyhow!("{e}"))?;
    String::from_utf8(bytes).context("CSV text")
}

/// The 1-minute load average (Linux `/proc/loadavg`), to read wall times against.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// The demo scene without its light, reflections, textures and specular terms.
fn strip_for_plain(text: &str) -> String {
    let mut out = String::new();
    let mut skip_table = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('[') {
            skip_table = t.starts_with("[light]") || t.starts_with("[textures.");
        }
        if skip_table {
            continue;
        }
        let key = t.split('=').next().unwrap_or("").trim();
        if matches!(key, "texture" | "reflection" | "reflectivity" | "specular" | "ks" | "k" | "exponent") {
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn plot(path: &Path, series: &[(String, Vec<(f64, f64)>)]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Row interpolation: traced pixels vs PSNR (grid over l, EPS)", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0f64..1.0f64, 20.0f64..100.0f64)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("traced fraction of pixels")
        .y_desc("PSNR vs full trace (dB, 99 = identical)")
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    let colours = [RED, BLUE, GREEN, MAGENTA];
    for (k, (name, pts)) in series.iter().enumerate() {
        let c = colours[k % colours.len()];
        chart
            .draw_series(pts.iter().map(|&(x, y)| Circle::new((x, y), 4, c.filled())))
            .map_err(|e| anyhow!("{e}"))?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
    }
    super::plot::legend_and_present(&mut chart, &root)
}
