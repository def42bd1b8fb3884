//! One scene's measurements per (kernel, format): the native frame against the reference, the
//! timed model, and the watertightness probes.

use std::time::Instant;

use gridrt_coproc::exact;
use gridrt_coproc::{
    test_cycles, CoprocConfig, Coprocessor, FixedFrame, FslError, Intersector, KernelKind, ListEntry, NumberFormat,
    RayKind, RayResult, TimingProfile, LIST_CAPACITY,
};
use gridrt_firmware::camera::Camera;
use gridrt_firmware::dda::{build_list_in, GridDesc, TraversalList};
use gridrt_firmware::fixed::RayFormat;
use gridrt_firmware::shade::{self, Light, BACKGROUND, DEFAULT_ALBEDO};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::{LightingRecord, Material, MaterialModel};

use super::options::AccuracyOptions;
use super::probes::ProbeSet;
use super::row::{AccuracyError, AccuracyRow};
use crate::compare::compare;
use crate::grid::Grid;
use crate::reference::{ReferenceImage, MISS_ID};
use crate::render_settings::RenderSettings;
use crate::scene::Mesh;

/// Everything a scene's configurations share.
pub(super) struct SceneRun<'a> {
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
    pub(super) fn new(
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

    pub(super) fn row(
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
