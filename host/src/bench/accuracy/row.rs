//! One result row of the bench, and why the bench could not run.

use std::path::PathBuf;

use crate::grid::GridError;
use crate::scene::SceneLoadError;

/// One row of `accuracy.csv`: one (scene, kernel, format).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AccuracyRow {
    /// Scene file name.
    pub scene: String,
    /// Triangles of the scene.
    pub triangles: u32,
    /// Kernel (`--isect` name).
    pub kernel: &'static str,
    /// Number format of the kernel.
    pub format: &'static str,
    /// Number format of the firmware's ray generation and DDA.
    pub raygen: &'static str,
    /// Image size.
    pub width: u16,
    /// Image size.
    pub height: u16,
    /// Rays traced per frame (primary + shadow rays sent to the model).
    pub rays: u64,
    /// Native wall time per traced ray, ns (best of `runs`, single thread).
    pub native_ns_per_ray: f64,
    /// Modelled cycles of one full test on GridRT's PE (static cost model).
    pub model_cycles_per_test: f64,
    /// Modelled co-processor cycles per traced ray (timed model, kernel-costed profile).
    pub model_cycles_per_ray: f64,
    /// Ray–triangle tests per traced ray in the timed model.
    pub model_tests_per_ray: f64,
    /// Soft-core instructions per ray, when known (see the module doc).
    pub fw_instructions_per_ray: Option<f64>,
    /// PSNR against the f64 reference, dB (`None`: identical images).
    pub psnr_db: Option<f64>,
    /// Largest channel difference against the reference (0–255).
    pub max_pixel_error: u8,
    /// Pixels whose primary primitive differs from the reference's, per pixel.
    pub hit_mismatch_rate: f64,
    /// Mean relative error of the primary hit distance against the exact reference.
    pub t_rel_err_mean: f64,
    /// Largest relative error of the primary hit distance against the exact reference.
    pub t_rel_err_max: f64,
    /// Probes that leaked, per probe crossing its disk.
    pub leak_rate: f64,
    /// Leaking probes.
    pub leaks: u64,
    /// Probes shot.
    pub probes: u64,
    /// Fixed-point overflows: tests in the native frame plus records flagged at load.
    pub overflows: u64,
    /// Bytes of the kernel's per-triangle record.
    pub bytes_per_triangle: usize,
    /// Operations of one full test (add + mul + div + cmp).
    pub ops_per_test: u32,
}

/// Why the bench could not run.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// A scene did not load.
    #[error("loading {path}: {source}")]
    Scene {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: SceneLoadError,
    },
    /// Its grid could not be built.
    #[error("building the grid of {scene}: {source}")]
    Grid {
        /// Scene name.
        scene: String,
        /// Why.
        #[source]
        source: GridError,
    },
    /// The camera of the default view was refused.
    #[error("camera of {scene}: {what}")]
    Camera {
        /// Scene name.
        scene: String,
        /// Why.
        what: String,
    },
    /// The co-processor model refused the configuration, a PE image or a ray.
    #[error("co-processor model ({scene}, {kernel}, {format}): {what}")]
    Coproc {
        /// Scene name.
        scene: String,
        /// Kernel name.
        kernel: &'static str,
        /// Format name.
        format: &'static str,
        /// What failed.
        what: String,
    },
    /// Writing an output file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Drawing the plot failed.
    #[error("drawing {path}: {what}")]
    Plot {
        /// The file.
        path: PathBuf,
        /// Why.
        what: String,
    },
}
