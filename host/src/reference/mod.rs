//! The independent f64 reference renderer every device image is compared with.
//!
//! It shares no intersection or traversal code with the device path: an f64 BVH instead of
//! the uniform grid, the watertight ray–triangle test in f64 instead of the co-processor
//! kernels, and its own f64 shading of the same formulas (docs/CONTRACTS.md).
//!
//! | file | what |
//! |---|---|
//! | `renderer` | [`Reference`]: rays, hits, shadows, reflections, one pixel |
//! | `bvh` | [`TriangleBvh`] and the watertight test |
//! | `analytic` | ViRAY's primitives in f64 |
//! | `shading` | BRDFs, Fresnel, outgoing radiance |
//! | `texture` | procedural textures in f64 |
//! | `camera` | [`CameraF64`], the f64 pinhole camera of docs/CONTRACTS.md |
//! | `vec3` | f64 3-vector helpers |
//! | `frame` | [`ReferenceImage`], the row workers, the 8-bit rule |

mod analytic;
mod bvh;
mod camera;
mod frame;
mod renderer;
mod shading;
mod texture;
mod vec3;

pub use bvh::{Hit, TriangleBvh};
pub use camera::CameraF64;
pub use frame::{render_pixels, to_rgb8, ReferenceImage, MISS_ID};
pub use renderer::{render, Reference, Stages, SHADOW_T_MAX};

#[cfg(test)]
mod tests;
