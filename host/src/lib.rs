//! Host library of the GridRT toolkit: everything the `gridrt` CLI does, as a library.
//!
//! | module | what |
//! |---|---|
//! | [`scene`] | OBJ (tobj) and PLY loading into a triangle [`scene::Mesh`] |
//! | [`grid`] | Eq. 6.1 resolution, SAT binning, voxel→PE map, PE memory images |
//! | [`image_format`] | the versioned scene image (`shared::scene`) |
//! | [`pipeline`] | mesh → grid → scene image in one call |
//! | [`camera`] | default camera/light and [`camera::RenderSettings`] (docs/CONTRACTS.md) |
//! | [`reference`](mod@reference) | independent f64 reference renderer (BVH + watertight test) |
//! | [`compare`] | PSNR and pixel/hit differences |
//! | [`flash`] | ELF → flash image, flashing through the bootloader (SPEC.md §3.11), progress events |
//! | [`serial`] | opening serial ports (no flush on open) and listing them |
//! | [`session`] | protocol client over any `Read + Write` byte transport, progress events |
//! | [`multi`] | one frame on several boards: work queue of row bands, merged result |
//! | [`link_bench`] | `gridrt bench link`: wire bytes, efficiency, compression, modelled frame time |
//! | [`stats`] | JSON statistics |
//! | [`scene_file`] | TOML scene files (docs/SCENE-FILE.md) → [`world::World`] |
//! | [`plan`] | the pipeline plan (which stages a scene needs) and `--interp` |
//! | [`reference_v2`] | f64 reference of scene-file worlds (analytic primitives, ViRAY shading) |
//! | [`world`] | analytic primitives, extended materials and lighting (scene image v2) |
//!
//! Errors are typed (`thiserror`); the library never prints. Progress is reported through
//! [`session::ProgressEvent`] callbacks, which only the binary draws.
#![warn(missing_docs)]

pub mod bench_accuracy;
pub mod camera;
pub mod compare;
pub mod flash;
pub mod grid;
pub mod image_format;
pub mod link_bench;
pub mod multi;
pub mod pipeline;
pub mod plan;
pub mod reference;
pub mod reference_v2;
pub mod scene;
pub mod scene_file;
pub mod serial;
pub mod session;
pub mod simrun;
pub mod stats;
pub mod world;
