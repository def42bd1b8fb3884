//! ViRAY's shading model (seed 000 §4.6) for scene image v2, with the errata of the seed
//! summary corrected. Formulas are pinned in docs/CONTRACTS.md § "Shading, scene image v2";
//! the host's f64 reference (`host/src/reference_v2.rs`) re-implements them.
//!
//! For one hit with unit normal n (facing the ray), unit view vector v = −d/|d| and unit
//! light vector l = (light − p)/|light − p|:
//!
//! ```text
//! L_o = k_a·c_d∘L_a + vis · spot · E · c_L ∘ (k_d·c_d·f_d + k_s·c_s·f_s)
//! E   = max(n·l, 0) · (1/r² with inverse-square falloff, else 1)
//! ```
//! Corrections (seed 000 §8.3): the cosine uses l = light − p (the thesis writes p − light);
//! the spotlight factor uses the spot axis, `clamp((a·(p−light)/|p−light| − cos_o)/(cos_i −
//! cos_o), 0, 1)`, not n, and is a step function when `cos_i = cos_o` (no division by zero);
//! Fresnel uses the correct complex denominator (pbrt's exact conductor formula); exponents
//! are real (`fmath::pow`), not limited to 10 squarings; the mirror reflectance in Torrance–Sparrow
//! mode uses ∠(n, v) (for the mirror direction the half vector *is* n).

use gridrt_shared::math::Vec3;
#[cfg(feature = "specular")]
use gridrt_shared::scene_v2::SpecularModel;
use gridrt_shared::scene_v2::{DiffuseModel, Falloff, LightingRecord, MaterialExt, ReflectMode};

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
pub fn fresnel(ext: &MaterialExt, cos_i: f32) -> f32 {
    match ext.reflect_mode {
        ReflectMode::Conductor => fresnel_conductor(cos_i, ext.eta, ext.kappa),
        _ => fresnel_dielectric(cos_i, ext.eta),
    }
}

/// Mirror reflectance r of the material at `cos_o = n·v`; 0 = no reflection ray.
pub fn reflectance(ext: &MaterialExt, constant: f32, cos_o: f32) -> f32 {
    match ext.reflect_mode {
        ReflectMode::None => 0.0,
        ReflectMode::Constant => constant,
        ReflectMode::Dielectric => fresnel_dielectric(cos_o, ext.eta),
        ReflectMode::Conductor => fresnel_conductor(cos_o, ext.eta, ext.kappa),
    }
}

/// Spotlight factor at p (1 for an omnidirectional light).
pub fn spot_factor(lighting: &LightingRecord, light_pos: Vec3, p: Vec3) -> f32 {
    let Some(axis) = Vec3::from_array(lighting.spot_dir).try_normalize() else { return 1.0 };
    let Some(dir) = (p - light_pos).try_normalize() else { return 0.0 };
    let c = axis.dot(dir);
    let (co, ci) = (lighting.cos_outer, lighting.cos_inner);
    if ci > co {
        ((c - co) / (ci - co)).clamp(0.0, 1.0)
    } else if c >= co {
        1.0
    } else {
        0.0
    }
}

/// Irradiance factor E / |light colour|: `max(n·l, 0)` times the falloff.
pub fn irradiance(lighting: &LightingRecord, n: Vec3, p: Vec3, light_pos: Vec3) -> f32 {
    let d = light_pos - p;
    let r2 = d.length_squared();
    let Some(l) = d.try_normalize() else { return 0.0 };
    let cos = n.dot(l).max(0.0);
    match lighting.falloff {
        Falloff::None => cos,
        Falloff::InverseSquare => {
            if r2 > 0.0 {
                cos / r2
            } else {
                0.0
            }
        }
    }
}

/// Diffuse BRDF value (Lambert 1/π, or simplified Oren–Nayar).
pub fn diffuse_brdf(ext: &MaterialExt, n: Vec3, l: Vec3, v: Vec3) -> f32 {
    match ext.diffuse_model {
        DiffuseModel::Lambert => INV_PI,
        DiffuseModel::OrenNayar => {
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
            let cos_phi = match (lp.try_normalize(), vp.try_normalize()) {
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
    }
}

/// Specular BRDF value (0 without a specular model).
#[cfg(feature = "specular")]
pub fn specular_brdf(ext: &MaterialExt, n: Vec3, l: Vec3, v: Vec3) -> f32 {
    let Some(h) = (l + v).try_normalize() else { return 0.0 };
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

/// Direct term `spot · E · c_L ∘ (k_d·c_d·f_d + k_s·c_s·f_s)` for a visible light (the caller
/// multiplies by visibility and checks E > 0 and spot > 0 before tracing the shadow ray).
pub fn direct(
    ext: &MaterialExt,
    cd: [f32; 3],
    n: Vec3,
    v: Vec3,
    p: Vec3,
    light: &DirectLight,
    e_spot: f32,
) -> [f32; 3] {
    let Some(l) = (light.pos - p).try_normalize() else { return [0.0; 3] };
    let fd = ext.kd * diffuse_brdf(ext, n, l, v);
    #[cfg(feature = "specular")]
    let fs = if light.specular { ext.ks * specular_brdf(ext, n, l, v) } else { 0.0 };
    #[cfg(not(feature = "specular"))]
    let fs = 0.0;
    [0, 1, 2].map(|k| e_spot * light.radiance[k] * (fd * cd[k] + fs * ext.specular[k]))
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(feature = "specular")]
    use gridrt_shared::scene_v2::SpecularModel;

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
    fn spot_cone_edges_and_step() {
        let mut l =
            LightingRecord { spot_dir: [0.0, -1.0, 0.0], cos_outer: 0.7, cos_inner: 0.85, ..LightingRecord::default() };
        let at = |x: f32| Vec3::new(x, -1.0, 0.0);
        assert_eq!(spot_factor(&l, Vec3::ZERO, at(0.0)), 1.0);
        assert_eq!(spot_factor(&l, Vec3::ZERO, at(5.0)), 0.0);
        let mid = spot_factor(&l, Vec3::ZERO, at(0.8));
        assert!(mid > 0.0 && mid < 1.0);
        l.cos_inner = 0.7;
        assert_eq!(spot_factor(&l, Vec3::ZERO, at(0.9)), 1.0);
        assert_eq!(spot_factor(&l, Vec3::ZERO, at(1.1)), 0.0);
    }

    #[test]
    #[cfg(feature = "specular")]
    fn brdfs_reduce_and_normalise() {
        let n = Vec3::Y;
        let l = Vec3::new(0.3, 1.0, 0.1).normalize();
        let v = Vec3::new(-0.2, 1.0, 0.4).normalize();
        let mut e = MaterialExt { diffuse_model: DiffuseModel::OrenNayar, sigma2: 0.0, ..MaterialExt::default() };
        assert!((diffuse_brdf(&e, n, l, v) - INV_PI).abs() < 1e-6);
        e.sigma2 = 1.0;
        assert!(diffuse_brdf(&e, n, l, v) != INV_PI);
        // Blinn–Phong peak at the mirror configuration: (e+2)/(2π).
        let e = MaterialExt { specular_model: SpecularModel::BlinnPhong, exponent: 16.0, ..MaterialExt::default() };
        assert!((specular_brdf(&e, n, n, n) - 18.0 / TAU).abs() < 1e-4);
        let ts =
            MaterialExt { specular_model: SpecularModel::TorranceSparrow, exponent: 16.0, ..MaterialExt::default() };
        assert!(specular_brdf(&ts, n, l, v) >= 0.0);
    }
}
