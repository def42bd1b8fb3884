//! Shading in f64, the same formulas as the firmware's `shade` module (docs/CONTRACTS.md
//! § Shading): the diffuse models (GridRT's matte, Lambert, Oren–Nayar), the specular models
//! (Blinn–Phong, Torrance–Sparrow), Fresnel, and the outgoing radiance.

use gridrt_shared::scene::{DiffuseModel, MaterialModel, ReflectMode, SpecularModel};

use super::vec3::{dot, normalize, sub};

/// `a + b`.
pub(super) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `s·a`.
pub(super) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

pub(super) fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
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

pub(super) fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
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

pub(super) fn diffuse(e: &MaterialModel, n: [f64; 3], l: [f64; 3], v: [f64; 3]) -> f64 {
    let inv_pi = std::f64::consts::FRAC_1_PI;
    match e.diffuse_model {
        DiffuseModel::Matte => 1.0,
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

pub(super) fn specular(e: &MaterialModel, n: [f64; 3], l: [f64; 3], v: [f64; 3]) -> f64 {
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

/// The light a visible point light delivers: `spot·E·c_L` per channel and the BRDF weights.
pub(super) struct DirectTerm {
    /// `spot · E · c_L`.
    pub light: [f64; 3],
    /// `k_d · f_d`.
    pub diffuse: f64,
    /// `k_s · f_s`.
    pub specular: f64,
}

/// Radiance leaving the surface (firmware `shade::outgoing`): ambient plus the direct term
/// when the light is visible; the matte form factors the albedo out.
pub(super) fn outgoing(e: &MaterialModel, cd: [f64; 3], la: [f64; 3], direct: Option<&DirectTerm>) -> [f64; 3] {
    let (ka, cs) = (e.ka as f64, e.specular.map(|c| c as f64));
    [0, 1, 2].map(|k| match (e.diffuse_model, direct) {
        (DiffuseModel::Matte, None) => cd[k] * (ka * la[k]),
        (DiffuseModel::Matte, Some(d)) => {
            cd[k] * (ka * la[k] + d.light[k] * d.diffuse) + d.light[k] * (d.specular * cs[k])
        }
        (_, None) => ka * cd[k] * la[k],
        (_, Some(d)) => ka * cd[k] * la[k] + d.light[k] * (d.diffuse * cd[k] + d.specular * cs[k]),
    })
}
