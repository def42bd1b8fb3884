//! `gridrt bench rays`: primary-ray throughput of the native path, optionally beside Embree.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{anyhow, bail, Context};
use gridrt_coproc::{CoprocConfig, Coprocessor, KernelKind, RayKind, TimingProfile, LIST_CAPACITY};
use gridrt_firmware::camera::Camera;
use gridrt_firmware::dda::{build_list, TraversalList};
use gridrt_host::grid::{build, GridParams};
use gridrt_host::native::{grid_desc, Hits, NativeScene, Trace};
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::stats::BenchReport;
use gridrt_shared::math::Vec3;
use serde::Serialize;

use crate::cmd::common::SceneOptions;

/// Which implementation traces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RayPath {
    /// The fast native path (`gridrt_host::native`): same result words as the model.
    Native,
    /// The firmware's list builder and the co-processor model's `trace_untimed`, ray by ray
    /// (any kernel).
    Model,
}

#[derive(Debug, clap::Args)]
pub struct Args {
    #[clap(flatten)]
    scene: SceneOptions,
    /// Image width (one primary ray per pixel).
    #[arg(long, default_value_t = 1024)]
    width: u16,
    /// Image height.
    #[arg(long, default_value_t = 1024)]
    height: u16,
    /// Intersection kernel (the native path runs the default, watertight; others imply
    /// `--path model`).
    #[arg(long, value_enum, default_value_t = crate::cmd::common::Kernel::Watertight)]
    kernel: crate::cmd::common::Kernel,
    /// Implementation to time.
    #[arg(long, value_enum, default_value_t = RayPath::Native)]
    path: RayPath,
    /// Threads (rayon). With N > 1 the single-thread rate is measured too and the speed-up
    /// reported.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=256))]
    threads: u32,
    /// Skip the untimed pass that checks every pixel's result words against the
    /// co-processor model (native path only).
    #[arg(long)]
    no_verify: bool,
    /// Also trace the same camera rays with Embree 3 (single thread, same process, same
    /// runs) and report the ratio and the hit agreement. Needs a build with `--features
    /// embree` (Debian: `apt-get install libembree-dev`).
    #[arg(long)]
    vs_embree: bool,
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

/// The JSON report: the common bench fields plus the native path's and Embree's.
#[derive(Debug, Serialize)]
struct RaysReport {
    #[serde(flatten)]
    base: BenchReport,
    /// `native-avx2`, `native-portable` or `model`.
    path: String,
    /// Ray–triangle tests the PEs perform per frame.
    tests: u64,
    /// Every pixel's result words were checked equal to the co-processor model's.
    verified_against_model: bool,
    /// Single-thread rate (also measured when `threads` > 1).
    single_thread_mrays_per_s: f64,
    /// `mrays_per_s / single_thread_mrays_per_s`.
    thread_speedup: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    embree: Option<EmbreeReport>,
}

#[derive(Debug, Serialize)]
struct EmbreeReport {
    version: String,
    best_ms: f64,
    median_ms: f64,
    mrays_per_s: f64,
    hits: u64,
    /// Pixels where both hit or both miss.
    hit_agreement: u64,
    /// Pixels where both hit the same primitive.
    same_prim: u64,
    /// gridrt's single-thread rate over Embree's (both single thread).
    ratio: f64,
}

/// Best and median seconds of a pass and its totals.
#[derive(Debug, Clone, Copy)]
struct Timed {
    best: f64,
    median: f64,
    totals: Hits,
}

/// A timed pass over the frame; returns its totals (equal in every run).
type Pass<'a> = Box<dyn FnMut() -> anyhow::Result<Hits> + 'a>;

/// Best and median time of each pass and its totals. The passes run interleaved — warm-up
/// rounds, then `runs` rounds of each pass in turn — so that load from elsewhere on the
/// machine touches all of them alike.
fn time_interleaved(
    warmup: u32,
    runs: u32,
    passes: &mut [&mut dyn FnMut() -> anyhow::Result<Hits>],
) -> anyhow::Result<Vec<Timed>> {
    for _ in 0..warmup {
        for p in passes.iter_mut() {
            p()?;
        }
    }
    let mut times = vec![Vec::new(); passes.len()];
    let mut last: Vec<Option<Hits>> = vec![None; passes.len()];
    for _ in 0..runs.max(1) {
        for (i, p) in passes.iter_mut().enumerate() {
            let start = Instant::now();
            let o = std::hint::black_box(p()?);
            times[i].push(start.elapsed().as_secs_f64());
            if last[i].is_some_and(|l| l != o) {
                bail!("runs disagree: the path is not deterministic");
            }
            last[i] = Some(o);
        }
    }
    times
        .into_iter()
        .zip(last)
        .map(|(mut t, o)| {
            t.sort_by(f64::total_cmp);
            Ok(Timed { best: t[0], median: t[t.len() / 2], totals: o.ok_or_else(|| anyhow!("no run"))? })
        })
        .collect()
}

impl Args {
    /// Runs the bench.
    pub fn run(self) -> anyhow::Result<()> {
        let scene = self.scene.load()?;
        // The bench has no device: size each PE memory to the largest image unless given.
        let params = GridParams {
            m: self.scene.grid.grid_m,
            pe_count: self.scene.pes,
            pe_mem_words: self.scene.pe_mem_words.unwrap_or(u32::MAX),
            mapping: self.scene.mapping.into(),
            dims_override: None,
            max_voxels: self.scene.grid.grid_max_voxels,
        };
        let grid = build(&scene.mesh, &params).context("building the grid")?;
        let kernel: KernelKind = self.kernel.into();
        let path = if kernel == KernelKind::Watertight { self.path } else { RayPath::Model };
        let pe_mem_words = self.scene.pe_mem_words.unwrap_or(grid.max_pe_words().max(1) as u32);
        let config = CoprocConfig {
            pe_count: grid.pe_count,
            pe_mem_words,
            max_list: LIST_CAPACITY as u16,
            timing: TimingProfile::GRIDRT,
            kernel,
        };
        let mut backing = vec![0u32; config.required_backing_words()];
        let mut coproc =
            Coprocessor::new(config, &mut backing).map_err(|e| anyhow!("co-processor configuration: {e}"))?;
        for (pe, words) in grid.pe_images.iter().enumerate() {
            coproc.load_pe(pe as u8, words).map_err(|e| anyhow!("loading PE {pe}: {e}"))?;
        }
        let coproc = &coproc;

        let (w, h) = (self.width as u32, self.height as u32);
        let settings = RenderSettings::default_for(&grid.mesh_bounds).with_size(self.width, self.height);
        let c = &settings.camera;
        let camera =
            Camera::new(Vec3::from_array(c.eye), Vec3::from_array(c.target), Vec3::from_array(c.up), c.fov_y_deg, w, h)
                .map_err(|e| anyhow!("camera: {e:?}"))?;
        let desc = grid_desc(&grid);
        let owners = &grid.owners;

        // The model, ray by ray (also the reference of the verification pass).
        let model_pixel = |x: u32, y: u32, list: &mut TraversalList| -> anyhow::Result<Trace> {
            let ray = camera.primary_ray(x, y);
            build_list(&desc, owners, &ray, 0.0, f32::INFINITY, list);
            if list.is_empty() {
                return Ok(Trace::Culled);
            }
            coproc
                .trace_untimed(RayKind::Closest, &ray, f32::INFINITY, list)
                .map(Trace::Result)
                .map_err(|e| anyhow!("co-processor model refused the ray of pixel ({x}, {y}): {e}"))
        };
        let model_rows = |rows: std::ops::Range<u32>| -> anyhow::Result<Hits> {
            let mut list = TraversalList::new();
            let mut hits = Hits::default();
            for y in rows {
                for x in 0..w {
                    hits.add(&model_pixel(x, y, &mut list)?);
                }
            }
            Ok(hits)
        };

        let native = match path {
            RayPath::Native => Some(NativeScene::from_grid(&grid).context("laying out the native scene")?),
            RayPath::Model => None,
        };
        let path_name = match &native {
            Some(n) if n.uses_avx2() => "native-avx2",
            Some(_) => "native-portable",
            None => "model",
        };
        let mut verified = false;
        if let (Some(n), false) = (&native, self.no_verify) {
            let mut list = TraversalList::new();
            let mut row = Vec::with_capacity(w as usize);
            let frame = n.frame(&camera, w, h);
            for y in 0..h {
                row.clear();
                n.trace_row(&frame, y, &mut row);
                for (x, got) in row.iter().enumerate() {
                    let want = model_pixel(x as u32, y, &mut list)?;
                    if !same_words(got, &want) {
                        bail!(
                            "native path differs from the co-processor model at pixel ({x}, {y}): {got:?} vs {want:?}"
                        );
                    }
                }
            }
            verified = true;
        }

        let pool = |threads: u32| -> anyhow::Result<Option<rayon::ThreadPool>> {
            if threads <= 1 {
                return Ok(None);
            }
            Ok(Some(rayon::ThreadPoolBuilder::new().num_threads(threads as usize).build()?))
        };
        let frame = native.as_ref().map(|n| n.frame(&camera, w, h));
        let pass = |threads: u32| -> anyhow::Result<Pass<'_>> {
            let pool = pool(threads)?;
            let (native, frame, model_rows) = (&native, &frame, &model_rows);
            Ok(Box::new(move || match (native.as_ref().zip(frame.as_ref()), &pool) {
                (Some((n, f)), p) => Ok(n.count_frame(f, p.as_ref())),
                (None, None) => model_rows(0..h),
                (None, Some(p)) => p.install(|| {
                    use rayon::prelude::*;
                    (0..h)
                        .into_par_iter()
                        .map(|y| model_rows(y..y + 1))
                        .try_reduce(Hits::default, |a, b| Ok(a.merge(b)))
                }),
            }))
        };
        let mut passes = vec![pass(self.threads)?];
        if self.threads > 1 {
            passes.push(pass(1)?);
        }
        let (timed, embree) = if self.vs_embree {
            let (timed, e) = self.embree(native.as_ref(), &grid, &camera, passes)?;
            (timed, Some(e))
        } else {
            let mut refs: Vec<&mut dyn FnMut() -> anyhow::Result<Hits>> =
                passes.iter_mut().map(|p| &mut **p as &mut dyn FnMut() -> anyhow::Result<Hits>).collect();
            (time_interleaved(self.warmup, self.runs, &mut refs)?, None)
        };
        let Timed { best, median, totals: o } = timed[0];
        let single = timed.get(1).map_or(best, |t| t.best);
        let rays = w as u64 * h as u64;
        let rate = |s: f64| rays as f64 / s / 1e6;
        let embree = embree.map(|mut e| {
            e.ratio = rate(single) / e.mrays_per_s;
            e
        });

        let report = RaysReport {
            base: BenchReport {
                scene: self.scene.scene.display().to_string(),
                triangles: grid.triangle_count,
                grid: grid.dims,
                pe_count: grid.pe_count,
                width: self.width,
                height: self.height,
                rays,
                hits: o.hits,
                culled: o.culled,
                runs: self.runs.max(1),
                warmup: self.warmup,
                best_ms: best * 1e3,
                median_ms: median * 1e3,
                ns_per_ray: best * 1e9 / rays as f64,
                mrays_per_s: rate(best),
                threads: self.threads,
            },
            path: path_name.into(),
            tests: o.tests,
            verified_against_model: verified,
            single_thread_mrays_per_s: rate(single),
            thread_speedup: single / best,
            embree,
        };
        self.print(&report);
        if let Some(path) = &self.json {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            }
            std::fs::write(path, serde_json::to_string_pretty(&report)? + "\n")
                .with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }

    fn print(&self, r: &RaysReport) {
        let b = &r.base;
        println!(
            "{}: {} triangles, grid {}×{}×{}, {} PEs, {}×{} primary rays ({} hits, {} culled, {} tests)",
            b.scene,
            b.triangles,
            b.grid[0],
            b.grid[1],
            b.grid[2],
            b.pe_count,
            b.width,
            b.height,
            b.hits,
            b.culled,
            r.tests
        );
        println!(
            "{}: best {:.2} ms, median {:.2} ms of {} runs: {:.2} Mrays/s, {:.1} ns/ray ({} thread{}){}",
            r.path,
            b.best_ms,
            b.median_ms,
            b.runs,
            b.mrays_per_s,
            b.ns_per_ray,
            b.threads,
            if b.threads == 1 { "" } else { "s" },
            if r.verified_against_model { "; every pixel's result words equal the model's" } else { "" }
        );
        if b.threads > 1 {
            println!("single thread: {:.2} Mrays/s; speed-up {:.2}×", r.single_thread_mrays_per_s, r.thread_speedup);
        }
        if let Some(e) = &r.embree {
            println!(
                "Embree {}: best {:.2} ms, median {:.2} ms: {:.2} Mrays/s (1 thread), {} hits; \
                 hit/miss agree on {} of {} pixels, same primitive on {} of {} hits",
                e.version, e.best_ms, e.median_ms, e.mrays_per_s, e.hits, e.hit_agreement, b.rays, e.same_prim, b.hits
            );
            println!("gridrt / Embree (single thread): {:.3}×", e.ratio);
        }
    }

    /// Times `passes` and Embree on the same camera rays, interleaved; Embree's report has
    /// its ratio filled in by the caller.
    #[cfg(feature = "embree")]
    fn embree(
        &self,
        native: Option<&NativeScene>,
        grid: &gridrt_host::grid::Grid,
        camera: &Camera,
        mut passes: Vec<Pass<'_>>,
    ) -> anyhow::Result<(Vec<Timed>, EmbreeReport)> {
        use gridrt_host::native::embree::with_scene;
        let owned;
        let native = match native {
            Some(n) => n,
            None => {
                owned = NativeScene::from_grid(grid)?;
                &owned
            }
        };
        let (w, h) = (self.width as u32, self.height as u32);
        let ours: Vec<Trace> = {
            let frame = native.frame(camera, w, h);
            let mut v = Vec::with_capacity(w as usize * h as usize);
            for y in 0..h {
                native.trace_row(&frame, y, &mut v);
            }
            v
        };
        let (timed, theirs, version) = with_scene(&native.triangles(), |emb| {
            let mut theirs = || Ok(Hits { hits: emb.count_frame(camera, w, h), ..Hits::default() });
            let mut refs: Vec<&mut dyn FnMut() -> anyhow::Result<Hits>> =
                passes.iter_mut().map(|p| &mut **p as &mut dyn FnMut() -> anyhow::Result<Hits>).collect();
            refs.push(&mut theirs);
            let timed = time_interleaved(self.warmup, self.runs, &mut refs);
            (timed, emb.trace_frame(camera, w, h), emb.version())
        })
        .context("building the Embree scene")?;
        let mut timed = timed?;
        let Timed { best, median, totals: e } = timed.pop().ok_or_else(|| anyhow!("no Embree run"))?;
        let mut hit_agreement = 0;
        let mut same_prim = 0;
        for (a, b) in ours.iter().zip(&theirs) {
            let ours_hit = matches!(a, Trace::Result(r) if r.hit);
            if ours_hit == b.is_some() {
                hit_agreement += 1;
            }
            if let (Trace::Result(r), Some(p)) = (a, b) {
                same_prim += (r.hit && r.prim == *p) as u64;
            }
        }
        let report = EmbreeReport {
            version,
            best_ms: best * 1e3,
            median_ms: median * 1e3,
            mrays_per_s: w as f64 * h as f64 / best / 1e6,
            hits: e.hits,
            hit_agreement,
            same_prim,
            ratio: 0.0,
        };
        Ok((timed, report))
    }

    #[cfg(not(feature = "embree"))]
    fn embree(
        &self,
        _: Option<&NativeScene>,
        _: &gridrt_host::grid::Grid,
        _: &Camera,
        _: Vec<Pass<'_>>,
    ) -> anyhow::Result<(Vec<Timed>, EmbreeReport)> {
        bail!(
            "--vs-embree needs a gridrt built with `--features embree` (Embree 3; Debian: apt-get install libembree-dev)"
        )
    }
}

/// Same answer word for word (culled on both sides, or the same 8 result words).
fn same_words(a: &Trace, b: &Trace) -> bool {
    match (a, b) {
        (Trace::Culled, Trace::Culled) => true,
        (Trace::Result(a), Trace::Result(b)) => a.to_words() == b.to_words(),
        _ => false,
    }
}
