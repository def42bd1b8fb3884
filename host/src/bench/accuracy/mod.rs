//! Accuracy against run time: every intersection kernel in every number format, on bundled
//! scenes, compared with the f64 reference renderer — the library behind
//! `gridrt bench accuracy` (after the kernel comparison of Andrade Guerra 2020).
//!
//! For each scene the grid and PE images are built once and the f64 reference image is
//! rendered once ([`crate::reference`]). Then for each (kernel, number format):
//!
//! 1. **Native frame.** The firmware's own code renders the frame on the host — its camera
//!    (`gridrt_firmware::camera`), 3D-DDA list (`gridrt_firmware::dda`), shading and shadow
//!    rays (`gridrt_firmware::shade`, the device's formulas) — with the co-processor model's
//!    untimed path as the intersector (`Coprocessor::trace_untimed_with_info`), single
//!    threaded. `native_ns_per_ray` = best wall time of `runs` frames / rays traced (primary
//!    and shadow rays sent to the model). The image is compared with the reference:
//!    `psnr_db` (`inf` when identical), `max_pixel_error` (largest channel difference,
//!    0–255) and `hit_mismatch_rate` (pixels whose primary primitive id differs). Because an
//!    8-bit image often cannot tell the formats apart, the geometric error is reported too:
//!    `t_rel_err_mean` / `t_rel_err_max`, the relative error of the primary hit distance
//!    against the exact reference (`gridrt_coproc::exact`, f64) on the same f32 ray, over the
//!    pixels that hit the reference's primitive.
//! 2. **Timed model.** The same frame through the timed path with the GridRT profile costed
//!    for this kernel and format (`TimingProfile::for_kernel`): `model_cycles_per_ray` and
//!    `model_tests_per_ray`. `model_cycles_per_test` is the static per-test cost
//!    (`gridrt_coproc::test_cycles`: op counts × per-format op cycles).
//! 3. **Leaks.** `probes` rays aimed exactly at shared edges and vertices of the scene's
//!    mesh, crossing the surface transversally there; a probe leaks when the kernel hits no
//!    triangle of the disk around its aim point although the exact predicates say the ray
//!    crosses it (`gridrt_coproc::probe`). `leak_rate` = leaks / probes crossing their disk.
//!
//! `fw_instructions_per_ray` is left empty: soft-core instruction counts come from a render
//! of the firmware image under QEMU (`gridrt render --stats`, `instructions_per_primary_ray`),
//! not from this native run. `overflows` counts fixed-point range overflows (tests reported
//! by the model, plus records flagged at load): they are reported, never wrapped.
//!
//! The plot (`write_plot`, SVG) shows, per (kernel, format), the error (top: worst-scene
//! image MSE; bottom: worst-scene mean relative t error) against the native run time (left)
//! and against the modelled co-processor cycles per test (right), Pareto fronts marked.

use std::time::Instant;

use crate::grid::{build, GridParams};
use crate::reference::{render as reference_render, Reference, Stages};
use crate::render_settings::RenderSettings;
use crate::scene;

mod options;
mod probes;
mod report;
mod row;
mod scene_run;
#[cfg(test)]
mod tests;

pub use options::{scenes_dir, AccuracyOptions, DEFAULT_SCENES};
pub use report::{pareto_front, summarize, to_csv, write_csv, write_plot, Summary, CSV_HEADER};
pub use row::{AccuracyError, AccuracyRow};

use probes::ProbeSet;
use scene_run::SceneRun;

/// Progress of [`run`], in order: for each scene `Scene`, then one `Row` per configuration.
#[derive(Debug)]
pub enum AccuracyEvent<'a> {
    /// A scene is loaded, its grid built and its reference rendered.
    Scene {
        /// Scene name.
        name: &'a str,
        /// Triangles.
        triangles: u32,
        /// Reference render time, ms.
        reference_ms: f64,
    },
    /// A configuration is done.
    Row(&'a AccuracyRow),
}

/// Runs the bench (module doc). Deterministic except for the timings.
pub fn run(
    opts: &AccuracyOptions,
    progress: &mut dyn FnMut(AccuracyEvent<'_>),
) -> Result<Vec<AccuracyRow>, AccuracyError> {
    let mut rows = Vec::new();
    for path in &opts.scenes {
        let mesh = scene::load_mesh(path).map_err(|source| AccuracyError::Scene { path: path.clone(), source })?;
        let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
        let params = GridParams { m: opts.grid_m, pe_count: opts.pes, pe_mem_words: u32::MAX, ..GridParams::default() };
        let grid = build(&mesh, &params).map_err(|source| AccuracyError::Grid { scene: name.clone(), source })?;
        let settings =
            RenderSettings::default_for(&grid.mesh_bounds).with_size(opts.width, opts.height).with_prim_ids(true);
        let start = Instant::now();
        let shaded = scene::Scene::from_mesh(mesh.clone());
        let reference = reference_render(
            &Reference::new(&shaded, &grid.bounds),
            &settings,
            Stages { shadows: settings.shadows, reflections: false, textures: false, specular: false },
            opts.threads,
        );
        let reference_ms = start.elapsed().as_secs_f64() * 1e3;
        progress(AccuracyEvent::Scene { name: &name, triangles: grid.triangle_count, reference_ms });
        let scene = SceneRun::new(&name, &mesh, &grid, &settings, opts)?;
        let probes = ProbeSet::new(&mesh);
        for &kind in &opts.kernels {
            for &format in &opts.formats {
                let row = scene.row(kind, format, &reference, &probes, opts)?;
                progress(AccuracyEvent::Row(&row));
                rows.push(row);
            }
        }
    }
    Ok(rows)
}
