//! f64 reference renderer of scene-file worlds (scene image v2): triangles through the
//! independent BVH of [`crate::reference`], ViRAY's analytic primitives intersected in f64,
//! and ViRAY shading (docs/CONTRACTS.md § "Shading, scene image v2") re-implemented in f64:
//! Lambert / Oren–Nayar, Blinn–Phong / Torrance–Sparrow, a point light with spotlight cone,
//! hard shadows, mirror reflections with constant or Fresnel coefficient up to the scene's
//! depth, and procedural textures with bilinear filtering.
//!
//! The primitives are evaluated with the f32 world→object maps the device receives (widened
//! to f64), so both sides render the same geometry. Hit rule: nearest `t > 0`, ties → lowest
//! primitive id.

use gridrt_shared::scene_v2::{
    DiffuseModel, Falloff, Mapping, MaterialExt, PrimKind, ReflectMode, SpecularModel, TextureKind,
};

use crate::camera::{cross, dot, normalize, sub, CameraF64, RenderSettings};
use crate::reference::{render_pixels, ReferenceImage, ReferenceScene, MISS_ID, SHADOW_T_MAX};
use crate::scene::Bounds;
use crate::world::{apply_point, apply_transpose, apply_vector, from_wire, Affine64, World};

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

struct Prim {
    kind: PrimKind,
    w2o: Affine64,
    material: u32,
    id: u32,
}

/// A world prepared for the reference renderer.
pub struct WorldReference<'w> {
    world: &'w World,
    tris: Option<ReferenceScene>,
    prims: Vec<Prim>,
    objects: Vec<(u32, u32, Affine64)>,
    grid_diag: f64,
}

fn quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    // a t² + 2 b t + c = 0
    if a == 0.0 {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let q = if b >= 0.0 { -(b + s) } else { -(b - s) };
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t0, t1) = (q / a, c / q);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

impl Prim {
    /// Nearest t > 0 and the object-space hit point.
    fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<f64> {
        let o = apply_point(&self.w2o, o);
        let d = apply_vector(&self.w2o, d);
        let first = |r: Option<(f64, f64)>, ok: &dyn Fn(f64) -> bool| {
            r.and_then(|(a, b)| [a, b].into_iter().find(|&t| t > 0.0 && ok(t)))
        };
        match self.kind {
            PrimKind::Sphere => first(quadratic(dot(d, d), dot(o, d), dot(o, o) - 1.0), &|_| true),
            PrimKind::Cylinder => first(
                quadratic(d[0] * d[0] + d[2] * d[2], o[0] * d[0] + o[2] * d[2], o[0] * o[0] + o[2] * o[2] - 1.0),
                &|t| (o[1] + t * d[1]).abs() <= 1.0,
            ),
            PrimKind::Cone => {
                let (ou, du) = (1.0 - o[1], -d[1]);
                let a = d[0] * d[0] + d[2] * d[2] - du * du;
                let b = o[0] * d[0] + o[2] * d[2] - ou * du;
                let c = o[0] * o[0] + o[2] * o[2] - ou * ou;
                let ok = |t: f64| (0.0..=1.0).contains(&(ou + t * du));
                if a == 0.0 {
                    if b == 0.0 {
                        return None;
                    }
                    let t = -c / (2.0 * b);
                    return (t > 0.0 && ok(t)).then_some(t);
                }
                first(quadratic(a, b, c), &ok)
            }
            PrimKind::Disk | PrimKind::Square => {
                if d[1] == 0.0 {
                    return None;
                }
                let t = -o[1] / d[1];
                if !(t > 0.0 && t.is_finite()) {
                    return None;
                }
                let (x, z) = (o[0] + t * d[0], o[2] + t * d[2]);
                let inside =
                    if self.kind == PrimKind::Disk { x * x + z * z <= 1.0 } else { x.abs() <= 1.0 && z.abs() <= 1.0 };
                inside.then_some(t)
            }
        }
    }

    fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        let q = apply_point(&self.w2o, p);
        let n = match self.kind {
            PrimKind::Sphere => q,
            PrimKind::Cylinder => [q[0], 0.0, q[2]],
            PrimKind::Cone => [q[0], 1.0 - q[1], q[2]],
            PrimKind::Disk | PrimKind::Square => [0.0, 1.0, 0.0],
        };
        apply_transpose(&self.w2o, n)
    }
}

/// A hit: t, primitive id, material, geometric normal (not normalised).
#[derive(Debug, Clone, Copy)]
struct WHit {
    t: f64,
    prim: u32,
    material: u32,
    normal: [f64; 3],
}

// ---------------------------------------------------------------- textures (f64)

fn hash(x: u32, y: u32, seed: u32) -> u32 {
    let mut h = x.wrapping_mul(0x8DA6_B343) ^ y.wrapping_mul(0xD816_3841) ^ seed.wrapping_mul(0xCB1A_B31F);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5BD1_E995);
    h ^ (h >> 15)
}

fn noise(i: u32, j: u32, n: u32, seed: u32) -> f64 {
    let cell = (n / 8).max(1);
    let cells = (n / cell).max(1);
    let (ix, iy) = (i / cell, j / cell);
    let fx = (i % cell) as f64 / cell as f64;
    let fy = (j % cell) as f64 / cell as f64;
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let v = |x: u32, y: u32| (hash(x, y, seed) >> 8) as f64 / 16_777_216.0;
    let (x1, y1) = ((ix + 1) % cells, (iy + 1) % cells);
    let top = v(ix, iy) + (v(x1, iy) - v(ix, iy)) * s(fx);
    let bot = v(ix, y1) + (v(x1, y1) - v(ix, y1)) * s(fx);
    top + (bot - top) * s(fy)
}

fn texel(e: &MaterialExt, c1: [f64; 3], i: u32, j: u32) -> [f64; 3] {
    let n = 1u32 << e.tex_log2.clamp(1, 12);
    let c2 = e.colour2.map(|c| c as f64);
    let mix = |m: f64| [0, 1, 2].map(|k| c1[k] * m + c2[k] * (1.0 - m));
    let tau = std::f64::consts::TAU;
    match e.texture {
        TextureKind::None => c1,
        TextureKind::Checker => {
            let cs = (n / (e.tex_param as u32).clamp(1, n)).max(1);
            if ((i / cs) + (j / cs)).is_multiple_of(2) {
                c1
            } else {
                c2
            }
        }
        TextureKind::Xor => mix((((i * 256 / n) ^ (j * 256 / n)) & 255) as f64 / 255.0),
        TextureKind::Marble => {
            let x = i as f64 / n as f64;
            mix(0.5 + 0.5 * (tau * (4.0 * x + e.tex_param as f64 * noise(i, j, n, e.tex_seed))).sin())
        }
        TextureKind::Wood => {
            let x = i as f64 / n as f64 - 0.5;
            let y = j as f64 / n as f64 - 0.5;
            let m = 0.5
                + 0.5 * (tau * (e.tex_param as f64 * (x * x + y * y).sqrt() + 0.5 * noise(i, j, n, e.tex_seed))).cos();
            mix(m * m)
        }
        TextureKind::RgbDots => {
            let cs = (n / (e.tex_param as u32).clamp(1, n)).max(1);
            let (ci, cj) = (i / cs, j / cs);
            let di = (2 * (i - ci * cs) + 1) as i64 - cs as i64;
            let dj = (2 * (j - cj * cs) + 1) as i64 - cs as i64;
            if 100 * (di * di + dj * dj) <= 49 * (cs as i64) * (cs as i64) {
                let mut c = [0.0; 3];
                c[((ci + cj) % 3) as usize] = 1.0;
                c
            } else {
                c2
            }
        }
    }
}

fn texture(e: &MaterialExt, c1: [f64; 3], p: [f64; 3]) -> [f64; 3] {
    let tau = std::f64::consts::TAU;
    let around = || {
        let u = p[0].atan2(p[2]) / tau;
        if u < 0.0 {
            u + 1.0
        } else {
            u
        }
    };
    let (u, v) = match e.mapping {
        Mapping::Planar => ((p[0] + 1.0) * 0.5, (p[2] + 1.0) * 0.5),
        Mapping::Cylindrical => (around(), (p[1] + 1.0) * 0.5),
        Mapping::Spherical => {
            let len = dot(p, p).sqrt();
            let c = if len > 0.0 { (p[1] / len).clamp(-1.0, 1.0) } else { 0.0 };
            (around(), 1.0 - c.acos() / std::f64::consts::PI)
        }
    };
    let u = u * e.uv_scale[0] as f64 + e.uv_offset[0] as f64;
    let v = v * e.uv_scale[1] as f64 + e.uv_offset[1] as f64;
    let (u, v) = (u - u.floor(), v - v.floor());
    let n = 1u32 << e.tex_log2.clamp(1, 12);
    let nf = n as f64;
    let wrap = |i: i64| i.rem_euclid(n as i64) as u32;
    if !e.bilinear {
        return texel(e, c1, wrap((u * nf).floor() as i64), wrap((v * nf).floor() as i64));
    }
    let (x, y) = (u * nf - 0.5, v * nf - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i0, j0) = (x0 as i64, y0 as i64);
    let t00 = texel(e, c1, wrap(i0), wrap(j0));
    let t10 = texel(e, c1, wrap(i0 + 1), wrap(j0));
    let t01 = texel(e, c1, wrap(i0), wrap(j0 + 1));
    let t11 = texel(e, c1, wrap(i0 + 1), wrap(j0 + 1));
    [0, 1, 2].map(|k| {
        let top = t00[k] + (t10[k] - t00[k]) * fx;
        let bot = t01[k] + (t11[k] - t01[k]) * fx;
        top + (bot - top) * fy
    })
}

// ---------------------------------------------------------------- shading (f64)

fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let c = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - sin2_t).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c = cos_i.clamp(0.0, 1.0);
    let (c2, s2) = (c * c, 1.0 - c * c);
    let (e2, k2) = (eta * eta, k * k);
    let t0 = e2 - k2 - s2;
    let a2b2 = (t0 * t0 + 4.0 * e2 * k2).max(0.0).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    let r = 0.5 * (rp + rs);
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

impl<'w> WorldReference<'w> {
    /// Prepares `world`; `grid_bounds` is the device's grid box (the ray-offset rule scales
    /// with its diagonal).
    pub fn new(world: &'w World, grid_bounds: &Bounds) -> Self {
        let t = world.mesh.triangles.len() as u32;
        let tris = (!world.mesh.triangles.is_empty()).then(|| ReferenceScene::new(&world.mesh, grid_bounds));
        let prims = world
            .prims
            .iter()
            .enumerate()
            .map(|(i, p)| Prim { kind: p.kind, w2o: from_wire(&p.to_object), material: p.material, id: t + i as u32 })
            .collect();
        let objects =
            world.objects.iter().map(|o| (o.first_prim, o.prim_count, from_wire(&o.world_to_object))).collect();
        Self { world, tris, prims, objects, grid_diag: grid_bounds.diagonal_len() }
    }

    fn closest(&self, o: [f64; 3], d: [f64; 3], t_max: f64) -> Option<WHit> {
        let mut best: Option<WHit> = None;
        if let Some(tris) = &self.tris {
            if let Some(h) = tris.closest_hit(o, d, t_max) {
                let tri = &self.world.mesh.triangles[h.prim as usize];
                let v = tri.v.map(|p| p.map(|c| c as f64));
                best = Some(WHit {
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
                    best = Some(WHit { t, prim: p.id, material: p.material, normal: p.normal(q) });
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
        let w = self.world;
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
            let mut lo = [0, 1, 2].map(|k| e.ka as f64 * cd[k] * la[k]);
            let nl = dot(h.normal, h.normal).sqrt();
            if !(nl > 0.0 && nl.is_finite()) {
                acc = add(acc, scale(lo, thr));
                break;
            }
            let mut n = scale(h.normal, 1.0 / nl);
            if dot(n, d) > 0.0 {
                n = scale(n, -1.0);
            }
            let v = normalize(scale(d, -1.0));
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
                        let fd = e.kd as f64 * diffuse(&e, n, l, v);
                        let fs = if st.specular { e.ks as f64 * specular(&e, n, l, v) } else { 0.0 };
                        let es = e_irr * spot;
                        for k in 0..3 {
                            lo[k] += es * rad[k] * (fd * cd[k] + fs * e.specular[k] as f64);
                        }
                    }
                }
            }
            acc = add(acc, scale(lo, thr));
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

fn diffuse(e: &MaterialExt, n: [f64; 3], l: [f64; 3], v: [f64; 3]) -> f64 {
    let inv_pi = std::f64::consts::FRAC_1_PI;
    match e.diffuse_model {
        DiffuseModel::Lambert => inv_pi,
        DiffuseModel::OrenNayar => {
            let s2 = e.sigma2 as f64;
            let a = 1.0 - s2 / (2.0 * (s2 + 0.33));
            let b = 0.45 * s2 / (s2 + 0.09);
            let ci = dot(n, l).clamp(-1.0, 1.0);
            let co = dot(n, v).clamp(-1.0, 1.0);
            let si = (1.0 - ci * ci).max(0.0).sqrt();
            let so = (1.0 - co * co).max(0.0).sqrt();
            let lp = sub(l, scale(n, ci));
            let vp = sub(v, scale(n, co));
            let (ll, vl) = (dot(lp, lp).sqrt(), dot(vp, vp).sqrt());
            let cos_phi = if ll > 0.0 && vl > 0.0 { (dot(lp, vp) / (ll * vl)).max(0.0) } else { 0.0 };
            let (sin_a, tan_b) = if ci < co {
                (si, if co > 0.0 { so / co } else { 0.0 })
            } else {
                (so, if ci > 0.0 { si / ci } else { 0.0 })
            };
            inv_pi * (a + b * cos_phi * sin_a * tan_b)
        }
    }
}

fn specular(e: &MaterialExt, n: [f64; 3], l: [f64; 3], v: [f64; 3]) -> f64 {
    let hv = add(l, v);
    if dot(hv, hv) == 0.0 {
        return 0.0;
    }
    let h = normalize(hv);
    let nh = dot(n, h).max(0.0);
    let ex = e.exponent as f64;
    let dist = (ex + 2.0) / std::f64::consts::TAU * nh.powf(ex);
    match e.specular_model {
        SpecularModel::None => 0.0,
        SpecularModel::BlinnPhong => dist,
        SpecularModel::TorranceSparrow => {
            let (no, ni, vh) = (dot(n, v), dot(n, l), dot(v, h));
            if no <= 0.0 || ni <= 0.0 || vh <= 0.0 {
                return 0.0;
            }
            let g = (2.0 * nh * no / vh).min(2.0 * nh * ni / vh).min(1.0);
            let f = match e.reflect_mode {
                ReflectMode::Conductor => fresnel_conductor(vh, e.eta as f64, e.kappa as f64),
                _ => fresnel_dielectric(vh, e.eta as f64),
            };
            dist * g * f / (4.0 * no * ni)
        }
    }
}

/// Renders a world with `threads` workers.
pub fn render(scene: &WorldReference<'_>, settings: &RenderSettings, stages: Stages, threads: usize) -> ReferenceImage {
    let cam = CameraF64::new(settings);
    render_pixels(settings, threads, |x, y| scene.shade_pixel(&cam, settings, stages, x, y))
}
