//! The scene image the host builds and the device loads (SPEC.md §5): one layout, one version.
//!
//! ```text
//! header (64 B) ‖ voxel→PE map (nx·ny·nz B, padded to 4) ‖ material colours (16 B each)
//! ‖ material models (96 B each) ‖ objects (64 B each) ‖ lighting (80 B) ‖ PE blocks
//! [‖ point section (32 B head + 32 B per point), when the header has `scene_flags::POINTS`]
//! ```
//! A PE block is `pe u16 ‖ reserved u16 ‖ words u32 ‖ words × u32` where the words are the PE's
//! memory image ([`PeImage`]), loaded verbatim over FSL with a LOAD_PE packet. A mesh-only
//! scene is simply a scene with default lighting, matte materials and no objects.
//!
//! | file | what |
//! |---|---|
//! | `layout` | sizes, magic numbers, limits, [`SceneError`] |
//! | `header` | [`SceneHeader`] |
//! | `materials` | [`Material`] colours and [`MaterialModel`] shading models |
//! | `lights` | [`LightingRecord`] |
//! | `geometry` | triangle and analytic-primitive records, objects, affine maps |
//! | `pe_image` | [`PeImage`], the PE memory image |
//! | `points` | [`PointsHead`], [`PointRecord`]: the point section (flag [`scene_flags::POINTS`]) |
//! | `stream` | [`SceneStream`], the streaming parser, and [`SceneSink`] |
//! | `compact` | [`Unpacker`]: the compact upload stream (SPEC.md §5.12) decoded into image bytes |

// Link-facing: every index and every sum on received values is checked (ARCHITECTURE.md).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

mod compact;
mod geometry;
mod header;
mod layout;
mod lights;
mod materials;
mod pe_image;
mod points;
mod stream;

pub use compact::{
    compact_op, unzigzag, zigzag, CompactHeader, Sink as UnpackSink, Unpacker, COMPACT_HEADER_LEN, COMPACT_MAGIC,
    COMPACT_VERSION, HISTORY_WORDS, MAX_CACHE_LOG2, MAX_OP_LEN,
};
pub use geometry::{
    affine_point, affine_transpose_vector, affine_vector, Affine, ObjectKind, ObjectRecord, PrimKind, PrimRecord,
    TriangleRecord,
};
pub use header::SceneHeader;
pub use layout::{
    SceneError, EMPTY_VOXEL, HEADER_LEN, LIGHTING_LEN, MAGIC, MATERIAL_LEN, MATERIAL_MODEL_LEN, MAX_DEPTH, MAX_PES,
    MAX_VOXELS, OBJECT_LEN, PE_HEADER_WORDS, PE_IMAGE_TAG, PRIM_WORDS, TRIANGLE_WORDS, VERSION, VOXEL_ENTRY_WORDS,
};
pub use lights::{Falloff, LightingRecord};
pub use materials::{DiffuseModel, Mapping, Material, MaterialModel, ReflectMode, SpecularModel, TextureKind};
pub use pe_image::PeImage;
pub use points::{scene_flags, PointRecord, PointsHead, POINTS_HEAD_LEN, POINT_LEN};
pub use stream::{SceneSink, SceneStream};

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests;
