//! What the accuracy bench runs: scenes, size, kernels, formats, repetitions.

use std::path::{Path, PathBuf};

use gridrt_coproc::{KernelKind, NumberFormat};
use gridrt_firmware::fixed::RayFormat;

/// The bundled scenes the bench runs by default (in `tests/scenes/`).
pub const DEFAULT_SCENES: [&str; 4] = ["bun_zipper_res4.obj", "suzanne.obj", "teapot.obj", "cornell_box.obj"];

/// Directory of the bundled scenes.
pub fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
}

/// What to run.
#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    /// Scene files (OBJ or PLY).
    pub scenes: Vec<PathBuf>,
    /// Image width (one primary ray per pixel).
    pub width: u16,
    /// Image height.
    pub height: u16,
    /// Kernels.
    pub kernels: Vec<KernelKind>,
    /// Number formats of the co-processor kernels.
    pub formats: Vec<NumberFormat>,
    /// Number format of the firmware's ray generation and DDA.
    pub raygen: RayFormat,
    /// Timed native frames per configuration (the best counts).
    pub runs: u32,
    /// Watertightness probes per configuration.
    pub probes: u32,
    /// PEs of the modelled co-processor.
    pub pes: u16,
    /// Grid resolution multiplier (GridRT Eq. 6.1).
    pub grid_m: f64,
    /// Threads of the reference renderer.
    pub threads: usize,
    /// Seed of the probe rays.
    pub seed: u64,
}

impl AccuracyOptions {
    /// The defaults: the bundled scenes at 160×120, every kernel in every format, f32 ray
    /// generation, 5 timed runs, 20 000 probes, 4 PEs, m = 1.
    pub fn new() -> Self {
        Self {
            scenes: DEFAULT_SCENES.iter().map(|s| scenes_dir().join(s)).collect(),
            width: 160,
            height: 120,
            kernels: KernelKind::ALL.to_vec(),
            formats: NumberFormat::ALL.to_vec(),
            raygen: RayFormat::F32,
            runs: 5,
            probes: 20_000,
            pes: 4,
            grid_m: 1.0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            seed: 0xACC0_2026,
        }
    }
}

impl Default for AccuracyOptions {
    fn default() -> Self {
        Self::new()
    }
}
