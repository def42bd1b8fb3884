//! Host library of the GridRT toolkit: everything the `gridrt` CLI does, as a library.
//!
//! | module | what |
//! |---|---|
//! | [`scene`] | the one scene model ([`scene::Scene`]: meshes, analytic primitives, materials, textures, lights, camera) and its loaders: OBJ (tobj), PLY, TOML scene files (docs/SCENE-FILE.md) |
//! | [`grid`] | Eq. 6.1 resolution, SAT binning, voxel→PE map, PE memory images |
//! | [`image_format`] | the versioned scene image (`shared::scene`) |
//! | [`scene_image`] | [`scene_image::PreparedScene`]: scene → grid → scene image in one call |
//! | [`bounds`] | axis-aligned bounds ([`bounds::Bounds`]), below the scene model and the camera |
//! | [`camera_path`] | camera paths of a frame stream: an orbit about the scene's centre, a scene file's keyframes |
//! | [`render_settings`] | [`render_settings::RenderSettings`]: camera, light, size, flags of a frame and their defaults (docs/CONTRACTS.md) |
//! | [`reference`](mod@reference) | independent f64 reference renderer (BVH + watertight test, analytic primitives, f64 shading) |
//! | [`compare`] | PSNR and pixel/hit differences |
//! | [`flash`] | ELF → flash image, flashing through the bootloader (SPEC.md §3.11, windowed §3.14), progress events |
//! | [`faults`] | a faulty serial line: seeded bit flips, drops and bursts; a paced relay between two pseudo-terminals; a timed session over it |
//! | [`serial`] | opening serial ports (no flush on open) and listing them |
//! | [`session`] | protocol client over any `Read + Write` byte transport, progress events |
//! | [`native`] | the fast native ray path: firmware DDA + co-processor search laid out for a CPU (SIMD, threads), word-identical results |
//! | [`sim_board`] | [`sim_board::SimBoard`]: one frame on the in-process loopback simulator |
//! | [`multi`] | one frame on several boards: work queue of row bands, merged result |
//! | [`bench`] | every bench behind `gridrt bench`: [`bench::accuracy`], [`bench::link`], [`bench::link_faults`], [`bench::frame`], [`bench::splat`] |
//! | [`stream`] | frames as a stream: one request per frame along a camera path, on one board or several, frame times, fps and line utilisation |
//! | [`view`] | `--view`: a tiny HTTP server on 127.0.0.1 showing the frame filling in and the stream's figures |
//! | [`stats`] | JSON statistics |
//! | [`plan`] | the pipeline plan (which stages a scene needs) and `--interp` |
//!
//! Errors are typed (`thiserror`); the library never prints. Progress is reported through
//! [`session::ProgressEvent`] callbacks, which only the binary draws.
#![warn(missing_docs)]

pub mod bench;
pub mod bounds;
pub mod camera_path;
pub mod compact;
pub mod compare;
pub mod faults;
pub mod flash;
pub mod grid;
pub mod image_format;
pub mod multi;
pub mod native;
pub mod plan;
pub mod points;
pub mod reference;
pub mod render_settings;
pub mod scene;
pub mod scene_image;
pub mod serial;
pub mod session;
pub mod sim_board;
pub mod stats;
pub mod stream;
pub mod view;
