//! Shading of a hit (docs/CONTRACTS.md § Shading): one module for every scene, meshes and
//! ViRAY's analytic scenes alike. A material's model picks the formula: GridRT's matte
//! surface (what OBJ/PLY materials get), Lambert or Oren–Nayar diffuse, optional Blinn–Phong
//! or Torrance–Sparrow specular, and a constant or Fresnel mirror reflectance.
//!
//! Stages the scene does not need cost nothing: the device's pipeline plan skips shadow rays,
//! reflection rays, textures and the specular term at run time, and the cargo features
//! `shadows`, `reflections`, `specular` and `textures` remove them from the build (ViRAY's
//! compile-time stage switches, ViRAY).
//!
//! | file | what |
//! |---|---|
//! | `geometry` | hit point, facing normal, shadow-ray origin and extent |
//! | `light` | the request's light, irradiance with falloff, spotlight cone |
//! | `brdf` | diffuse/specular models, Fresnel, reflectance, the outgoing radiance |
//! | `colour` | background, default albedo, the 8-bit rule |
//! | `bytes` | the 8-bit colour of a matte hit in fixed point, with the f32 rule's bytes |
//! | `factor` | the light's factor `max(n·l, 0)` estimated in integers, for `bytes`; dot-product signs |
//!
//! These are pure functions; the device (`crate::device`) calls them and owns the rays.

mod brdf;
mod bytes;
mod colour;
mod factor;
mod geometry;
mod light;

pub use brdf::{
    diffuse_brdf, direct, direct_reads_view, direct_toward, fresnel_conductor, fresnel_dielectric, outgoing,
    reflectance, DirectLight, DirectTerm,
};
#[cfg(feature = "specular")]
pub use brdf::{fresnel, specular_brdf};
pub use bytes::{MatteBytes, FAST_MATERIALS};
pub use colour::{clamp01, to_rgb8, to_u8, BACKGROUND, DEFAULT_ALBEDO};
pub use factor::{dot_sign, light_factor, LightFactor, FACTOR_ERROR};
pub use geometry::{
    facing, facing_normal, hit_point, shadow_epsilon, shadow_epsilon_from, shadow_ray, shadow_ray_from, UnitNormals,
    SHADOW_EPS_DIAG, SHADOW_EPS_POS, SHADOW_T_MAX,
};
pub use light::{
    irradiance, irradiance_toward, spot_axis, spot_factor, spot_factor_in, spot_factor_on, Light, SpotCone,
};
