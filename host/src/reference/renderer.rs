//! The f64 reference renderer of a [`Scene`]: triangles through an independent BVH
//! ([`TriangleBvh`]), ViRAY's analytic primitives intersected in f64, and the shading of
//! docs/CONTRACTS.md § Shading re-implemented in f64: GridRT's matte surface, Lambert /
//! Oren–Nayar, Blinn–Phong / Torrance–Sparrow, a point light with spotlight cone, hard
//! shadows, mirror reflections with constant or Fresnel coefficient up to the scene's depth,
//! and procedural textures with bilinear filtering. Camera, shading and the shadow rule are
//! evaluated in f64 from the same f32 inputs the device receives.
//!
//! Hit rule: nearest `t > 0`, ties → lowest primitive id.

use gridrt_shared::scene::{Falloff, ReflectMode, TextureKind};

use super::analytic::Prim;
use super::bvh::TriangleBvh;
use super::camera::CameraF64;
use super::frame::{render_pixels, ReferenceImage, MISS_ID};
use super::shading::{add, diffuse, fresnel_conductor, fresnel_dielectric, outgoing, scale, specular, DirectTerm};
use super::texture::texture;
use super::vec3::{cross, dot, normalize, sub};
use crate::render_settings::RenderSettings;
use crate::scene::transform::{apply_point, from_wire, Affine64};
use crate::scene::{Bounds, Scene};

/// Shadow rays end at `1 − 2^-10` of the way to the light.
pub const SHADOW_T_MAX: f64 = 1.0 - 1.0 / 1024.0;

/// Which stages run (the pipeline plan the device was asked to follow).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stages {
    /// Shadow rays.
    pub shadows: bool,
    /// Reflection rays.
    pub reflections: bool,
    /// Texture stage.
    pub textures: bool,
    /// Specular terms.
    pub specular: bool,
}

impl Stages {
    /// Everything on.
    pub const ALL: Self = Self { shadows: true, reflections: true, textures: true, specular: true };
}

/// A scene prepared for the reference renderer.
pub struct Reference<'s> {
    scene: &'s Scene,
    tris: Option<TriangleBvh>,
    prims: Vec<Prim>,
    objects: Vec<(u32, u32, Affine64)>,
    grid_diag: f64,
}

/// A hit: t, primitive id, material, geometric normal (not normalised).
#[derive(Debug, Clone, Copy)]
struct Hit {
    t: f64,
    prim: u32,
    material: u32,
    normal: [f64; 3],
}

impl<'s> Reference<'s> {
    /// Prepares `scene`; `grid_bounds` is the device's grid box (the ray-offset rule scales
    /// with its diagonal).
    pub fn new(scene: &'s Scene, grid_bounds: &Bounds) -> Self {
        let world = scene;
        let t = world.mesh.triangles.len() as u32;
        let tris = (!world.mesh.triangles.is_empty()).then(|| TriangleBvh::new(&world.mesh));
        let prims = world
            .prims
            .iter()
            .enumerate()
            .map(|(i, p)| Prim { kind: p.kind, w2o: from_wire(&p.to_object), material: p.material, id: t + i as u32 })
            .collect();
        let objects =
            world.objects.iter().map(|o| (o.first_prim, o.prim_count, from_wire(&o.world_to_object))).collect();
        Self { scene, tris, prims, objects, grid_diag: grid_bounds.diagonal_len() }
    }

    fn closest(&self, o: [f64; 3], d: [f64; 3], t_max: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        if let Some(tris) = &self.tris {
            if let Some(h) = tris.closest_hit(o, d, t_max) {
                let tri = &self.scene.mesh.triangles[h.prim as usize];
                let v = tri.v.map(|p| p.map(|c| c as f64));
                best = Some(Hit {
                    t: h.t,
                    prim: h.prim,
                    material: tri.material,
                    normal: cross(sub(v[1], v[0]), sub(v[2], v[0])),
                });
            }
        }
        for p in &self.prims {
            if let Some(t) = p.hit(o, d) {
                if t < t_max && best.is_none_or(|b| t < b.t || (t == b.t && p.id < b.prim)) {
                    let q = [0, 1, 2].map(|i| o[i] + t * d[i]);
                    best = Some(Hit { t, prim: p.id, material: p.material, normal: p.normal(q) });
                }
            }
        }
        best
    }

    fn occluded(&self, o: [f64; 3], d: [f64; 3], t_max: f64) -> bool {
        self.prims.iter().any(|p| p.hit(o, d).is_some_and(|t| t < t_max))
            || self.tris.as_ref().is_some_and(|s| s.any_hit(o, d, t_max))
    }

    fn eps(&self, p: [f64; 3]) -> f64 {
        let p_inf = p.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        1e-4 * self.grid_diag + p_inf / 1_048_576.0
    }

    /// Shades one pixel: (linear RGB clamped, primary prim id).
    pub fn shade_pixel(&self, cam: &CameraF64, s: &RenderSettings, st: Stages, x: u32, y: u32) -> ([f64; 3], u32) {
        let w = self.scene;
        let lg = &w.lighting;
        let (mut o, mut d) = cam.primary_ray(x, y);
        let la = lg.ambient_colour.map(|c| c as f64 * s.ambient as f64);
        let lpos = s.light.pos.map(|c| c as f64);
        let rad = lg.light_colour.map(|c| c as f64 * s.light.intensity as f64);
        let lit = lg.light_count > 0 && rad.iter().any(|&c| c != 0.0);
        let depth = if st.reflections { lg.max_depth.max(1) } else { 1 };
        let mut acc = [0.0; 3];
        let mut thr = 1.0;
        let mut first = MISS_ID;
        for bounce in 0..depth {
            let Some(h) = self.closest(o, d, f64::INFINITY) else {
                acc = add(acc, scale(lg.background.map(|c| c as f64), thr));
                break;
            };
            if bounce == 0 {
                first = h.prim;
            }
            let p = [0, 1, 2].map(|i| o[i] + h.t * d[i]);
            let (m, e) = w.material(h.material);
            let mut cd = m.diffuse.map(|c| c as f64);
            if st.textures && e.texture != TextureKind::None {
                if let Some((_, _, w2o)) = self.objects.iter().find(|(f, c, _)| h.prim >= *f && h.prim - *f < *c) {
                    cd = texture(&e, cd, apply_point(w2o, p));
                }
            }
            let nl = dot(h.normal, h.normal).sqrt();
            if !(nl > 0.0 && nl.is_finite()) {
                // Degenerate normal: no direction to light it from; ambient only.
                acc = add(acc, scale(outgoing(&e, cd, la, None), thr));
                break;
            }
            let mut n = normalize(h.normal);
            if dot(n, d) > 0.0 {
                n = scale(n, -1.0);
            }
            let v = normalize(scale(d, -1.0));
            let mut direct = None;
            if lit {
                let ld = sub(lpos, p);
                let r2 = dot(ld, ld);
                let l = normalize(ld);
                let cos = dot(n, l).max(0.0);
                let e_irr = match lg.falloff {
                    Falloff::None => cos,
                    Falloff::InverseSquare => {
                        if r2 > 0.0 {
                            cos / r2
                        } else {
                            0.0
                        }
                    }
                };
                let spot = {
                    let a = lg.spot_dir.map(|c| c as f64);
                    if dot(a, a) == 0.0 {
                        1.0
                    } else {
                        let c = dot(normalize(a), normalize(sub(p, lpos)));
                        let (co, ci) = (lg.cos_outer as f64, lg.cos_inner as f64);
                        if ci > co {
                            ((c - co) / (ci - co)).clamp(0.0, 1.0)
                        } else if c >= co {
                            1.0
                        } else {
                            0.0
                        }
                    }
                };
                if e_irr > 0.0 && spot > 0.0 {
                    let visible = if st.shadows && s.shadows {
                        let p2 = add(p, scale(n, self.eps(p)));
                        !self.occluded(p2, sub(lpos, p2), SHADOW_T_MAX)
                    } else {
                        true
                    };
                    if visible {
                        let es = e_irr * spot;
                        direct = Some(DirectTerm {
                            light: rad.map(|c| es * c),
                            diffuse: e.kd as f64 * diffuse(&e, n, l, v),
                            specular: if st.specular { e.ks as f64 * specular(&e, n, l, v) } else { 0.0 },
                        });
                    }
                }
            }
            acc = add(acc, scale(outgoing(&e, cd, la, direct.as_ref()), thr));
            if bounce + 1 == depth || e.reflect_mode == ReflectMode::None {
                break;
            }
            let cos_o = dot(n, v);
            let r = match e.reflect_mode {
                ReflectMode::None => 0.0,
                ReflectMode::Constant => m.reflect as f64,
                ReflectMode::Dielectric => fresnel_dielectric(cos_o, e.eta as f64),
                ReflectMode::Conductor => fresnel_conductor(cos_o, e.eta as f64, e.kappa as f64),
            };
            if r.is_nan() || r <= 0.0 {
                break;
            }
            thr *= r;
            let origin = add(p, scale(n, self.eps(p)));
            let dn = dot(d, n);
            d = sub(d, scale(n, 2.0 * dn));
            o = origin;
        }
        (acc.map(|c| c.clamp(0.0, 1.0)), first)
    }
}

/// Renders `scene` with `threads` workers.
pub fn render(scene: &Reference<'_>, settings: &RenderSettings, stages: Stages, threads: usize) -> ReferenceImage {
    let cam = CameraF64::new(settings);
    render_pixels(settings, threads, |x, y| scene.shade_pixel(&cam, settings, stages, x, y))
}
