//! The point light at a hit: the request's light (position, intensity, ambient), the
//! irradiance factor with its falloff, and ViRAY's spotlight cone (ViRAY, with the
//! summary's erratum: the cone uses the spot axis, not n).

use crate::fmath::try_normalize;
use crate::sfloat;
use gridrt_shared::math::Vec3;
use gridrt_shared::scene::{Falloff, LightingRecord};

/// Point light and ambient term of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Light position.
    pub pos: Vec3,
    /// Scale of the diffuse term.
    pub intensity: f32,
    /// Ambient term.
    pub ambient: f32,
}

/// The unit spot axis of the light; `None` for an omnidirectional light. The same for every
/// hit of a frame: the pipeline computes it once.
pub fn spot_axis(lighting: &LightingRecord) -> Option<Vec3> {
    try_normalize(Vec3::from_array(lighting.spot_dir))
}

/// Spotlight factor at p (1 for an omnidirectional light).
pub fn spot_factor(lighting: &LightingRecord, light_pos: Vec3, p: Vec3) -> f32 {
    spot_factor_on(lighting, spot_axis(lighting), light_pos, p)
}

/// [`spot_factor`] with the frame's [`spot_axis`].
pub fn spot_factor_on(lighting: &LightingRecord, axis: Option<Vec3>, light_pos: Vec3, p: Vec3) -> f32 {
    spot_factor_in(axis.map(|axis| SpotCone::new(lighting, axis)).as_ref(), light_pos, p)
}

/// A spotlight's cone as [`spot_factor_in`] reads it, once per frame: the unit axis, the
/// cosines and the cone's width `cos_inner − cos_outer` (computed per hit it was a
/// subtraction that the compiler hoisted in front of every camera ray's path, a soft-float
/// call per traced pixel, spotlight or not).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotCone {
    axis: Vec3,
    cos_outer: f32,
    cos_inner: f32,
    width: f32,
}

impl SpotCone {
    /// The cone of `lighting` around the unit `axis` ([`spot_axis`]).
    pub fn new(lighting: &LightingRecord, axis: Vec3) -> Self {
        let (co, ci) = (lighting.cos_outer, lighting.cos_inner);
        Self { axis, cos_outer: co, cos_inner: ci, width: ci - co }
    }

    /// The frame's cone; `None` for an omnidirectional light.
    pub fn of(lighting: &LightingRecord) -> Option<Self> {
        spot_axis(lighting).map(|axis| Self::new(lighting, axis))
    }
}

/// [`spot_factor`] with the frame's [`SpotCone`] (`None`: omnidirectional, factor 1).
/// Inline, so that an omnidirectional light costs no call; the cone out of line.
#[inline(always)]
pub fn spot_factor_in(cone: Option<&SpotCone>, light_pos: Vec3, p: Vec3) -> f32 {
    match cone {
        None => 1.0,
        Some(cone) => spot_factor_of_cone(cone, light_pos, p),
    }
}

/// [`spot_factor_in`] for a spotlight.
#[inline(never)]
fn spot_factor_of_cone(cone: &SpotCone, light_pos: Vec3, p: Vec3) -> f32 {
    let Some(dir) = try_normalize(p - light_pos) else { return 0.0 };
    let c = cone.axis.dot(dir);
    let (co, ci) = (cone.cos_outer, cone.cos_inner);
    if ci > co {
        ((c - co) / cone.width).clamp(0.0, 1.0)
    } else if c >= co {
        1.0
    } else {
        0.0
    }
}

/// Irradiance factor E / |light colour|: `max(n·l, 0)` times the falloff.
pub fn irradiance(lighting: &LightingRecord, n: Vec3, p: Vec3, light_pos: Vec3) -> f32 {
    irradiance_toward(lighting, n, p, light_pos).0
}

/// [`irradiance`] and the unit light vector `l = (light − p)/|light − p|` it used (`None`,
/// with E = 0, when the light sits on p): the direct term reuses `l`. Inline with an FPU (a
/// call and its arguments cost about as much as its body).
#[cfg_attr(not(soft_float), inline(always))]
pub fn irradiance_toward(lighting: &LightingRecord, n: Vec3, p: Vec3, light_pos: Vec3) -> (f32, Option<Vec3>) {
    let d = sfloat::vsub(light_pos, p);
    let Some(l) = try_normalize(d) else { return (0.0, None) };
    let cos = sfloat::dot(n, l).max(0.0);
    let e = match lighting.falloff {
        Falloff::None => cos,
        Falloff::InverseSquare => {
            let r2 = d.length_squared();
            if r2 > 0.0 {
                cos / r2
            } else {
                0.0
            }
        }
    };
    (e, Some(l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_behind_surface_gives_zero_irradiance() {
        let l = LightingRecord { falloff: Falloff::None, ..LightingRecord::default() };
        assert_eq!(irradiance(&l, Vec3::Z, Vec3::ZERO, Vec3::new(0.0, 0.0, -3.0)), 0.0);
        assert_eq!(irradiance(&l, Vec3::Z, Vec3::ZERO, Vec3::ZERO), 0.0);
        assert_eq!(irradiance(&l, Vec3::Z, Vec3::ZERO, Vec3::new(0.0, 0.0, 10.0)), 1.0);
        let sq = LightingRecord { falloff: Falloff::InverseSquare, ..l };
        assert_eq!(irradiance(&sq, Vec3::Z, Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)), 0.25);
    }

    /// The factor with the frame's cone is `spot_factor`'s, whose cone width was computed per
    /// hit: random cones (the inner cosine above, equal to or below the outer one) and points.
    #[test]
    fn the_frames_cone_gives_spot_factor() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5B07_C0DE);
        for _ in 0..20_000 {
            let co = rng.gen_range(-1.0..1.0f32);
            let ci = if rng.gen_bool(0.1) { co } else { rng.gen_range(-1.0..1.0f32) };
            let spot_dir = [0; 3].map(|_| rng.gen_range(-1.0..1.0f32));
            let l = LightingRecord { spot_dir, cos_outer: co, cos_inner: ci, ..LightingRecord::default() };
            let light = Vec3::from_array([0; 3].map(|_| rng.gen_range(-5.0..5.0f32)));
            let p = Vec3::from_array([0; 3].map(|_| rng.gen_range(-5.0..5.0f32)));
            let cone = SpotCone::of(&l);
            let want = spot_factor_per_hit(&l, light, p);
            assert_eq!(spot_factor(&l, light, p).to_bits(), want.to_bits());
            assert_eq!(spot_factor_in(cone.as_ref(), light, p).to_bits(), want.to_bits(), "{l:?} {p:?}");
        }
    }

    /// The reference for `the_frames_cone_gives_spot_factor`: the factor with the cone's width
    /// computed per hit.
    fn spot_factor_per_hit(lighting: &LightingRecord, light_pos: Vec3, p: Vec3) -> f32 {
        let Some(axis) = spot_axis(lighting) else { return 1.0 };
        let Some(dir) = try_normalize(p - light_pos) else { return 0.0 };
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
}
