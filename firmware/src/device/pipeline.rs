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
//! The frame and row loops that call [`pixel`] are `super::render`; rows traced away from the
//! device loop go through the same [`pixel`] (`super::farm`).

use super::fail::Fail;
use super::raypath::{RayClass, RayPath};
use super::scene::SceneStore;
use super::stats::{count, Stage, StageClock, Stopwatch};
use crate::camera::{Camera, ColumnTerms, RowRays};
use crate::cull::{BoxSpans, OccupancyMask};
use crate::fsl::FslLink;
use crate::interp::Sample;
use crate::sfloat::{add, mul, vsub};
use crate::shade::{self, LightFactor, DEFAULT_ALBEDO};
use core::ops::Range;
use gridrt_shared::fsl::{RayKind, RayResult};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::msg::{feature, render_flags};
#[cfg(feature = "textures")]
use gridrt_shared::scene::{affine_point, TextureKind};
use gridrt_shared::scene::{Material, MaterialModel, ReflectMode};

/// The model of a material id the scene does not define.
const MATTE: MaterialModel = MaterialModel::MATTE;

/// Per-frame constants of the pixel pipeline.
pub(super) struct FrameCtx {
    pub(super) cam: Camera,
    /// The camera rays' column terms on a soft-float core (`crate::camera::ColumnTerms`).
    pub(super) columns: ColumnTerms,
    /// Per row, the columns whose camera rays can enter the grid box.
    pub(super) spans: BoxSpans,
    /// The image tiles whose camera rays may meet a cell with primitives (`crate::cull`).
    pub(super) occupancy: OccupancyMask,
    /// What a pixel whose camera ray misses everything gets: the background.
    pub(super) background: Sample,
    /// The ambient light `L_a` (ambient colour × ambient term).
    pub(super) ambient: [f32; 3],
    /// The point light as the direct term uses it.
    pub(super) direct: shade::DirectLight,
    /// The light reaches surfaces at all (a light with a non-zero radiance).
    pub(super) lit: bool,
    /// The spotlight's cone ([`shade::SpotCone`]); `None` for an omnidirectional light.
    pub(super) spot: Option<shade::SpotCone>,
    pub(super) shadows: bool,
    pub(super) reflections: bool,
    pub(super) textures: bool,
    pub(super) specular: bool,
    /// `1e-4 · |grid box diagonal|`, the per-scene term of the shadow-ray offset.
    pub(super) eps_diag: f32,
    /// The 8-bit colour of matte camera hits in fixed point, on a soft-float core
    /// (`shade::MatteBytes`; empty elsewhere).
    pub(super) bytes: shade::MatteBytes,
    /// The light's factor at those hits may be estimated in integers (`shade::light_factor`):
    /// a soft-float core, a light, no falloff, no spot cone.
    pub(super) estimate_light: bool,
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
pub(super) const fn compiled_plan() -> u16 {
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
    count(&mut path.stats.primary_rays, 1);
    // A camera ray that can meet only empty cells: its walk would list nothing (culled), its
    // pixel is the background (`crate::cull::OccupancyMask`).
    if !ctx.occupancy.may_hit(x, row.y() as u16) {
        count(&mut path.stats.culled_rays, 1);
        sw.lap(clock, &mut path.stats, Stage::RayGen);
        return Ok(ctx.background);
    }
    open_pixel(path, scene, clock, sw, ctx, row, x)
}

/// [`pixel`] for a pixel the occupancy mask does not clear (the caller tested
/// `may_hit`), its primary ray not counted (the caller counts its row's).
#[allow(clippy::arithmetic_side_effects)] // as `pixel`
// Out of line on a soft-float core, inline with an FPU: measured, each the lower count.
#[cfg_attr(soft_float, inline(never))]
#[cfg_attr(not(soft_float), inline(always))]
pub(super) fn open_pixel<L: FslLink, C: StageClock, const N: usize>(
    path: &mut RayPath<L>,
    scene: &SceneStore<N>,
    clock: &C,
    sw: &mut Stopwatch,
    ctx: &FrameCtx,
    row: &RowRays<'_>,
    x: u16,
) -> Result<Sample, Fail> {
    let ray = row.ray(x as u32);
    sw.lap(clock, &mut path.stats, Stage::RayGen);
    let hit = path.trace_as(scene, clock, sw, &ray, RayKind::Closest, f32::INFINITY, RayClass::Primary)?;
    let r = match hit {
        Some(r) if r.hit => r,
        // A camera ray that meets nothing is the frame's background, computed once with the
        // same formula (`0 + 1·background`).
        _ => {
            sw.lap(clock, &mut path.stats, Stage::Shade);
            return Ok(ctx.background);
        }
    };
    let p = shade::hit_point(&ray, r.t);
    let unit = unit_normal(path, &r, ray.dir);
    // The common camera hit on a soft-float core: a material with a fixed-point rule under a
    // light whose factor the integers estimate. Everything else, and the estimate's `Unsure`,
    // is `path_from`'s: kept out of line there, its loop's state does not crowd this path's
    // registers.
    if let Some(n) = unit {
        if ctx.estimate_light && ctx.bytes.covers(r.material) {
            let m = material(scene, r.material);
            let ext = scene.material_model.get(r.material as usize).unwrap_or(&MATTE);
            if let Some(rgb) = matte_camera_hit(path, scene, clock, sw, ctx, (p, n), &m, ext, r.material)? {
                sw.lap(clock, &mut path.stats, Stage::Shade);
                return Ok(Sample { rgb, prim: r.prim, t: r.t });
            }
        }
    }
    path_from(path, scene, clock, sw, ctx, &ray, (r, p, unit))
}

/// The material of id `material`, or the default one when the scene does not define it.
#[inline(always)]
fn material<const N: usize>(scene: &SceneStore<N>, material: u16) -> Material {
    scene.materials.get(material as usize).copied().unwrap_or(Material { diffuse: DEFAULT_ALBEDO, reflect: 0.0 })
}

/// The unit normal of hit `r` facing a ray along `dir`; `None` for a degenerate normal. On a
/// soft-float core the unit normal of a primitive hit recently comes from the cache.
#[inline(always)]
fn unit_normal<L>(path: &mut RayPath<L>, r: &RayResult, dir: Vec3) -> Option<Vec3> {
    if cfg!(soft_float) {
        path.normals.unit(r.prim, r.normal).map(|n| shade::facing(n, dir))
    } else {
        shade::facing_normal(r.normal, dir)
    }
}

/// The rest of [`pixel`] from the camera ray's hit `first` (the result, its point and unit
/// normal): shading, the shadow ray, and the mirror bounces, in the f32 rules. Out of line on
/// a soft-float core, where [`pixel`] answers most hits without it; inline with an FPU, where
/// every hit comes here (out of line it cost riscv32imafc 8 instructions per primary ray).
#[allow(clippy::arithmetic_side_effects)] // f32 shading on glam vectors, as in `pixel`
#[cfg_attr(soft_float, inline(never))]
#[cfg_attr(not(soft_float), inline(always))]
fn path_from<L: FslLink, C: StageClock, const N: usize>(
    path: &mut RayPath<L>,
    scene: &SceneStore<N>,
    clock: &C,
    sw: &mut Stopwatch,
    ctx: &FrameCtx,
    camera: &Ray,
    first: (RayResult, Vec3, Option<Vec3>),
) -> Result<Sample, Fail> {
    let lighting = &scene.lighting;
    let (la, dl, lit) = (ctx.ambient, &ctx.direct, ctx.lit);
    let depth = if ctx.reflections { lighting.max_depth.max(1) } else { 1 };
    let mut acc = [0f32; 3];
    let mut throughput = 1f32;
    let (first_prim, first_t) = (first.0.prim, first.0.t);
    let mut pending = Some(first);
    // The ray of the current bounce: the camera ray's by reference until a mirror bounce
    // (a copy of it was a `memcpy` call per hit).
    let mut bounced: Option<Ray> = None;
    for bounce in 0..depth {
        let ray = bounced.as_ref().unwrap_or(camera);
        let (r, p, unit) = match pending.take() {
            Some(hit) => hit,
            None => {
                let hit =
                    path.trace_as(scene, clock, sw, ray, RayKind::Closest, f32::INFINITY, RayClass::Reflection)?;
                let Some(r) = hit.filter(|r| r.hit) else {
                    for (a, b) in acc.iter_mut().zip(lighting.background) {
                        *a = add(*a, mul(throughput, b));
                    }
                    break;
                };
                let p = shade::hit_point(ray, r.t);
                let unit = unit_normal(path, &r, ray.dir);
                (r, p, unit)
            }
        };
        let m = material(scene, r.material);
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
        let Some(n) = unit else {
            // Degenerate normal: no direction to light it from; ambient only.
            for (a, b) in acc.iter_mut().zip(shade::outgoing(ext, cd, la, None)) {
                *a += throughput * b;
            }
            break;
        };
        // The unit view vector, computed only for the models that read it.
        let view = || crate::fmath::try_normalize(-ray.dir).unwrap_or(n);
        let mut direct = None;
        // The light's factor `spot·E` at a hit it reaches, +0 elsewhere (`shade::MatteBytes`).
        let mut e_seen = 0.0;
        if lit {
            let (e, l) = shade::irradiance_toward(lighting, n, p, dl.pos);
            let spot = if e > 0.0 { shade::spot_factor_in(ctx.spot.as_ref(), dl.pos, p) } else { 0.0 };
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
        // Written out per channel (a zipped loop kept `acc` in memory with an FPU).
        let [o0, o1, o2] = shade::outgoing(ext, cd, la, direct.as_ref());
        acc = [add(acc[0], mul(throughput, o0)), add(acc[1], mul(throughput, o1)), add(acc[2], mul(throughput, o2))];
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
        bounced = Some(Ray { origin, dir: ray.dir - n * (2.0 * ray.dir.dot(n)) });
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
#[inline(always)]
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
