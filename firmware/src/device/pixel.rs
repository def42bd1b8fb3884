//! One pixel of a frame: its primary ray, shading (`crate::shade`: matte, ViRAY's models,
//! textures), shadow and reflection rays, following the frame's plan ([`FrameCtx`]). The
//! device's own row loop (`pipeline`) and a row farm's tracers (`farm`) both call [`pixel`].

use super::fail::Fail;
use super::raypath::{RayClass, RayPath};
use super::scene::SceneStore;
use super::stats::{count, Stage, StageClock, Stopwatch};
use crate::camera::Camera;
use crate::fsl::FslLink;
use crate::interp::{self, Sample};
use crate::shade::{self, Light, DEFAULT_ALBEDO};
use gridrt_shared::fsl::RayKind;
use gridrt_shared::math::Ray;
#[cfg(feature = "textures")]
use gridrt_shared::math::Vec3;
#[cfg(feature = "textures")]
use gridrt_shared::scene::{affine_point, TextureKind};
use gridrt_shared::scene::{Material, MaterialModel, ReflectMode};

/// Per-frame constants of the pixel pipeline.
pub(super) struct FrameCtx {
    pub(super) cam: Camera,
    pub(super) light: Light,
    pub(super) shadows: bool,
    pub(super) reflections: bool,
    pub(super) textures: bool,
    pub(super) specular: bool,
    pub(super) diag: f32,
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
    x: u16,
    y: u16,
) -> Result<Sample, Fail> {
    let lighting = &scene.lighting;
    let mut ray = ctx.cam.primary_ray(x as u32, y as u32);
    count(&mut path.stats.primary_rays, 1);
    sw.lap(clock, &mut path.stats, Stage::RayGen);
    let la = lighting.ambient_colour.map(|c| c * ctx.light.ambient);
    let dl = shade::DirectLight {
        pos: ctx.light.pos,
        radiance: lighting.light_colour.map(|c| c * ctx.light.intensity),
        specular: ctx.specular,
    };
    let lit = lighting.light_count > 0 && dl.radiance.iter().any(|&c| c != 0.0);
    let depth = if ctx.reflections { lighting.max_depth.max(1) } else { 1 };
    let mut acc = [0f32; 3];
    let mut throughput = 1f32;
    let (mut first_prim, mut first_t) = (interp::MISS, f32::INFINITY);
    for bounce in 0..depth {
        let class = if bounce == 0 { RayClass::Primary } else { RayClass::Reflection };
        let hit = path.trace_as(scene, clock, sw, &ray, RayKind::Closest, f32::INFINITY, class)?;
        let r = match hit {
            Some(r) if r.hit => r,
            _ => {
                for (a, b) in acc.iter_mut().zip(lighting.background) {
                    *a += throughput * b;
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
        let ext = scene.material_model.get(r.material as usize).copied().unwrap_or(MaterialModel::MATTE);
        #[allow(unused_mut)]
        let mut cd = m.diffuse;
        #[cfg(feature = "textures")]
        if ctx.textures && ext.texture != TextureKind::None {
            if let Some(po) = object_point(scene, r.prim, p) {
                cd = crate::texture::sample(&ext, cd, po);
            }
        }
        let Some(n) = shade::facing_normal(r.normal, ray.dir) else {
            // Degenerate normal: no direction to light it from; ambient only.
            for (a, b) in acc.iter_mut().zip(shade::outgoing(&ext, cd, la, None)) {
                *a += throughput * b;
            }
            break;
        };
        let v = (-ray.dir).try_normalize().unwrap_or(n);
        let mut direct = None;
        if lit {
            let e = shade::irradiance(lighting, n, p, dl.pos);
            let spot = if e > 0.0 { shade::spot_factor(lighting, dl.pos, p) } else { 0.0 };
            if e > 0.0 && spot > 0.0 {
                let visible = if ctx.shadows {
                    count(&mut path.stats.shadow_rays, 1);
                    let sr = shade::shadow_ray(p, n, dl.pos, ctx.diag);
                    sw.lap(clock, &mut path.stats, Stage::Shade);
                    let blocker =
                        path.trace_as(scene, clock, sw, &sr, RayKind::Any, shade::SHADOW_T_MAX, RayClass::Shadow)?;
                    !blocker.is_some_and(|b| b.hit)
                } else {
                    true
                };
                if visible {
                    direct = shade::direct(&ext, n, v, p, &dl, e * spot);
                }
            }
        }
        for (a, b) in acc.iter_mut().zip(shade::outgoing(&ext, cd, la, direct.as_ref())) {
            *a += throughput * b;
        }
        sw.lap(clock, &mut path.stats, Stage::Shade);
        if bounce.wrapping_add(1) == depth || ext.reflect_mode == ReflectMode::None {
            break;
        }
        let refl = shade::reflectance(&ext, m.reflect, n.dot(v));
        if refl.is_nan() || refl <= 0.0 {
            break;
        }
        throughput *= refl;
        count(&mut path.stats.reflection_rays, 1);
        let origin = p + n * shade::shadow_epsilon(ctx.diag, p);
        ray = Ray { origin, dir: ray.dir - n * (2.0 * ray.dir.dot(n)) };
    }
    let rgb = shade::to_rgb8(acc);
    sw.lap(clock, &mut path.stats, Stage::Shade);
    Ok(Sample { rgb, prim: first_prim, t: first_t })
}
