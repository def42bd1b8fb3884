//! `gridrt bench`: benchmarks of the native ray path.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{anyhow, Context};
use gridrt_coproc::{CoprocConfig, Coprocessor, RayKind, TimingProfile, LIST_CAPACITY};
use gridrt_firmware::camera::Camera;
use gridrt_firmware::dda::{build_list, GridDesc, TraversalList};
use gridrt_host::camera::RenderSettings;
use gridrt_host::grid::{build, GridParams};
use gridrt_host::stats::BenchReport;
use gridrt_shared::math::Vec3;

use super::common::SceneOptions;

/// Benchmarks.
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Primary rays through the native path, single-threaded: firmware camera → firmware
    /// 3D-DDA list → co-processor model `trace_untimed` on the loaded PE images (no cycle
    /// model, no UART, no shading). Reports the best of --runs after --warmup runs.
    Rays(RaysArgs),
    /// Accuracy against run time of every intersection kernel and number format.
    Accuracy(super::bench_accuracy::Args),
    /// What the pipeline plan and row interpolation save: rays, FSL words and modeled time
    /// with and without each skip, traced pixels vs PSNR over (l, EPS), and the ViRAY-like
    /// demo at 1920×1080 (CSV, SVG plot and JSON in --out).
    Skip(super::bench_skip::Args),
    /// The UART link (issue 6): wire bytes per frame, payload efficiency against the line
    /// rate and compression per pixel encoding on the bundled scenes, modelled frame time
    /// with transmission overlapped with ray work at 115 200 / 921 600 / 3 000 000 baud, on
    /// 1, 2 and 4 boards (CSV, SVG plot and JSON in --out).
    Link(super::bench_link::Args),
    /// Seed 001's point splats (issue 15): native splats/s and image error against the
    /// ray-traced disks for 10³…10⁶ points and several shape tables, optionally soft-core
    /// instructions per splat from QEMU (`--port`); CSV, SVG plot and JSON in --out.
    Splat(super::bench_splat::Args),
}

#[derive(Debug, clap::Args)]
struct RaysArgs {
    #[clap(flatten)]
    scene: SceneOptions,
    /// Image width (one primary ray per pixel).
    #[arg(long, default_value_t = 1024)]
    width: u16,
    /// Image height.
    #[arg(long, default_value_t = 1024)]
    height: u16,
    /// Intersection kernel.
    #[arg(long, value_enum, default_value_t = super::common::Kernel::Watertight)]
    kernel: super::common::Kernel,
    /// Untimed warm-up runs.
    #[arg(long, default_value_t = 1)]
    warmup: u32,
    /// Timed runs (the best one is reported).
    #[arg(long, default_value_t = 5)]
    runs: u32,
    /// Write the report as JSON here.
    #[arg(long, value_name = "JSON")]
    json: Option<PathBuf>,
}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
        match self.what {
            What::Rays(args) => args.run(),
            What::Accuracy(a) => a.run(),
            What::Skip(a) => a.run(),
            What::Link(a) => a.run(),
            What::Splat(a) => a.run(),
        }
    }
}

struct Outcome {
    hits: u64,
    culled: u64,
    checksum: u64,
}

impl RaysArgs {
    fn run(self) -> anyhow::Result<()> {
        let mesh = self.scene.load()?;
        // The bench has no device: size each PE memory to the largest image unless given.
        let params = GridParams {
            m: self.scene.grid_m,
            pe_count: self.scene.pes,
            pe_mem_words: self.scene.pe_mem_words.unwrap_or(u32::MAX),
            mapping: self.scene.mapping.into(),
            dims_override: None,
        };
        let grid = build(&mesh.mesh, &params).context("building the grid")?;
        let pe_mem_words = self.scene.pe_mem_words.unwrap_or(grid.max_pe_words().max(1) as u32);
        let config = CoprocConfig {
            pe_count: grid.pe_count,
            pe_mem_words,
            max_list: LIST_CAPACITY as u16,
            timing: TimingProfile::GRIDRT,
            kernel: self.kernel.into(),
        };
        let mut backing = vec![0u32; config.required_backing_words()];
        let mut coproc =
            Coprocessor::new(config, &mut backing).map_err(|e| anyhow!("co-processor configuration: {e}"))?;
        for (pe, words) in grid.pe_images.iter().enumerate() {
            coproc.load_pe(pe as u8, words).map_err(|e| anyhow!("loading PE {pe}: {e}"))?;
        }

        let settings = RenderSettings::default_for(&grid.mesh_bounds).with_size(self.width, self.height);
        let c = &settings.camera;
        let camera = Camera::new(
            Vec3::from_array(c.eye),
            Vec3::from_array(c.target),
            Vec3::from_array(c.up),
            c.fov_y_deg,
            self.width as u32,
            self.height as u32,
        )
        .map_err(|e| anyhow!("camera: {e:?}"))?;
        let desc = GridDesc {
            min: Vec3::from_array(grid.bounds.min),
            max: Vec3::from_array(grid.bounds.max),
            dims: grid.dims.map(|d| d as u32),
        };

        // One pass over the image; errors from the model abort the bench.
        let owners = &grid.owners;
        let coproc = &coproc;
        let pass = || -> anyhow::Result<Outcome> {
            let mut list = TraversalList::new();
            let mut out = Outcome { hits: 0, culled: 0, checksum: 0 };
            for y in 0..self.height as u32 {
                for x in 0..self.width as u32 {
                    let ray = camera.primary_ray(x, y);
                    build_list(&desc, owners, &ray, 0.0, f32::INFINITY, &mut list);
                    if list.is_empty() {
                        out.culled += 1;
                        continue;
                    }
                    let r = coproc
                        .trace_untimed(RayKind::Closest, &ray, f32::INFINITY, &list)
                        .map_err(|e| anyhow!("co-processor model refused the ray of pixel ({x}, {y}): {e}"))?;
                    if r.hit {
                        out.hits += 1;
                        out.checksum = out.checksum.wrapping_add(r.prim as u64);
                    }
                }
            }
            Ok(std::hint::black_box(out))
        };

        for _ in 0..self.warmup {
            pass()?;
        }
        let runs = self.runs.max(1);
        let mut times = Vec::with_capacity(runs as usize);
        let mut last = None;
        for _ in 0..runs {
            let start = Instant::now();
            let o = pass()?;
            times.push(start.elapsed().as_secs_f64());
            if let Some(prev) = &last {
                let prev: &Outcome = prev;
                if prev.checksum != o.checksum || prev.hits != o.hits {
                    return Err(anyhow!("runs disagree: the native path is not deterministic"));
                }
            }
            last = Some(o);
        }
        let o = last.ok_or_else(|| anyhow!("no run"))?;
        times.sort_by(f64::total_cmp);
        let best = times[0];
        let median = times[times.len() / 2];
        let rays = self.width as u64 * self.height as u64;
        let report = BenchReport {
            scene: self.scene.scene.display().to_string(),
            triangles: grid.triangle_count,
            grid: grid.dims,
            pe_count: grid.pe_count,
            width: self.width,
            height: self.height,
            rays,
            hits: o.hits,
            culled: o.culled,
            runs,
            warmup: self.warmup,
            best_ms: best * 1e3,
            median_ms: median * 1e3,
            ns_per_ray: best * 1e9 / rays as f64,
            mrays_per_s: rays as f64 / best / 1e6,
            threads: 1,
        };
        println!(
            "{}: {} triangles, grid {}×{}×{}, {} PEs, {}×{} primary rays ({} hits, {} culled)",
            report.scene,
            report.triangles,
            report.grid[0],
            report.grid[1],
            report.grid[2],
            report.pe_count,
            report.width,
            report.height,
            report.hits,
            report.culled
        );
        println!(
            "best {:.2} ms, median {:.2} ms of {} runs: {:.2} Mrays/s, {:.1} ns/ray (single thread)",
            report.best_ms, report.median_ms, report.runs, report.mrays_per_s, report.ns_per_ray
        );
        if let Some(path) = &self.json {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            }
            std::fs::write(path, serde_json::to_string_pretty(&report)? + "\n")
                .with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }
}
