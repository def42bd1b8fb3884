//! Surface response: the diffuse models (GridRT's matte surface, Lambert, Oren–Nayar), the
//! specular models (normalised Blinn–Phong, Torrance–Sparrow), Fresnel, the mirror
//! reflectance, and the radiance leaving a hit (docs/CONTRACTS.md § Shading).
//!
//! For one hit with unit normal n (facing the ray), unit view vector v = −d/|d| and unit
//! light vector l = (light − p)/|light − p|, with `D = spot·E·c_L` the light reaching p:
//!
//! ```text
//! Lambert, Oren–Nayar:  L_o = k_a·c_d∘L_a + vis·D∘(k_d·f_d·c_d + k_s·f_s·c_s)
//! Matte (GridRT):       L_o = c_d∘(k_a·L_a + vis·D·k_d) + vis·D∘k_s·f_s·c_s
//! ```
//! The matte form factors c_d out, as docs/CONTRACTS.md has always written a mesh's shading, so
//! OBJ/PLY scenes render bit for bit as before. ViRAY's model follows the ViRAY paper
//! with its errata corrected: the cosine uses l = light − p; Fresnel uses the correct
//! complex denominator (pbrt's exact conductor formula); exponents are real (`fmath::pow`),
//! not limited to 10 squarings; the mirror reflectance in Torrance–Sparrow mode uses ∠(n, v)
//! (for the mirror direction the half vector *is* n).

use crate::fmath::try_normalize;
use crate::sfloat::{add, mul};
use gridrt_shared::math::Vec3;
#[cfg(feature = "specular")]
use gridrt_shared::scene::SpecularModel;
use gridrt_shared::scene::{DiffuseModel, MaterialModel, ReflectMode};

const INV_PI: f32 = core::f32::consts::FRAC_1_PI;
#[cfg(feature = "specular")]
const TAU: f32 = core::f32::consts::TAU;

/// Unpolarised Fresnel reflectance of a dielectric of relative index `eta` at `cos_i` (> 0
/// from the outside); total internal reflection gives 1.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = libm::sqrtf(1.0 - sin2_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Unpolarised Fresnel reflectance of a conductor `eta − i·k` at `cos_i` (exact formula,
/// pbrt-v3 `FrConductor`; `k = 0` reduces to a dielectric without total reflection).
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let (e2, k2) = (eta * eta, k * k);
    let t0 = e2 - k2 - s2;
    let a2b2 = libm::sqrtf((t0 * t0 + 4.0 * e2 * k2).max(0.0));
    let t1 = a2b2 + c2;
    let a = libm::sqrtf((0.5 * (a2b2 + t0)).max(0.0));
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

/// Fresnel of a material at `cos_i` (conductor mode: complex index, else dielectric).
#[cfg(feature = "specular")]
pub fn fresnel(ext: &MaterialModel, cos_i: f32) -> f32 {
    match ext.reflect_mode {
        ReflectMode::Conductor => fresnel_conductor(cos_i, ext.eta, ext.kappa),
        _ => fresnel_dielectric(cos_i, ext.eta),
    }
}

/// Mirror reflectance r of the material at `cos_o = n·v`; 0 = no reflection ray.
pub fn reflectance(ext: &MaterialModel, constant: f32, cos_o: f32) -> f32 {
    match ext.reflect_mode {
        ReflectMode::None => 0.0,
        ReflectMode::Constant => constant,
        ReflectMode::Dielectric => fresnel_dielectric(cos_o, ext.eta),
        ReflectMode::Conductor => fresnel_conductor(cos_o, ext.eta, ext.kappa),
    }
}

/// Diffuse BRDF value (matte 1, Lambert 1/π, or simplified Oren–Nayar).
pub fn diffuse_brdf(ext: &MaterialModel, n: Vec3, l: Vec3, v: Vec3) -> f32 {
    match ext.diffuse_model {
        DiffuseModel::Matte => 1.0,
        DiffuseModel::Lambert => INV_PI,
        DiffuseModel::OrenNayar => oren_nayar(ext, n, l, v),
    }
}

/// The simplified Oren–Nayar BRDF. Out of line: inline, its registers were saved and
/// restored on every matte and Lambert hit too.
#[inline(never)]
fn oren_nayar(ext: &MaterialModel, n: Vec3, l: Vec3, v: Vec3) -> f32 {
    let s2 = ext.sigma2;
    let a = 1.0 - s2 / (2.0 * (s2 + 0.33));
    let b = 0.45 * s2 / (s2 + 0.09);
    let cos_i = n.dot(l).clamp(-1.0, 1.0);
    let cos_o = n.dot(v).clamp(-1.0, 1.0);
    let sin_i = libm::sqrtf((1.0 - cos_i * cos_i).max(0.0));
    let sin_o = libm::sqrtf((1.0 - cos_o * cos_o).max(0.0));
    // cos(φi − φo) from the tangent-plane projections.
    let lp = l - n * cos_i;
    let vp = v - n * cos_o;
    let cos_phi = match (try_normalize(lp), try_normalize(vp)) {
        (Some(a), Some(b)) => a.dot(b).max(0.0),
        _ => 0.0,
    };
    // α = max(θi, θo), β = min: sin α · tan β.
    let (sin_a, tan_b) = if cos_i < cos_o {
        (sin_i, if cos_o > 0.0 { sin_o / cos_o } else { 0.0 })
    } else {
        (sin_o, if cos_i > 0.0 { sin_i / cos_i } else { 0.0 })
    };
    INV_PI * (a + b * cos_phi * sin_a * tan_b)
}

/// Specular BRDF value (0 without a specular model). Out of line, as `oren_nayar`.
#[cfg(feature = "specular")]
#[inline(never)]
pub fn specular_brdf(ext: &MaterialModel, n: Vec3, l: Vec3, v: Vec3) -> f32 {
    let Some(h) = try_normalize(l + v) else { return 0.0 };
    let nh = n.dot(h).max(0.0);
    let d = (ext.exponent + 2.0) / TAU * crate::fmath::pow(nh, ext.exponent);
    match ext.specular_model {
        SpecularModel::None => 0.0,
        SpecularModel::BlinnPhong => d,
        SpecularModel::TorranceSparrow => {
            let (no, ni) = (n.dot(v), n.dot(l));
            let vh = v.dot(h);
            if no <= 0.0 || ni <= 0.0 || vh <= 0.0 {
                return 0.0;
            }
            let g = (2.0 * nh * no / vh).min(2.0 * nh * ni / vh).min(1.0);
            d * g * fresnel(ext, vh) / (4.0 * no * ni)
        }
    }
}

/// Everything the direct-lighting term needs besides the material.
#[derive(Debug, Clone, Copy)]
pub struct DirectLight {
    /// Light position.
    pub pos: Vec3,
    /// Light colour × intensity.
    pub radiance: [f32; 3],
    /// Specular stage on (the pipeline plan).
    pub specular: bool,
}

/// The light a visible point light delivers to a surface: `D = spot·E·c_L` with the BRDF
/// weights `k_d·f_d` and `k_s·f_s` for the light direction.
#[derive(Debug, Clone, Copy)]
pub struct DirectTerm {
    /// `spot · E · c_L` per channel.
    pub light: [f32; 3],
    /// `k_d · f_d`.
    pub diffuse: f32,
    /// `k_s · f_s` (0 without the specular stage).
    pub specular: f32,
}

/// The direct term at p for a light that reaches it with factor `e_spot = spot · E` (the
/// caller checks E > 0 and spot > 0 and traces the shadow ray first). `None` when the light
/// sits on p.
pub fn direct(ext: &MaterialModel, n: Vec3, v: Vec3, p: Vec3, light: &DirectLight, e_spot: f32) -> Option<DirectTerm> {
    let l = try_normalize(light.pos - p)?;
    Some(direct_toward(ext, n, v, l, light, e_spot))
}

/// True when [`direct_toward`] reads its view vector `v` (Oren–Nayar, or the specular
/// stage); matte and Lambert surfaces without it do not, and the pipeline skips computing v.
pub fn direct_reads_view(ext: &MaterialModel, light: &DirectLight) -> bool {
    ext.diffuse_model == DiffuseModel::OrenNayar || (cfg!(feature = "specular") && light.specular)
}

/// [`direct`] with the unit light vector `l` the irradiance computed already. Inline with an
/// FPU, as `outgoing`.
#[cfg_attr(not(soft_float), inline(always))]
pub fn direct_toward(ext: &MaterialModel, n: Vec3, v: Vec3, l: Vec3, light: &DirectLight, e_spot: f32) -> DirectTerm {
    let diffuse = ext.kd * diffuse_brdf(ext, n, l, v);
    #[cfg(feature = "specular")]
    let specular = if light.specular { ext.ks * specular_brdf(ext, n, l, v) } else { 0.0 };
    #[cfg(not(feature = "specular"))]
    let specular = 0.0;
    let [r, g, b] = light.radiance;
    DirectTerm { light: [mul(e_spot, r), mul(e_spot, g), mul(e_spot, b)], diffuse, specular }
}

/// Radiance leaving the surface towards the viewer (module doc): ambient `L_a` plus the
/// direct term when the light is visible. Inline with an FPU (a call and its arguments cost
/// about as much as its body).
#[cfg_attr(not(soft_float), inline(always))]
pub fn outgoing(ext: &MaterialModel, cd: [f32; 3], la: [f32; 3], direct: Option<&DirectTerm>) -> [f32; 3] {
    // The model decided once, the channels written out (per channel it was a match in each
    // of three closure calls, and `[0, 1, 2].map` kept a loop with its index in memory).
    // `crate::sfloat`'s arithmetic, in the order of the formulas:
    // cd·(ka·la), cd·(ka·la + D·kd) + D·(ks·cs), ka·cd·la, ka·cd·la + D·(kd·cd + ks·cs).
    let ka = ext.ka;
    let cs = ext.specular;
    match (ext.diffuse_model, direct) {
        (DiffuseModel::Matte, None) => rgb(|k| mul(cd[k], mul(ka, la[k]))),
        (DiffuseModel::Matte, Some(d)) => rgb(|k| {
            add(mul(cd[k], add(mul(ka, la[k]), mul(d.light[k], d.diffuse))), mul(d.light[k], mul(d.specular, cs[k])))
        }),
        (_, None) => rgb(|k| mul(mul(ka, cd[k]), la[k])),
        (_, Some(d)) => rgb(|k| {
            add(mul(mul(ka, cd[k]), la[k]), mul(d.light[k], add(mul(d.diffuse, cd[k]), mul(d.specular, cs[k]))))
        }),
    }
}

/// `[f(0), f(1), f(2)]`, each call inline.
#[inline(always)]
fn rgb(f: impl Fn(usize) -> f32) -> [f32; 3] {
    [f(0), f(1), f(2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(feature = "specular")]
    use gridrt_shared::scene::SpecularModel;

    #[test]
    fn fresnel_limits() {
        // Normal incidence: ((η−1)/(η+1))².
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_conductor(1.0, 1.5, 0.0) - 0.04).abs() < 1e-6);
        // Grazing: 1.
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        // Conductor at normal incidence: ((η−1)² + k²)/((η+1)² + k²).
        let want = ((0.33f32).powi(2) + 1.0) / ((2.33f32).powi(2) + 1.0);
        assert!((fresnel_conductor(1.0, 1.33, 1.0) - want).abs() < 1e-5);
        // Total internal reflection.
        assert_eq!(fresnel_dielectric(0.2, 0.7), 1.0);
    }

    #[test]
    fn matte_is_the_contract_formula() {
        // colour = albedo · (ambient + intensity · ndotl · visible), docs/CONTRACTS.md.
        let m = MaterialModel { diffuse_model: DiffuseModel::Matte, ..MaterialModel::default() };
        let light = DirectLight { pos: Vec3::new(0.0, 0.0, 10.0), radiance: [1.0; 3], specular: false };
        let d = direct(&m, Vec3::Z, Vec3::Z, Vec3::ZERO, &light, 1.0);
        let lit = outgoing(&m, [0.8; 3], [0.15; 3], d.as_ref());
        assert_eq!(lit, [0.8 * (0.15 + 1.0); 3]);
        // 0.92·255 + 0.5 = 235.1 → 235.
        assert_eq!(super::super::colour::to_rgb8(lit), [235, 235, 235]);
        let shadowed = outgoing(&m, [0.8, 0.4, 0.2], [0.15; 3], None);
        assert_eq!(shadowed, [0.8 * 0.15, 0.4 * 0.15, 0.2 * 0.15]);
    }

    #[test]
    fn lambert_divides_by_pi() {
        let m = MaterialModel::default();
        let light = DirectLight { pos: Vec3::new(0.0, 0.0, 10.0), radiance: [2.0; 3], specular: false };
        let d = direct(&m, Vec3::Z, Vec3::Z, Vec3::ZERO, &light, 1.0);
        let lit = outgoing(&m, [0.5; 3], [0.0; 3], d.as_ref());
        assert!((lit[0] - 0.5 * 2.0 / core::f32::consts::PI).abs() < 1e-6, "{lit:?}");
    }

    #[test]
    #[cfg(feature = "specular")]
    fn brdfs_reduce_and_normalise() {
        let n = Vec3::Y;
        let l = Vec3::new(0.3, 1.0, 0.1).normalize();
        let v = Vec3::new(-0.2, 1.0, 0.4).normalize();
        let mut e = MaterialModel { diffuse_model: DiffuseModel::OrenNayar, sigma2: 0.0, ..MaterialModel::default() };
        assert!((diffuse_brdf(&e, n, l, v) - INV_PI).abs() < 1e-6);
        e.sigma2 = 1.0;
        assert!(diffuse_brdf(&e, n, l, v) != INV_PI);
        // Blinn–Phong peak at the mirror configuration: (e+2)/(2π).
        let e = MaterialModel { specular_model: SpecularModel::BlinnPhong, exponent: 16.0, ..MaterialModel::default() };
        assert!((specular_brdf(&e, n, n, n) - 18.0 / TAU).abs() < 1e-4);
        let ts = MaterialModel {
            specular_model: SpecularModel::TorranceSparrow,
            exponent: 16.0,
            ..MaterialModel::default()
        };
        assert!(specular_brdf(&ts, n, l, v) >= 0.0);
    }
}
