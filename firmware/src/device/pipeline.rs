//! The per-pixel pipeline of a frame: primary ray, shading (`crate::shade`: matte, ViRAY's
//! models, textures), shadow and reflection rays, and row interpolation (`crate::interp`),
//! following the pipeline plan of the request (SPEC.md §3.13).
//!
//! The plan decides what runs: no shadow rays without a light (or with `SHADOWS` clear), no
//! reflection rays without `REFLECTIONS` (the host clears it when no material reflects), no
//! texture stage without `TEXTURES`, no specular term without `SPECULAR`. Shadow rays are
//! any-hit queries; a ray whose list is empty (it misses the grid box or meets only empty
//! voxels) costs no FSL words. A plan bit whose stage is compiled out (cargo features
//! `reflections`, `textures`, `specular`) is refused with `Error{BadRequest}`.
//!
//! A frame without row interpolation may have its rows traced away from the device loop by
//! a [`RowFarm`] (a simulator's threads, `super::farm`): each row's pixels through the same
//! [`pixel`], handed back in order and sent as the device's own loop sends them.

use super::fail::Fail;
use super::raypath::{RayClass, RayPath};
use super::request::{field, Job};
use super::scene::SceneStore;
use super::stats::{count, cycles_between, FrameStats, FrameWriter, Stage, StageClock, Stopwatch};
use crate::camera::{Camera, ColumnTerms, RowRays};
use crate::cull::{BoxSpans, OccupancyMask};
use crate::fsl::FslLink;
use crate::interp::{self, Counts, Sample, StepControl};
use crate::pixels::{FrameTx, SpanEncoder, TxError};
use crate::sfloat::{add, mul, vsub};
use crate::shade::{self, LightFactor, DEFAULT_ALBEDO};
use core::ops::{ControlFlow, Range};
use embedded_io::Write;
use gridrt_shared::fsl::RayKind;
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::msg::{feature, render_flags, ErrorCode, Msg};
#[cfg(feature = "textures")]
use gridrt_shared::scene::{affine_point, TextureKind};
use gridrt_shared::scene::{Falloff, Material, MaterialModel, ReflectMode};

/// The model of a material id the scene does not define.
const MATTE: MaterialModel = MaterialModel::MATTE;

/// Widest row the interpolation buffer holds.
pub const MAX_INTERP_WIDTH: usize = 2048;

/// Per-frame constants of the pixel pipeline.
pub(super) struct FrameCtx {
    cam: Camera,
    /// The camera rays' column terms on a soft-float core (`crate::camera::ColumnTerms`).
    columns: ColumnTerms,
    /// Per row, the columns whose camera rays can enter the grid box.
    spans: BoxSpans,
    /// The image tiles whose camera rays may meet a cell with primitives (`crate::cull`).
    occupancy: OccupancyMask,
    /// What a pixel whose camera ray misses everything gets: the background.
    background: Sample,
    /// The ambient light `L_a` (ambient colour × ambient term).
    ambient: [f32; 3],
    /// The point light as the direct term uses it.
    direct: shade::DirectLight,
    /// The light reaches surfaces at all (a light with a non-zero radiance).
    lit: bool,
    /// The unit spot axis ([`shade::spot_axis`]).
    spot_axis: Option<gridrt_shared::math::Vec3>,
    shadows: bool,
    reflections: bool,
    textures: bool,
    specular: bool,
    /// `1e-4 · |grid box diagonal|`, the per-scene term of the shadow-ray offset.
    eps_diag: f32,
    /// The 8-bit colour of matte camera hits in fixed point, on a soft-float core
    /// (`shade::MatteBytes`; empty elsewhere).
    bytes: shade::MatteBytes,
    /// The light's factor at those hits may be estimated in integers (`shade::light_factor`):
    /// a soft-float core, a light, no falloff, no spot cone.
    estimate_light: bool,
}

impl FrameCtx {
    /// The columns of row `y` within `x0..x1` whose camera rays can enter the grid box (the
    /// others see only the background, `crate::cull`) and the row's camera rays.
    #[inline(always)]
    pub(super) fn row(&self, y: u16, width: u16, x0: u16, x1: u16) -> (Range<u16>, RowRays<'_>) {
        let (lo, hi) = self.spans.row(y, width);
        let lo = lo.clamp(x0, x1);
        let hi = hi.clamp(lo, x1);
        (lo..hi, self.cam.row_with(y as u32, self.columns.terms()))
    }
}

/// The plan bits this build honours.
const fn compiled_plan() -> u16 {
    let r = if cfg!(feature = "reflections") { render_flags::REFLECTIONS } else { 0 };
    let t = if cfg!(feature = "textures") { render_flags::TEXTURES } else { 0 };
    let s = if cfg!(feature = "specular") { render_flags::SPECULAR } else { 0 };
    r | t | s
}

/// Feature bits of the stages in this module.
pub const fn pipeline_features() -> u32 {
    let r = if cfg!(feature = "reflections") { feature::REFLECTIONS } else { 0 };
    let t = if cfg!(feature = "textures") { feature::TEXTURES } else { 0 };
    let s = if cfg!(feature = "specular") { feature::SPECULAR } else { 0 };
    r | t | s | feature::INTERP | feature::ANALYTIC_PRIMITIVES
}

/// The texture-space point of a hit on primitive `prim` (the object table maps prim ids to
/// objects), or `None` when no object holds it.
#[cfg(feature = "textures")]
fn object_point<const N: usize>(scene: &SceneStore<N>, prim: u32, p: Vec3) -> Option<[f32; 3]> {
    let o = scene.objects.iter().find(|o| prim.checked_sub(o.first_prim).is_some_and(|k| k < o.prim_count))?;
    Some(affine_point(&o.world_to_object, p.to_array()))
}

/// One pixel: the path of its primary ray through at most `max_depth` mirror bounces
/// (module doc).
// The arithmetic here is f32 shading on glam vectors, which the lint cannot tell from
// integers; the integer work is the counters (`count`) and the bounce index.
#[allow(clippy::arithmetic_side_effects)]
pub(super) fn pixel<L: FslLink, C: StageClock, const N: usize>(
    path: &mut RayPath<L>,
    scene: &SceneStore<N>,
    clock: &C,
    sw: &mut Stopwatch,
    ctx: &FrameCtx,
    row: &RowRays<'_>,
    x: u16,
) -> Result<Sample, Fail> {
    let lighting = &scene.lighting;
    count(&mut path.stats.primary_rays, 1);
    // A camera ray that can meet only empty cells: its walk would list nothing (culled), its
    // pixel is the background (`crate::cull::OccupancyMask`).
    if !ctx.occupancy.may_hit(x, row.y() as u16) {
        count(&mut path.stats.culled_rays, 1);
        sw.lap(clock, &mut path.stats, Stage::RayGen);
        return Ok(ctx.background);
    }
    let mut ray = row.ray(x as u32);
    sw.lap(clock, &mut path.stats, Stage::RayGen);
    let (la, dl, lit) = (ctx.ambient, &ctx.direct, ctx.lit);
    let depth = if ctx.reflections { lighting.max_depth.max(1) } else { 1 };
    let mut acc = [0f32; 3];
    let mut throughput = 1f32;
    let (mut first_prim, mut first_t) = (interp::MISS, f32::INFINITY);
    for bounce in 0..depth {
        let class = if bounce == 0 { RayClass::Primary } else { RayClass::Reflection };
        let hit = path.trace_as(scene, clock, sw, &ray, RayKind::Closest, f32::INFINITY, class)?;
        let r = match hit {
            Some(r) if r.hit => r,
            // A camera ray that meets nothing is the frame's background, computed once with
            // the same formula (`0 + 1·background`).
            _ if bounce == 0 => {
                sw.lap(clock, &mut path.stats, Stage::Shade);
                return Ok(ctx.background);
            }
            _ => {
                for (a, b) in acc.iter_mut().zip(lighting.background) {
                    *a = add(*a, mul(throughput, b));
                }
                break;
            }
        };
        if bounce == 0 {
            first_prim = r.prim;
            first_t = r.t;
        }
        let p = shade::hit_point(&ray, r.t);
        let m = scene
            .materials
            .get(r.material as usize)
            .copied()
            .unwrap_or(Material { diffuse: DEFAULT_ALBEDO, reflect: 0.0 });
        // By reference: the model is ~90 bytes, a copy per hit is a memcpy call.
        let ext = scene.material_model.get(r.material as usize).unwrap_or(&MATTE);
        #[allow(unused_mut)]
        let mut cd = m.diffuse;
        #[cfg(feature = "textures")]
        if ctx.textures && ext.texture != TextureKind::None {
            if let Some(po) = object_point(scene, r.prim, p) {
                cd = crate::texture::sample(ext, cd, po);
            }
        }
        // On a soft-float core the unit normal of a primitive hit recently comes from the cache.
        let unit = if cfg!(soft_float) {
            path.normals.unit(r.prim, r.normal).map(|n| shade::facing(n, ray.dir))
        } else {
            shade::facing_normal(r.normal, ray.dir)
        };
        let Some(n) = unit else {
            // Degenerate normal: no direction to light it from; ambient only.
            for (a, b) in acc.iter_mut().zip(shade::outgoing(ext, cd, la, None)) {
                *a += throughput * b;
            }
            break;
        };
        if bounce == 0 && ctx.estimate_light && ctx.bytes.covers(r.material) {
            if let Some(rgb) = matte_camera_hit(path, scene, clock, sw, ctx, (p, n), &m, ext, r.material)? {
                sw.lap(clock, &mut path.stats, Stage::Shade);
                return Ok(Sample { rgb, prim: r.prim, t: r.t });
            }
        }
        // The unit view vector, computed only for the models that read it.
        let view = || crate::fmath::try_normalize(-ray.dir).unwrap_or(n);
        let mut direct = None;
        // The light's factor `spot·E` at a hit it reaches, +0 elsewhere (`shade::MatteBytes`).
        let mut e_seen = 0.0;
        if lit {
            let (e, l) = shade::irradiance_toward(lighting, n, p, dl.pos);
            let spot = if e > 0.0 { shade::spot_factor_on(lighting, ctx.spot_axis, dl.pos, p) } else { 0.0 };
            // E > 0 has a light vector.
            if let (true, Some(l)) = (e > 0.0 && spot > 0.0, l) {
                let visible = if ctx.shadows {
                    count(&mut path.stats.shadow_rays, 1);
                    let sr = shade::shadow_ray_from(p, n, dl.pos, ctx.eps_diag);
                    sw.lap(clock, &mut path.stats, Stage::Shade);
                    let blocker =
                        path.trace_as(scene, clock, sw, &sr, RayKind::Any, shade::SHADOW_T_MAX, RayClass::Shadow)?;
                    !blocker.is_some_and(|b| b.hit)
                } else {
                    true
                };
                if visible {
                    e_seen = mul(e, spot);
                    // A camera hit whose bytes the fixed-point rule gives (it ends the path: no
                    // reflection for its material): the f32 rule's bytes without its arithmetic.
                    if bounce == 0 {
                        if let Some(rgb) = ctx.bytes.rgb(r.material, e_seen) {
                            sw.lap(clock, &mut path.stats, Stage::Shade);
                            return Ok(Sample { rgb, prim: r.prim, t: r.t });
                        }
                    }
                    let v = if shade::direct_reads_view(ext, dl) { view() } else { n };
                    direct = Some(shade::direct_toward(ext, n, v, l, dl, e_seen));
                }
            }
        }
        if bounce == 0 && direct.is_none() {
            if let Some(rgb) = ctx.bytes.rgb(r.material, e_seen) {
                sw.lap(clock, &mut path.stats, Stage::Shade);
                return Ok(Sample { rgb, prim: r.prim, t: r.t });
            }
        }
        for (a, b) in acc.iter_mut().zip(shade::outgoing(ext, cd, la, direct.as_ref())) {
            *a = add(*a, mul(throughput, b));
        }
        sw.lap(clock, &mut path.stats, Stage::Shade);
        if bounce.wrapping_add(1) == depth || ext.reflect_mode == ReflectMode::None {
            break;
        }
        let refl = shade::reflectance(ext, m.reflect, n.dot(view()));
        if refl.is_nan() || refl <= 0.0 {
            break;
        }
        throughput *= refl;
        count(&mut path.stats.reflection_rays, 1);
        let origin = p + n * shade::shadow_epsilon_from(ctx.eps_diag, p);
        ray = Ray { origin, dir: ray.dir - n * (2.0 * ray.dir.dot(n)) };
    }
    let rgb = shade::to_rgb8(acc);
    sw.lap(clock, &mut path.stats, Stage::Shade);
    Ok(Sample { rgb, prim: first_prim, t: first_t })
}

/// The bytes of a camera hit at `p` with unit normal `n` on a material with a fixed-point
/// rule (`shade::MatteBytes`), under an omnidirectional light without falloff: the light's
/// factor estimated in integers (`shade::light_factor`), the shadow ray where it is positive,
/// the rule, and the f32 rule within the rule's margin of a byte boundary. The same shadow
/// rays and bytes as [`pixel`]'s f32 path; `None` (nothing traced) when the estimate cannot
/// tell the factor's sign.
#[allow(clippy::too_many_arguments)]
fn matte_camera_hit<L: FslLink, C: StageClock, const N: usize>(
    path: &mut RayPath<L>,
    scene: &SceneStore<N>,
    clock: &C,
    sw: &mut Stopwatch,
    ctx: &FrameCtx,
    (p, n): (Vec3, Vec3),
    m: &Material,
    ext: &MaterialModel,
    material: u16,
) -> Result<Option<[u8; 3]>, Fail> {
    let dl = &ctx.direct;
    let e30 = match shade::light_factor(n, vsub(dl.pos, p)) {
        LightFactor::Unsure => return Ok(None),
        LightFactor::Unlit => 0,
        LightFactor::Lit(e30) => e30,
    };
    let visible = e30 > 0
        && (!ctx.shadows || {
            count(&mut path.stats.shadow_rays, 1);
            let sr = shade::shadow_ray_from(p, n, dl.pos, ctx.eps_diag);
            sw.lap(clock, &mut path.stats, Stage::Shade);
            let blocker = path.trace_as(scene, clock, sw, &sr, RayKind::Any, shade::SHADOW_T_MAX, RayClass::Shadow)?;
            !blocker.is_some_and(|b| b.hit)
        });
    if let Some(rgb) = ctx.bytes.rgb_q30(material, if visible { e30 } else { 0 }, visible) {
        return Ok(Some(rgb));
    }
    // Within the margin of a byte boundary: `pixel`'s f32 rule with the visibility known (the
    // f32 factor is positive where the estimate is; matte without specular reads no view
    // vector; an omnidirectional light's spot factor is 1).
    let direct = if visible {
        let (e, l) = shade::irradiance_toward(&scene.lighting, n, p, dl.pos);
        l.map(|l| shade::direct_toward(ext, n, n, l, dl, mul(e, 1.0)))
    } else {
        None
    };
    Ok(Some(shade::to_rgb8(shade::outgoing(ext, m.diffuse, ctx.ambient, direct.as_ref()))))
}

/// Refuses a plan that names a stage missing from `compiled` (the build's plan bits).
pub(super) fn check_plan(flags: u16, compiled: u16) -> Result<(), &'static str> {
    let missing = flags & (render_flags::REFLECTIONS | render_flags::TEXTURES | render_flags::SPECULAR) & !compiled;
    if missing & render_flags::TEXTURES != 0 {
        return Err(
            "the scene needs textures but this firmware was built without the texture stage (feature `textures`)",
        );
    }
    if missing & render_flags::REFLECTIONS != 0 {
        return Err("the scene needs reflections but this firmware was built without the reflection stage (feature `reflections`)");
    }
    if missing & render_flags::SPECULAR != 0 {
        return Err("the scene needs specular highlights but this firmware was built without the specular stage (feature `specular`)");
    }
    Ok(())
}

/// The rows of one frame a [`RowFarm`] is asked to trace: the region's rows, each over the
/// columns its camera rays can enter the grid box through ([`Rows::columns`]).
pub struct Rows<'a, const N: usize> {
    pub(super) scene: &'a SceneStore<N>,
    pub(super) ctx: &'a FrameCtx,
    /// Image width (the culling spans depend on it).
    pub(super) width: u16,
    pub(super) x0: u16,
    pub(super) x1: u16,
    pub(super) ys: Range<u16>,
    pub(super) polls: u32,
}

impl<const N: usize> Rows<'_, N> {
    /// The rows, top to bottom.
    pub fn ys(&self) -> Range<u16> {
        self.ys.clone()
    }

    /// Most samples a row has (the region's width).
    pub fn width(&self) -> usize {
        self.x1.wrapping_sub(self.x0) as usize
    }

    /// The columns of row `y` that are traced; the rest of the region's row is background.
    pub fn columns(&self, y: u16) -> Range<u16> {
        self.ctx.row(y, self.width, self.x0, self.x1).0
    }
}

/// A pixel of a row failed: the frame stops there, as it does in the device loop.
#[derive(Debug, Clone, Copy)]
pub struct RowFault {
    /// Samples of the row done before the failing pixel.
    pub(super) done: usize,
    pub(super) fail: Fail,
}

impl RowFault {
    /// Samples of the row done before the failing pixel.
    pub fn done(&self) -> usize {
        self.done
    }
}

/// One traced row, handed to the device.
pub struct RowDone<'s> {
    /// The row.
    pub y: u16,
    /// The samples of its [`Rows::columns`] (all of them unless `fault`).
    pub samples: &'s [Sample],
    /// The failure that stopped the row, if any.
    pub fault: Option<RowFault>,
    /// What tracing the row counted (`RowTracer::take_stats` after it).
    pub stats: FrameStats,
}

/// Traces the rows of a frame for the device, possibly on other threads.
pub trait RowFarm<L> {
    /// Traces every row of `rows` and hands each to `sink` in order, top to bottom; stops
    /// after a row with a fault or when `sink` breaks. Returns `false` without calling `sink`
    /// when it does not take this frame (e.g. `link` is not one it can share): the device
    /// then renders the frame on `link` itself.
    fn render<const N: usize>(
        &mut self,
        link: &L,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool;
}

/// The frame-rendering half of the device: the ray path, the stage clock, the span encoder,
/// the row buffer of the interpolation and the row farm.
pub(super) struct Renderer<L, C, F> {
    /// The co-processor link, traversal list and frame counters.
    pub(super) path: RayPath<L>,
    clock: C,
    spans: SpanEncoder,
    /// Row buffer of the row interpolation.
    row: [Sample; MAX_INTERP_WIDTH],
    farm: F,
}

impl<L: FslLink, C: StageClock, F: RowFarm<L>> Renderer<L, C, F> {
    /// The stage clock (the splat path times its stages with it too).
    #[cfg(feature = "splats")]
    pub(super) fn clock(&self) -> &C {
        &self.clock
    }

    /// A renderer over `link`, timed by `clock`, with rows traced by `farm` when it takes
    /// them.
    pub(super) fn new(link: L, clock: C, farm: F) -> Self {
        Self {
            path: RayPath::new(link),
            clock,
            spans: SpanEncoder::new(),
            row: [Sample::default(); MAX_INTERP_WIDTH],
            farm,
        }
    }

    /// Renders `job` and sends its spans and `Stats` through `tx`; returns (spans, CRC of the
    /// decoded pixels). On `Err` the frame stopped: nothing more is to be sent for it but the
    /// report of the failure.
    pub(super) fn frame<const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(u32, u32), Fail> {
        let req = job.req;
        self.path.stats = FrameStats::default();
        let prim_ids = req.flags & render_flags::PRIM_IDS != 0 && !job.crc_only;
        if job.span_bytes {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, 0);
            self.spans.set_data_limit(job.max_span);
        } else {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, job.max_span);
        }
        self.spans.set_silent(job.crc_only);
        let excluded = self.clock.excluded();
        let arrival = self.clock.now();
        let mut wire = FrameWriter::new(out, self.clock.clone());
        self.pixels(scene, tx, job, &mut wire)?;
        // The frame ends when its last byte has left the transmit FIFO (SPEC.md §3.8).
        wire.flush().map_err(|_| Fail::Output)?;
        let drained = self.clock.now();
        self.path.stats.frame_cycles = cycles_between(arrival, drained);
        self.path.stats.link_cycles = wire.first.map_or(0, |first| cycles_between(first, drained));
        self.path.stats.frame_tx_bytes = wire.bytes;
        let now = self.clock.excluded();
        self.path.stats.model_instructions = now.model.wrapping_sub(excluded.model);
        self.path.stats.link_wrapper_instructions = now.link_wrapper.wrapping_sub(excluded.link_wrapper);
        let (spans, crc) = self.spans.finish();
        if job.no_stats {
            return Ok((spans, crc));
        }
        let entries = self.path.stats.to_bytes();
        // Only a write error stops the frame here (a `Stats` that does not fit a frame would be
        // a firmware bug, and the frame's pixels are all out).
        if let Err(TxError::Write(_)) = tx.send(&Msg::Stats { frame: req.frame, entries: &entries }, out) {
            return Err(Fail::Output);
        }
        Ok((spans, crc))
    }

    /// The frame context and the plan the device follows, or the refusal of a plan bit whose
    /// stage this build does not have.
    fn frame_ctx<const N: usize>(scene: &SceneStore<N>, job: &Job<'_>) -> Result<FrameCtx, Fail> {
        let req = job.req;
        check_plan(req.flags, compiled_plan()).map_err(|t| Fail::Plain(ErrorCode::BadRequest, field::FLAGS, t))?;
        let shadows =
            cfg!(feature = "shadows") && req.flags & render_flags::SHADOWS != 0 && scene.lighting.light_count > 0;
        // A camera ray that sends nothing ends at bounce 0 with `acc = 0 + 1·background`.
        let background = scene.lighting.background.map(|b| 0.0 + 1.0 * b);
        let lighting = &scene.lighting;
        let light = job.light;
        let direct = shade::DirectLight {
            pos: light.pos,
            radiance: lighting.light_colour.map(|c| c * light.intensity),
            specular: req.flags & render_flags::SPECULAR != 0,
        };
        let diag = scene.grid.aabb().diagonal().length();
        Ok(FrameCtx {
            cam: job.cam,
            columns: ColumnTerms::default(),
            ambient: lighting.ambient_colour.map(|c| c * light.ambient),
            lit: lighting.light_count > 0 && direct.radiance.iter().any(|&c| c != 0.0),
            direct,
            spot_axis: shade::spot_axis(lighting),
            eps_diag: shade::SHADOW_EPS_DIAG * diag,
            spans: BoxSpans::new(&job.cam, &scene.grid.aabb()),
            occupancy: OccupancyMask::new(&job.cam, &scene.grid, scene.voxel_pe.get(..scene.voxels).unwrap_or(&[])),
            background: Sample { rgb: shade::to_rgb8(background), prim: interp::MISS, t: f32::INFINITY },
            shadows,
            reflections: req.flags & render_flags::REFLECTIONS != 0 && scene.lighting.max_depth > 1,
            textures: req.flags & render_flags::TEXTURES != 0,
            specular: req.flags & render_flags::SPECULAR != 0,
            bytes: shade::MatteBytes::default(),
            estimate_light: false,
        })
    }

    /// Pixels `from..to` of row `y`, whose camera rays cannot enter the grid box
    /// ([`background_run`]).
    fn background(
        &mut self,
        bg: &Sample,
        from: u16,
        to: u16,
        y: u16,
        tx: &mut FrameTx,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        background_run(&mut self.spans, &mut self.path.stats, bg, from, to, y, tx, out)
    }

    /// Row-major render loop of `region`; returns early (frame aborted) on any co-processor
    /// failure.
    fn pixels<const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        let (req, region) = (job.req, job.region);
        let mut ctx = Self::frame_ctx(scene, job)?;
        ctx.columns.fill(&ctx.cam, req.width, cfg!(soft_float));
        if cfg!(soft_float) {
            let plan = (ctx.direct.specular, ctx.textures, ctx.reflections);
            let radiance = if ctx.lit { ctx.direct.radiance } else { [0.0; 3] };
            ctx.bytes = shade::MatteBytes::new(&scene.materials, &scene.material_model, ctx.ambient, radiance, plan);
            ctx.estimate_light = ctx.lit && scene.lighting.falloff == Falloff::None && ctx.spot_axis.is_none();
        }
        let step = render_flags::interp_step(req.flags);
        let params = interp::Params {
            step,
            eps: render_flags::interp_eps(req.flags),
            adaptive: req.flags & render_flags::INTERP_ADAPTIVE != 0,
        };
        let interpolate = step > 0;
        if interpolate && region.cols as usize > MAX_INTERP_WIDTH {
            return Err(Fail::Plain(
                ErrorCode::BadRequest,
                field::FLAGS,
                "row interpolation supports rows of at most 2048 pixels",
            ));
        }
        let mut plan = 0u16;
        for (on, bit) in [
            (ctx.shadows, render_flags::SHADOWS),
            (ctx.reflections, render_flags::REFLECTIONS),
            (ctx.textures, render_flags::TEXTURES),
            (ctx.specular, render_flags::SPECULAR),
        ] {
            if on {
                plan |= bit;
            }
        }
        if interpolate {
            plan |= req.flags
                & (render_flags::INTERP_STEP_MASK | render_flags::INTERP_EPS_MASK | render_flags::INTERP_ADAPTIVE);
        }
        self.path.stats.plan = plan as u64;
        let mut sw = Stopwatch::start(&self.clock);
        let (x1, y1) = (region.x0.saturating_add(region.cols), region.y0.saturating_add(region.rows));
        if !interpolate {
            let rows = Rows {
                scene,
                ctx: &ctx,
                width: req.width,
                x0: region.x0,
                x1,
                ys: region.y0..y1,
                polls: self.path.polls,
            };
            if let Some(r) = self.farmed(&rows, tx, out) {
                return r;
            }
        }
        let mut counts = Counts::default();
        let mut ctl = StepControl::new(&params);
        for y in region.y0..y1 {
            // Columns outside the row's span see only the background (`crate::cull`).
            let (cols, rays) = ctx.row(y, req.width, region.x0, x1);
            let (lo, hi) = (cols.start, cols.end);
            if interpolate {
                let w = region.cols as usize;
                let before = counts;
                let (path, clock) = (&mut self.path, &self.clock);
                let row = self.row.get_mut(..w).unwrap_or(&mut []);
                // `region` lies inside the image (≤ 4096 wide): x0 + xi does not wrap.
                interp::fill_row(row, ctl.step, params.eps, &mut counts, |xi| {
                    let x = region.x0.wrapping_add(xi as u16);
                    if x < lo || x >= hi {
                        count(&mut path.stats.primary_rays, 1);
                        count(&mut path.stats.culled_rays, 1);
                        return Ok(ctx.background);
                    }
                    pixel(path, scene, clock, &mut sw, &ctx, &rays, x)
                })?;
                ctl.after_row(&before, &counts);
                for (x, s) in (region.x0..x1).zip(self.row.iter()) {
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    count(&mut self.path.stats.pixels, 1);
                }
                sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
            } else {
                self.background(&ctx.background, region.x0, lo, y, tx, out)?;
                for x in lo..hi {
                    let s = pixel(&mut self.path, scene, &self.clock, &mut sw, &ctx, &rays, x)?;
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    count(&mut self.path.stats.pixels, 1);
                    sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
                }
                self.background(&ctx.background, hi, x1, y, tx, out)?;
            }
            // Flush per row so the host sees progress while the next row renders.
            self.spans.flush(tx, out).map_err(Fail::tx)?;
            sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
        }
        self.path.stats.interpolated_pixels = counts.interpolated;
        self.path.stats.interp_retraces = counts.retraces;
        Ok(())
    }

    /// The rows of a frame without interpolation through the farm, sent as the loop of
    /// [`pixels`](Self::pixels) sends them (a farm only exists with a clock that reads 0, so
    /// the stage laps of that loop add nothing); `None` when the farm does not take the
    /// frame.
    fn farmed<const N: usize>(
        &mut self,
        rows: &Rows<'_, N>,
        tx: &mut FrameTx,
        out: &mut impl Write,
    ) -> Option<Result<(), Fail>> {
        let (spans, path) = (&mut self.spans, &mut self.path);
        let (link, stats) = (&path.link, &mut path.stats);
        let mut result = Ok(());
        let mut sink = |row: RowDone<'_>| {
            result = farmed_row(spans, stats, rows, &row, tx, out);
            if result.is_ok() {
                ControlFlow::Continue(())
            } else {
                ControlFlow::Break(())
            }
        };
        self.farm.render(link, rows, &mut sink).then_some(result)
    }
}

/// Sends a farmed row as the device loop sends a row: the background before its traced
/// columns, their samples, the background after, then the flush.
fn farmed_row<const N: usize>(
    spans: &mut SpanEncoder,
    stats: &mut FrameStats,
    rows: &Rows<'_, N>,
    row: &RowDone<'_>,
    tx: &mut FrameTx,
    out: &mut impl Write,
) -> Result<(), Fail> {
    stats.accumulate(&row.stats);
    let (bg, y) = (&rows.ctx.background, row.y);
    let cols = rows.columns(y);
    background_run(spans, stats, bg, rows.x0, cols.start, y, tx, out)?;
    let n = row.fault.map_or(cols.len(), |f| f.done);
    for (x, s) in cols.clone().zip(row.samples.iter().take(n)) {
        spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
        count(&mut stats.pixels, 1);
    }
    if let Some(f) = row.fault {
        return Err(f.fail);
    }
    background_run(spans, stats, bg, cols.end, rows.x1, y, tx, out)?;
    spans.flush(tx, out).map_err(Fail::tx)
}

/// Pixels `from..to` of row `y`, whose camera rays cannot enter the grid box: counted as
/// traced rays with empty lists (as tracing them would) and sent as one background run.
#[allow(clippy::too_many_arguments)]
fn background_run(
    spans: &mut SpanEncoder,
    stats: &mut FrameStats,
    bg: &Sample,
    from: u16,
    to: u16,
    y: u16,
    tx: &mut FrameTx,
    out: &mut impl Write,
) -> Result<(), Fail> {
    let n = to.saturating_sub(from);
    if n == 0 {
        return Ok(());
    }
    for c in [&mut stats.primary_rays, &mut stats.culled_rays, &mut stats.pixels] {
        count(c, u64::from(n));
    }
    spans.push_run(from, y, n, bg.rgb, bg.prim, tx, out).map_err(Fail::tx)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::{check_plan, compiled_plan, pipeline_features};
    use gridrt_shared::msg::{feature, render_flags};

    #[test]
    fn a_build_without_a_stage_refuses_plans_that_need_it() {
        let all = render_flags::REFLECTIONS | render_flags::TEXTURES | render_flags::SPECULAR;
        let no_textures = all & !render_flags::TEXTURES;
        let e = check_plan(render_flags::TEXTURES | render_flags::SHADOWS, no_textures).unwrap_err();
        assert!(e.contains("without the texture stage"), "{e}");
        assert!(check_plan(render_flags::REFLECTIONS | render_flags::SHADOWS, no_textures).is_ok());
        assert!(check_plan(render_flags::REFLECTIONS, 0).unwrap_err().contains("reflection"));
        assert!(check_plan(render_flags::SPECULAR, 0).unwrap_err().contains("specular"));
        // This build: whatever its features, it refuses exactly what it lacks.
        assert_eq!(check_plan(render_flags::TEXTURES, compiled_plan()).is_ok(), cfg!(feature = "textures"));
        assert_eq!(pipeline_features() & feature::TEXTURES != 0, cfg!(feature = "textures"));
    }
}
