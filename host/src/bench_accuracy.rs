//! Accuracy against run time: every intersection kernel in every number format, on bundled
//! scenes, compared with the f64 reference renderer — the library behind
//! `gridrt bench accuracy` (issue 4, seed 002 §5.2).
//!
//! For each scene the grid and PE images are built once and the f64 reference image is
//! rendered once ([`crate::reference`]). Then for each (kernel, number format):
//!
//! 1. **Native frame.** The firmware's own code renders the frame on the host — its camera
//!    (`gridrt_firmware::camera`), 3D-DDA list (`gridrt_firmware::dda`), shading and shadow
//!    rays (`gridrt_firmware::shade`, the device's formulas) — with the co-processor model's
//!    untimed path as the intersector (`Coprocessor::trace_untimed_with_info`), single
//!    threaded. `native_ns_per_ray` = best wall time of `runs` frames / rays traced (primary
//!    and shadow rays sent to the model). The image is compared with the reference:
//!    `psnr_db` (`inf` when identical), `max_pixel_error` (largest channel difference,
//!    0–255) and `hit_mismatch_rate` (pixels whose primary primitive id differs). Because an
//!    8-bit image often cannot tell the formats apart, the geometric error is reported too:
//!    `t_rel_err_mean` / `t_rel_err_max`, the relative error of the primary hit distance
//!    against the exact reference (`gridrt_coproc::exact`, f64) on the same f32 ray, over the
//!    pixels that hit the reference's primitive.
//! 2. **Timed model.** The same frame through the timed path with the GridRT profile costed
//!    for this kernel and format (`TimingProfile::for_kernel`): `model_cycles_per_ray` and
//!    `model_tests_per_ray`. `model_cycles_per_test` is the static per-test cost
//!    (`gridrt_coproc::test_cycles`: op counts × per-format op cycles).
//! 3. **Leaks.** `probes` rays aimed exactly at shared edges and vertices of the scene's
//!    mesh, crossing the surface transversally there; a probe leaks when the kernel hits no
//!    triangle of the disk around its aim point although the exact predicates say the ray
//!    crosses it (`gridrt_coproc::probe`). `leak_rate` = leaks / probes crossing their disk.
//!
//! `fw_instructions_per_ray` is left empty: soft-core instruction counts come from a render
//! of the firmware image under QEMU (`gridrt render --stats`, `instructions_per_primary_ray`),
//! not from this native run. `overflows` counts fixed-point range overflows (tests reported
//! by the model, plus records flagged at load): they are reported, never wrapped.
//!
//! The plot (`write_plot`, SVG) shows, per (kernel, format), the error (top: worst-scene
//! image MSE; bottom: worst-scene mean relative t error) against the native run time (left)
//! and against the modelled co-processor cycles per test (right), Pareto fronts marked.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use gridrt_coproc::exact;
use gridrt_coproc::isect::Triangle as KTriangle;
use gridrt_coproc::probe::{probe, ProbeStats};
use gridrt_coproc::{
    test_cycles, CoprocConfig, Coprocessor, FixedFrame, FslError, Intersector, KernelKind, ListEntry, NumberFormat,
    RayKind, RayResult, Record, TimingProfile, LIST_CAPACITY,
};
use gridrt_firmware::camera::Camera;
use gridrt_firmware::dda::{build_list_in, GridDesc, TraversalList};
use gridrt_firmware::fixed::RayFormat;
use gridrt_firmware::shade::{self, Light, BACKGROUND, DEFAULT_ALBEDO};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::{LightingRecord, Material, MaterialModel};

use crate::camera::RenderSettings;
use crate::compare::compare;
use crate::grid::{build, Grid, GridError, GridParams};
use crate::reference::{render as reference_render, Reference, ReferenceImage, Stages, MISS_ID};
use crate::scene::{self, Mesh, SceneLoadError};

/// The bundled scenes the bench runs by default (in `tests/scenes/`).
pub const DEFAULT_SCENES: [&str; 4] = ["bun_zipper_res4.obj", "suzanne.obj", "teapot.obj", "cornell_box.obj"];

/// Directory of the bundled scenes.
pub fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
}

/// What to run.
#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    /// Scene files (OBJ or PLY).
    pub scenes: Vec<PathBuf>,
    /// Image width (one primary ray per pixel).
    pub width: u16,
    /// Image height.
    pub height: u16,
    /// Kernels.
    pub kernels: Vec<KernelKind>,
    /// Number formats of the co-processor kernels.
    pub formats: Vec<NumberFormat>,
    /// Number format of the firmware's ray generation and DDA.
    pub raygen: RayFormat,
    /// Timed native frames per configuration (the best counts).
    pub runs: u32,
    /// Watertightness probes per configuration.
    pub probes: u32,
    /// PEs of the modelled co-processor.
    pub pes: u16,
    /// Grid resolution multiplier (GridRT Eq. 6.1).
    pub grid_m: f64,
    /// Threads of the reference renderer.
    pub threads: usize,
    /// Seed of the probe rays.
    pub seed: u64,
}

impl AccuracyOptions {
    /// The defaults: the bundled scenes at 160×120, every kernel in every format, f32 ray
    /// generation, 5 timed runs, 20 000 probes, 4 PEs, m = 1.
    pub fn new() -> Self {
        Self {
            scenes: DEFAULT_SCENES.iter().map(|s| scenes_dir().join(s)).collect(),
            width: 160,
            height: 120,
            kernels: KernelKind::ALL.to_vec(),
            formats: NumberFormat::ALL.to_vec(),
            raygen: RayFormat::F32,
            runs: 5,
            probes: 20_000,
            pes: 4,
            grid_m: 1.0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            seed: 0xACC0_2026,
        }
    }
}

impl Default for AccuracyOptions {
    fn default() -> Self {
        Self::new()
    }
}

/// One row of `accuracy.csv`: one (scene, kernel, format).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AccuracyRow {
    /// Scene file name.
    pub scene: String,
    /// Triangles of the scene.
    pub triangles: u32,
    /// Kernel (`--isect` name).
    pub kernel: &'static str,
    /// Number format of the kernel.
    pub format: &'static str,
    /// Number format of the firmware's ray generation and DDA.
    pub raygen: &'static str,
    /// Image size.
    pub width: u16,
    /// Image size.
    pub height: u16,
    /// Rays traced per frame (primary + shadow rays sent to the model).
    pub rays: u64,
    /// Native wall time per traced ray, ns (best of `runs`, single thread).
    pub native_ns_per_ray: f64,
    /// Modelled cycles of one full test on GridRT's PE (static cost model).
    pub model_cycles_per_test: f64,
    /// Modelled co-processor cycles per traced ray (timed model, kernel-costed profile).
    pub model_cycles_per_ray: f64,
    /// Ray–triangle tests per traced ray in the timed model.
    pub model_tests_per_ray: f64,
    /// Soft-core instructions per ray, when known (see the module doc).
    pub fw_instructions_per_ray: Option<f64>,
    /// PSNR against the f64 reference, dB (`None`: identical images).
    pub psnr_db: Option<f64>,
    /// Largest channel difference against the reference (0–255).
    pub max_pixel_error: u8,
    /// Pixels whose primary primitive differs from the reference's, per pixel.
    pub hit_mismatch_rate: f64,
    /// Mean relative error of the primary hit distance against the exact reference.
    pub t_rel_err_mean: f64,
    /// Largest relative error of the primary hit distance against the exact reference.
    pub t_rel_err_max: f64,
    /// Probes that leaked, per probe crossing its disk.
    pub leak_rate: f64,
    /// Leaking probes.
    pub leaks: u64,
    /// Probes shot.
    pub probes: u64,
    /// Fixed-point overflows: tests in the native frame plus records flagged at load.
    pub overflows: u64,
    /// Bytes of the kernel's per-triangle record.
    pub bytes_per_triangle: usize,
    /// Operations of one full test (add + mul + div + cmp).
    pub ops_per_test: u32,
}

/// Why the bench could not run.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// A scene did not load.
    #[error("loading {path}: {source}")]
    Scene {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: SceneLoadError,
    },
    /// Its grid could not be built.
    #[error("building the grid of {scene}: {source}")]
    Grid {
        /// Scene name.
        scene: String,
        /// Why.
        #[source]
        source: GridError,
    },
    /// The camera of the default view was refused.
    #[error("camera of {scene}: {what}")]
    Camera {
        /// Scene name.
        scene: String,
        /// Why.
        what: String,
    },
    /// The co-processor model refused the configuration, a PE image or a ray.
    #[error("co-processor model ({scene}, {kernel}, {format}): {what}")]
    Coproc {
        /// Scene name.
        scene: String,
        /// Kernel name.
        kernel: &'static str,
        /// Format name.
        format: &'static str,
        /// What failed.
        what: String,
    },
    /// Writing an output file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Drawing the plot failed.
    #[error("drawing {path}: {what}")]
    Plot {
        /// The file.
        path: PathBuf,
        /// Why.
        what: String,
    },
}

/// Progress of [`run`], in order: for each scene `Scene`, then one `Row` per configuration.
#[derive(Debug)]
pub enum AccuracyEvent<'a> {
    /// A scene is loaded, its grid built and its reference rendered.
    Scene {
        /// Scene name.
        name: &'a str,
        /// Triangles.
        triangles: u32,
        /// Reference render time, ms.
        reference_ms: f64,
    },
    /// A configuration is done.
    Row(&'a AccuracyRow),
}

/// Runs the bench (module doc). Deterministic except for the timings.
pub fn run(
    opts: &AccuracyOptions,
    progress: &mut dyn FnMut(AccuracyEvent<'_>),
) -> Result<Vec<AccuracyRow>, AccuracyError> {
    let mut rows = Vec::new();
    for path in &opts.scenes {
        let mesh = scene::load_mesh(path).map_err(|source| AccuracyError::Scene { path: path.clone(), source })?;
        let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
        let params = GridParams { m: opts.grid_m, pe_count: opts.pes, pe_mem_words: u32::MAX, ..GridParams::default() };
        let grid = build(&mesh, &params).map_err(|source| AccuracyError::Grid { scene: name.clone(), source })?;
        let settings =
            RenderSettings::default_for(&grid.mesh_bounds).with_size(opts.width, opts.height).with_prim_ids(true);
        let start = Instant::now();
        let shaded = scene::Scene::from_mesh(mesh.clone());
        let reference = reference_render(
            &Reference::new(&shaded, &grid.bounds),
            &settings,
            Stages { shadows: settings.shadows, reflections: false, textures: false, specular: false },
            opts.threads,
        );
        let reference_ms = start.elapsed().as_secs_f64() * 1e3;
        progress(AccuracyEvent::Scene { name: &name, triangles: grid.triangle_count, reference_ms });
        let scene = SceneRun::new(&name, &mesh, &grid, &settings, opts)?;
        let probes = ProbeSet::new(&mesh);
        for &kind in &opts.kernels {
            for &format in &opts.formats {
                let row = scene.row(kind, format, &reference, &probes, opts)?;
                progress(AccuracyEvent::Row(&row));
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// Everything a scene's configurations share.
struct SceneRun<'a> {
    name: &'a str,
    mesh: &'a Mesh,
    grid: &'a Grid,
    materials: &'a [Material],
    camera: Camera,
    light: Light,
    desc: GridDesc,
    diag: f32,
    shadows: bool,
    width: u16,
    height: u16,
}

/// The co-processor as the frame renderer sees it: a query, its result and its fixed-point
/// overflows.
type TraceFn<'t> = dyn FnMut(RayKind, &Ray, f32, &[ListEntry]) -> Result<(RayResult, u64), FslError> + 't;

/// One rendered native frame.
struct Frame {
    rgb: Vec<u8>,
    ids: Vec<u32>,
    /// Pixel index, primary ray and hit distance of every pixel that hit.
    hits: Vec<(usize, Ray, f32)>,
    rays: u64,
    overflows: u64,
}

impl<'a> SceneRun<'a> {
    fn new(
        name: &'a str,
        mesh: &'a Mesh,
        grid: &'a Grid,
        s: &RenderSettings,
        opts: &AccuracyOptions,
    ) -> Result<Self, AccuracyError> {
        let v = Vec3::from_array;
        let c = &s.camera;
        let camera = Camera::new(v(c.eye), v(c.target), v(c.up), c.fov_y_deg, opts.width as u32, opts.height as u32)
            .map_err(|e| AccuracyError::Camera { scene: name.into(), what: format!("{e:?}") })?;
        let desc = GridDesc { min: v(grid.bounds.min), max: v(grid.bounds.max), dims: grid.dims.map(|d| d as u32) };
        Ok(Self {
            name,
            mesh,
            grid,
            materials: &mesh.materials,
            camera,
            light: Light { pos: v(s.light.pos), intensity: s.light.intensity, ambient: s.ambient },
            diag: desc.aabb().diagonal().length(),
            desc,
            shadows: s.shadows,
            width: opts.width,
            height: opts.height,
        })
    }

    fn err(&self, kind: KernelKind, format: NumberFormat, what: String) -> AccuracyError {
        AccuracyError::Coproc { scene: self.name.into(), kernel: kind.name(), format: format.name(), what }
    }

    /// The model loaded with this scene for `kind` in `format` (PE memory sized for the image
    /// and the kernel's record table; GridRT timing costed for the kernel).
    fn coprocessor<'m>(
        &self,
        kind: KernelKind,
        format: NumberFormat,
        backing: &'m mut Vec<u32>,
    ) -> Result<Coprocessor<'m>, AccuracyError> {
        let g = self.grid;
        let words = g
            .pe_images
            .iter()
            .zip(&g.pe_triangles)
            .map(|(img, &t)| kind.pe_words_needed(format, img.len(), t as usize))
            .max()
            .unwrap_or(1)
            .max(1);
        let config = CoprocConfig {
            pe_count: g.pe_count,
            pe_mem_words: u32::try_from(words).map_err(|_| self.err(kind, format, "PE image too large".into()))?,
            max_list: LIST_CAPACITY as u16,
            timing: TimingProfile::GRIDRT.for_kernel(kind, format),
            kernel: kind,
        };
        backing.clear();
        backing.resize(config.required_backing_words(), 0);
        let mut cp = Coprocessor::new(config, backing).map_err(|e| self.err(kind, format, e.to_string()))?;
        let frame = FixedFrame::for_box(g.bounds.min, g.bounds.max, format)
            .ok_or_else(|| self.err(kind, format, "grid box not finite".into()))?;
        cp.set_number_format(format, frame);
        for (pe, img) in g.pe_images.iter().enumerate() {
            cp.load_pe(pe as u8, img).map_err(|e| self.err(kind, format, format!("loading PE {pe}: {e}")))?;
        }
        Ok(cp)
    }

    /// Renders the frame the way the device does (firmware camera, DDA and shading), with
    /// `trace` as the co-processor.
    fn render(&self, raygen: RayFormat, trace: &mut TraceFn<'_>) -> Result<Frame, FslError> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut f = Frame {
            rgb: Vec::with_capacity(3 * w * h),
            ids: Vec::with_capacity(w * h),
            hits: Vec::with_capacity(w * h),
            rays: 0,
            overflows: 0,
        };
        let mut list = TraversalList::new();
        let owners = &self.grid.owners;
        for y in 0..h as u32 {
            for x in 0..w as u32 {
                let ray = self.camera.primary_ray_in(raygen, x, y);
                build_list_in(raygen, &self.desc, owners, &ray, 0.0, f32::INFINITY, &mut list);
                let mut colour = BACKGROUND;
                let mut id = MISS_ID;
                let mut hit_t = None;
                if !list.is_empty() {
                    f.rays += 1;
                    let (r, o) = trace(RayKind::Closest, &ray, f32::INFINITY, &list)?;
                    f.overflows += o;
                    if r.hit {
                        id = r.prim;
                        hit_t = Some(r.t);
                        let albedo = self.materials.get(r.material as usize).map_or(DEFAULT_ALBEDO, |m| m.diffuse);
                        let p = shade::hit_point(&ray, r.t);
                        // GridRT's matte surface, as a mesh scene's materials have (firmware `shade`).
                        let matte = MaterialModel::MATTE;
                        let la = [self.light.ambient; 3];
                        colour = match shade::facing_normal(r.normal, ray.dir) {
                            None => shade::outgoing(&matte, albedo, la, None),
                            Some(n) => {
                                let ndotl = shade::irradiance(&LightingRecord::DEFAULT, n, p, self.light.pos);
                                let mut visible = true;
                                if self.shadows && ndotl > 0.0 {
                                    let sr = shade::shadow_ray(p, n, self.light.pos, self.diag);
                                    build_list_in(raygen, &self.desc, owners, &sr, 0.0, shade::SHADOW_T_MAX, &mut list);
                                    if !list.is_empty() {
                                        f.rays += 1;
                                        let (b, o) = trace(RayKind::Any, &sr, shade::SHADOW_T_MAX, &list)?;
                                        f.overflows += o;
                                        visible = !b.hit;
                                    }
                                }
                                let light = shade::DirectLight {
                                    pos: self.light.pos,
                                    radiance: [self.light.intensity; 3],
                                    specular: false,
                                };
                                let v = (-ray.dir).try_normalize().unwrap_or(n);
                                let direct = (visible && ndotl > 0.0)
                                    .then(|| shade::direct(&matte, n, v, p, &light, ndotl))
                                    .flatten();
                                shade::outgoing(&matte, albedo, la, direct.as_ref())
                            }
                        };
                    }
                }
                f.rgb.extend_from_slice(&shade::to_rgb8(colour));
                f.ids.push(id);
                if let Some(t) = hit_t {
                    f.hits.push((f.ids.len() - 1, ray, t));
                }
            }
        }
        Ok(f)
    }

    /// Mean and largest relative error of the primary hit distances against the exact
    /// reference, over the pixels that hit the reference's primitive.
    fn t_errors(&self, frame: &Frame, reference: &ReferenceImage) -> (f64, f64) {
        let (mut sum, mut max, mut n) = (0.0f64, 0.0f64, 0u64);
        for &(px, ray, t) in &frame.hits {
            let prim = frame.ids[px];
            if reference.prim_ids.get(px) != Some(&prim) {
                continue;
            }
            let Some(tri) = self.mesh.triangles.get(prim as usize) else { continue };
            let t_ref = exact::t_f64(&ray, &tri.v.map(Vec3::from_array));
            if !(t_ref.is_finite() && t_ref > 0.0) {
                continue;
            }
            let e = ((t as f64 - t_ref) / t_ref).abs();
            sum += e;
            max = max.max(e);
            n += 1;
        }
        (sum / n.max(1) as f64, max)
    }

    fn row(
        &self,
        kind: KernelKind,
        format: NumberFormat,
        reference: &ReferenceImage,
        probes: &ProbeSet,
        opts: &AccuracyOptions,
    ) -> Result<AccuracyRow, AccuracyError> {
        let mut backing = Vec::new();
        let mut cp = self.coprocessor(kind, format, &mut backing)?;
        let fail = |e: FslError| self.err(kind, format, format!("ray refused: {e}"));

        // 1. Native frames (untimed model), best of `runs`.
        let mut best = f64::INFINITY;
        let mut frame = None;
        for _ in 0..opts.runs.max(1) {
            let start = Instant::now();
            let f = self
                .render(opts.raygen, &mut |k, r, t, l| {
                    cp.trace_untimed_with_info(k, r, t, l).map(|(r, i)| (r, i.overflows))
                })
                .map_err(fail)?;
            best = best.min(start.elapsed().as_secs_f64());
            frame = Some(std::hint::black_box(f));
        }
        let frame = frame.ok_or_else(|| self.err(kind, format, "no frame".into()))?;

        // 2. Timed model.
        cp.reset_stats();
        let before = cp.stats().overflows;
        self.render(opts.raygen, &mut |k, r, t, l| cp.trace(k, r, t, l).map(|r| (r, 0))).map_err(fail)?;
        let stats = *cp.stats();
        debug_assert_eq!(stats.overflows - before, frame.overflows);
        let overflow_records = {
            // Records flagged at load: reload into a fresh model to read the load counters.
            let mut b2 = Vec::new();
            let cp2 = self.coprocessor(kind, format, &mut b2)?;
            cp2.stats().overflow_records
        };

        // 3. Image against the reference.
        let cmp = compare(&frame.rgb, &reference.rgb, Some(&frame.ids), Some(&reference.prim_ids))
            .map_err(|e| self.err(kind, format, e.to_string()))?;
        let pixels = (self.width as u64 * self.height as u64).max(1);
        let (t_mean, t_max) = self.t_errors(&frame, reference);

        // 4. Watertightness probes.
        let frame_box = FixedFrame::for_box(self.grid.bounds.min, self.grid.bounds.max, format)
            .ok_or_else(|| self.err(kind, format, "grid box not finite".into()))?;
        let leaks = probes.run(&Intersector::new(kind, format, frame_box), opts.probes, opts.seed);

        let rays = frame.rays.max(1);
        let ops = kind.ops(format);
        Ok(AccuracyRow {
            scene: self.name.into(),
            triangles: self.grid.triangle_count,
            kernel: kind.name(),
            format: format.name(),
            raygen: opts.raygen.name(),
            width: self.width,
            height: self.height,
            rays: frame.rays,
            native_ns_per_ray: best * 1e9 / rays as f64,
            model_cycles_per_test: test_cycles(kind, format),
            model_cycles_per_ray: stats.cycles as f64 / rays as f64,
            model_tests_per_ray: stats.tests as f64 / rays as f64,
            fw_instructions_per_ray: None,
            psnr_db: cmp.psnr_db,
            max_pixel_error: cmp.max_abs_diff,
            hit_mismatch_rate: cmp.hit_mismatches.unwrap_or(0) as f64 / pixels as f64,
            t_rel_err_mean: t_mean,
            t_rel_err_max: t_max,
            leak_rate: leaks.leak_rate(),
            leaks: leaks.leaks,
            probes: leaks.rays,
            overflows: frame.overflows + overflow_records,
            bytes_per_triangle: kind.bytes_per_triangle(format),
            ops_per_test: ops.total(),
        })
    }
}

// ------------------------------------------------------------ watertightness probes

/// SplitMix64: a tiny seeded generator (the host library has no `rand` dependency).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    fn f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Probe targets of a mesh (same construction as `coproc/tests/stress_watertight.rs`):
/// shared edges whose endpoints both have closed fans, and vertices with closed fans. The
/// mesh is welded by exact vertex position.
struct ProbeSet {
    verts: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    normals: Vec<Vec3>,
    /// Star of every vertex with a closed fan (empty otherwise).
    stars: Vec<Vec<usize>>,
    edges: Vec<(u32, u32)>,
    fan_verts: Vec<u32>,
    edge_len: f32,
}

impl ProbeSet {
    fn new(mesh: &Mesh) -> Self {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut verts = Vec::new();
        let mut faces = Vec::with_capacity(mesh.triangles.len());
        for t in &mesh.triangles {
            let f = t.v.map(|p| {
                *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                    verts.push(Vec3::from_array(p));
                    verts.len() as u32 - 1
                })
            });
            faces.push(f);
        }
        let mut edge_faces: HashMap<(u32, u32), u32> = HashMap::new();
        let mut incident: Vec<Vec<usize>> = vec![Vec::new(); verts.len()];
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *edge_faces.entry((a.min(b), a.max(b))).or_default() += 1;
                incident[f[k] as usize].push(fi);
            }
        }
        let interior = |a: u32, b: u32| edge_faces.get(&(a.min(b), a.max(b))) == Some(&2);
        let mut stars = vec![Vec::new(); verts.len()];
        let mut fan_verts = Vec::new();
        for (v, fs) in incident.iter().enumerate() {
            let v = v as u32;
            let closed = !fs.is_empty()
                && fs.iter().all(|&fi| {
                    let f = faces[fi];
                    (0..3).all(|k| {
                        let (a, b) = (f[k], f[(k + 1) % 3]);
                        (a != v && b != v) || interior(a, b)
                    })
                });
            if closed {
                stars[v as usize] = fs.clone();
                fan_verts.push(v);
            }
        }
        let mut edges: Vec<(u32, u32)> = edge_faces
            .iter()
            .filter(|(&(a, b), &n)| n == 2 && !stars[a as usize].is_empty() && !stars[b as usize].is_empty())
            .map(|(&e, _)| e)
            .collect();
        edges.sort_unstable();
        let normals = faces
            .iter()
            .map(|f| {
                let p = f.map(|i| verts[i as usize]);
                (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
            })
            .collect();
        let total: f32 = edges.iter().map(|&(a, b)| (verts[a as usize] - verts[b as usize]).length()).sum();
        let edge_len = total / edges.len().max(1) as f32;
        Self { verts, faces, normals, stars, edges, fan_verts, edge_len }
    }

    /// One probe: a ray through a random point of a shared edge (70 %) or exactly at a vertex
    /// (30 %), from 0.5–4 edge lengths off the surface on either side within 30° of the local
    /// normal, kept only if every face of its disk faces it with |cos| ≥ 0.1 (a height field
    /// along the ray: crossed exactly once). `None` when the mesh has no probe targets.
    fn ray(&self, rng: &mut Rng) -> Option<(Ray, Vec<usize>)> {
        if self.edges.is_empty() && self.fan_verts.is_empty() {
            return None;
        }
        for _ in 0..1000 {
            let (target, mut disk) = if !self.edges.is_empty() && (self.fan_verts.is_empty() || rng.f32(0.0, 1.0) < 0.7)
            {
                let (a, b) = self.edges[rng.below(self.edges.len())];
                let (pa, pb) = (self.verts[a as usize], self.verts[b as usize]);
                let mut disk = self.stars[a as usize].clone();
                disk.extend_from_slice(&self.stars[b as usize]);
                (pa + (pb - pa) * rng.f32(0.0, 1.0), disk)
            } else {
                let v = self.fan_verts[rng.below(self.fan_verts.len())];
                (self.verts[v as usize], self.stars[v as usize].clone())
            };
            disk.sort_unstable();
            disk.dedup();
            let n = disk.iter().map(|&f| self.normals[f]).sum::<Vec3>().normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            let h = rng.f32(0.5, 4.0) * self.edge_len;
            let side = if rng.f32(0.0, 1.0) < 0.5 { 1.0 } else { -1.0 };
            let any = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
            let (t1, t2) = (n.cross(any).normalize(), n.cross(n.cross(any)).normalize());
            let ang = rng.f32(0.0, std::f32::consts::TAU);
            let r = rng.f32(0.0, 0.577) * h;
            let origin = target + n * (side * h) + (t1 * ang.cos() + t2 * ang.sin()) * r;
            let ray = Ray { origin, dir: target - origin };
            let d = ray.dir.normalize_or_zero();
            let ok_pos = disk.iter().all(|&f| self.normals[f].dot(d) >= 0.1);
            let ok_neg = disk.iter().all(|&f| self.normals[f].dot(d) <= -0.1);
            if ok_pos || ok_neg {
                return Some((ray, disk));
            }
        }
        None
    }

    /// Probes `n` seeded rays with `is`.
    fn run(&self, is: &Intersector, n: u32, seed: u64) -> ProbeStats {
        let tris: Vec<KTriangle> = self.faces.iter().map(|f| f.map(|i| self.verts[i as usize])).collect();
        let recs: Vec<Record> = tris.iter().map(|t| is.precompute(t)).collect();
        let mut rng = Rng(seed);
        let mut stats = ProbeStats::default();
        let mut fan = Vec::new();
        for _ in 0..n {
            let Some((ray, disk)) = self.ray(&mut rng) else { break };
            fan.clear();
            fan.extend(disk.iter().map(|&f| (tris[f], recs[f])));
            stats.add(probe(is, &fan, &ray));
        }
        stats
    }
}

// ------------------------------------------------------------ outputs

/// CSV header of [`write_csv`].
pub const CSV_HEADER: &str = "scene,triangles,kernel,format,raygen,width,height,rays,native_ns_per_ray,\
model_cycles_per_test,model_cycles_per_ray,model_tests_per_ray,fw_instructions_per_ray,psnr_db,max_pixel_error,\
hit_mismatch_rate,t_rel_err_mean,t_rel_err_max,leak_rate,leaks,probes,overflows,bytes_per_triangle,ops_per_test";

/// The rows as CSV text (one header line, one line per row; empty fields for unknown values;
/// `psnr_db` is `inf` for an image identical to the reference).
pub fn to_csv(rows: &[AccuracyRow]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    let opt = |v: Option<f64>, prec: usize| v.map_or(String::new(), |v| format!("{v:.prec$}"));
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{:.1},{:.1},{:.1},{:.2},{},{},{},{:.6},{:.3e},{:.3e},{:.6},{},{},{},{},{}",
            r.scene,
            r.triangles,
            r.kernel,
            r.format,
            r.raygen,
            r.width,
            r.height,
            r.rays,
            r.native_ns_per_ray,
            r.model_cycles_per_test,
            r.model_cycles_per_ray,
            r.model_tests_per_ray,
            opt(r.fw_instructions_per_ray, 1),
            r.psnr_db.map_or("inf".into(), |p| format!("{p:.2}")),
            r.max_pixel_error,
            r.hit_mismatch_rate,
            r.t_rel_err_mean,
            r.t_rel_err_max,
            r.leak_rate,
            r.leaks,
            r.probes,
            r.overflows,
            r.bytes_per_triangle,
            r.ops_per_test
        );
    }
    s
}

/// Writes [`to_csv`] to `path`.
pub fn write_csv(rows: &[AccuracyRow], path: &Path) -> Result<(), AccuracyError> {
    std::fs::write(path, to_csv(rows)).map_err(|source| AccuracyError::Io { path: path.into(), source })
}

/// One (kernel, format) summarised over the scenes: mean native ns/ray, modelled cycles per
/// test, and the worst scene's error as an MSE (from its PSNR; identical images count as a
/// small floor so they stay on a log axis).
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Kernel name.
    pub kernel: &'static str,
    /// Format name.
    pub format: &'static str,
    /// Mean native ns per ray over the scenes.
    pub ns_per_ray: f64,
    /// Modelled cycles per test.
    pub cycles_per_test: f64,
    /// Worst (lowest) PSNR over the scenes, dB (`None` if every image was identical).
    pub worst_psnr_db: Option<f64>,
    /// Worst-scene MSE (255² · 10^(−PSNR/10)), floored at 10⁻⁴.
    pub worst_mse: f64,
    /// Total leaks over the scenes, per probe.
    pub leak_rate: f64,
    /// Worst scene's mean relative t error (floored at 10⁻¹⁰ for the log axis).
    pub worst_t_err: f64,
}

/// MSE floor for identical images on the plot's log axis.
const MSE_FLOOR: f64 = 1e-4;
/// Floor of the t error on the plot's log axis.
const T_ERR_FLOOR: f64 = 1e-10;

/// Summaries per (kernel, format), in first-seen order.
pub fn summarize(rows: &[AccuracyRow]) -> Vec<Summary> {
    let mut out: Vec<(Summary, u32, u64, u64)> = Vec::new();
    for r in rows {
        let mse = r.psnr_db.map_or(MSE_FLOOR, |p| (255.0f64 * 255.0 * 10f64.powf(-p / 10.0)).max(MSE_FLOOR));
        match out.iter_mut().find(|(s, ..)| s.kernel == r.kernel && s.format == r.format) {
            Some((s, n, leaks, probes)) => {
                s.ns_per_ray += r.native_ns_per_ray;
                s.worst_mse = s.worst_mse.max(mse);
                s.worst_t_err = s.worst_t_err.max(r.t_rel_err_mean.max(T_ERR_FLOOR));
                s.worst_psnr_db = match (s.worst_psnr_db, r.psnr_db) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                *n += 1;
                *leaks += r.leaks;
                *probes += r.probes;
            }
            None => out.push((
                Summary {
                    kernel: r.kernel,
                    format: r.format,
                    ns_per_ray: r.native_ns_per_ray,
                    cycles_per_test: r.model_cycles_per_test,
                    worst_psnr_db: r.psnr_db,
                    worst_mse: mse,
                    leak_rate: 0.0,
                    worst_t_err: r.t_rel_err_mean.max(T_ERR_FLOOR),
                },
                1,
                r.leaks,
                r.probes,
            )),
        }
    }
    out.into_iter()
        .map(|(mut s, n, leaks, probes)| {
            s.ns_per_ray /= n as f64;
            s.leak_rate = leaks as f64 / probes.max(1) as f64;
            s
        })
        .collect()
}

/// Indices of the Pareto-optimal points when both coordinates are minimised (a point is on
/// the front unless another is at least as good in both and better in one), sorted by x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let (xi, yi) = points[i];
            !points.iter().any(|&(x, y)| x <= xi && y <= yi && (x < xi || y < yi))
        })
        .collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    front
}

/// Draws the run-time/error plot (SVG), one point per (kernel, format) (colour: kernel;
/// marker: ● f32, ▲ fixed64-q23, ✕ fixed32-q16), Pareto front drawn and its points ringed:
/// top row the worst scene's image MSE against the reference, bottom row the worst scene's
/// mean relative t error; left column against native ns per ray, right column against the
/// modelled GridRT PE cycles per test.
pub fn write_plot(rows: &[AccuracyRow], path: &Path) -> Result<(), AccuracyError> {
    use plotters::prelude::*;
    let perr = |e: &dyn std::fmt::Display| AccuracyError::Plot { path: path.into(), what: e.to_string() };
    let sums = summarize(rows);
    if sums.is_empty() {
        return Err(perr(&"no rows"));
    }
    let root = SVGBackend::new(path, (1400, 1200)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| perr(&e))?;
    let areas = root.split_evenly((2, 2));
    let palette = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
    ];
    let colour =
        |k: &str| KernelKind::ALL.iter().position(|x| x.name() == k).map_or(BLACK, |i| palette[i % palette.len()]);
    let short = |s: &Summary| {
        let k = match s.kernel {
            "watertight" => "WT",
            "moller-trumbore" => "MT",
            "wald" => "Wald",
            "hanika-keller" => "HK",
            "cramer" => "Cr",
            other => other,
        };
        let f = match s.format {
            "f32" => "f32",
            "fixed64-q23" => "q23",
            "fixed32-q16" => "q16",
            other => other,
        };
        format!("{k}/{f}")
    };
    type Axis = fn(&Summary) -> f64;
    let x_ns: Axis = |s| s.ns_per_ray;
    let x_cyc: Axis = |s| s.cycles_per_test;
    let y_mse: Axis = |s| s.worst_mse;
    let y_t: Axis = |s| s.worst_t_err;
    let panels: [(Axis, Axis, &str, &str, &str); 4] = [
        (
            x_ns,
            y_mse,
            "Image error vs native run time",
            "native ns per ray (single thread, log)",
            "worst-scene MSE vs f64 reference (log; 1e-4 = identical)",
        ),
        (
            x_cyc,
            y_mse,
            "Image error vs modelled co-processor cost",
            "modelled GridRT PE cycles per test (log)",
            "worst-scene MSE vs f64 reference (log; 1e-4 = identical)",
        ),
        (
            x_ns,
            y_t,
            "Hit-distance error vs native run time",
            "native ns per ray (single thread, log)",
            "worst-scene mean relative t error vs exact (log)",
        ),
        (
            x_cyc,
            y_t,
            "Hit-distance error vs modelled co-processor cost",
            "modelled GridRT PE cycles per test (log)",
            "worst-scene mean relative t error vs exact (log)",
        ),
    ];
    for (area, (x_of, y_of, title, xlabel, ylabel)) in areas.iter().zip(panels) {
        let pts: Vec<(f64, f64)> = sums.iter().map(|s| (x_of(s), y_of(s))).collect();
        let range = |v: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
            (lo / 1.5, (hi * 1.5).max(lo * 3.0))
        };
        let (x0, x1) = range(&mut pts.iter().map(|p| p.0));
        let (y0, y1) = range(&mut pts.iter().map(|p| p.1));
        // Head room above the highest point for the legend.
        let y1 = y1 * 4.0;
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc(ylabel)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| perr(&e))?;
        let front = pareto_front(&pts);
        chart
            .draw_series(LineSeries::new(front.iter().map(|&i| pts[i]), BLACK.stroke_width(2)))
            .map_err(|e| perr(&e))?
            .label("Pareto front (lower-left is better)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(front.iter().map(|&i| Circle::new(pts[i], 11, BLACK.stroke_width(1))))
            .map_err(|e| perr(&e))?;
        for (s, &p) in sums.iter().zip(&pts) {
            let c = colour(s.kernel);
            let marker: DynElement<_, _> = match s.format {
                "f32" => Circle::new(p, 5, c.filled()).into_dyn(),
                "fixed64-q23" => TriangleMarker::new(p, 7, c.filled()).into_dyn(),
                _ => Cross::new(p, 6, c.stroke_width(3)).into_dyn(),
            };
            chart.draw_series(std::iter::once(marker)).map_err(|e| perr(&e))?;
            let label = EmptyElement::at(p) + Text::new(short(s), (8, -4), ("sans-serif", 11).into_font().color(&c));
            chart.draw_series(std::iter::once(label)).map_err(|e| perr(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()
            .map_err(|e| perr(&e))?;
    }
    root.present().map_err(|e| perr(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_non_dominated_points() {
        let pts = [(1.0, 5.0), (2.0, 2.0), (3.0, 3.0), (4.0, 1.0), (2.0, 2.0), (0.5, 9.0)];
        // (3, 3) is dominated by (2, 2); the duplicate (2, 2) points do not dominate each other.
        assert_eq!(pareto_front(&pts), vec![5, 0, 1, 4, 3]);
    }

    /// A small end-to-end run: the cornell box (few triangles) at 32×24, two configurations.
    #[test]
    fn bench_runs_on_a_small_scene_and_writes_csv_and_svg() {
        let mut opts = AccuracyOptions::new();
        opts.scenes = vec![scenes_dir().join("cornell_box.obj")];
        opts.width = 32;
        opts.height = 24;
        opts.kernels = vec![KernelKind::Watertight, KernelKind::HanikaKeller];
        opts.formats = vec![NumberFormat::F32, NumberFormat::Fixed32Q16];
        opts.runs = 1;
        opts.probes = 500;
        opts.threads = 1;
        let mut events = 0;
        let rows = run(&opts, &mut |_| events += 1).unwrap();
        assert_eq!(rows.len(), 4);
        assert_eq!(events, 5);
        let wt = &rows[0];
        assert_eq!((wt.kernel, wt.format, wt.leaks, wt.overflows), ("watertight", "f32", 0, 0));
        assert!(wt.psnr_db.is_none_or(|p| p > 40.0), "{wt:?}");
        assert!(wt.probes > 0 && wt.rays > 0 && wt.native_ns_per_ray > 0.0);
        let csv = to_csv(&rows);
        assert_eq!(csv.lines().count(), 5);
        assert_eq!(csv.lines().next().unwrap().split(',').count(), csv.lines().nth(1).unwrap().split(',').count());
        let dir = std::env::temp_dir().join(format!("gridrt-accuracy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write_csv(&rows, &dir.join("accuracy.csv")).unwrap();
        write_plot(&rows, &dir.join("accuracy.svg")).unwrap();
        let svg = std::fs::read_to_string(dir.join("accuracy.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("Pareto front"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
