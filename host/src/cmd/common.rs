//! Option groups shared by subcommands (`#[clap(flatten)]`ed).

use std::path::PathBuf;

use anyhow::Context;
use gridrt_coproc::{KernelKind, TimingProfile};
use gridrt_host::grid::PeMapping;
use gridrt_host::scene::Scene;

/// Where the device is.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Connection")]
pub struct PortOptions {
    /// Use the in-process loopback simulator (firmware device loop + co-processor model),
    /// reached only through an in-memory UART byte stream.
    #[arg(long, required_unless_present_any = ["port", "sim_devices"], conflicts_with = "port")]
    pub sim: bool,
    /// Serial port of a board or of QEMU's pty (e.g. /dev/ttyUSB0, /dev/pts/3). Repeat it for
    /// several boards: the frame is split into row bands that the boards take from a shared
    /// queue as they finish, and merged.
    #[arg(long, value_name = "PATH")]
    pub port: Vec<String>,
    /// Render on N simulated boards at once (implies --sim), splitting the frame as with
    /// several --port.
    #[arg(long, value_name = "N", conflicts_with = "port", value_parser = clap::value_parser!(u16).range(1..=64))]
    pub sim_devices: Option<u16>,
    /// Deliver the simulated boards' output no faster than --baud (8N1), so wall time and
    /// load balancing follow the modelled line rate.
    #[arg(long)]
    pub sim_paced: bool,
    /// Baud rate for --port (and the line rate of the modelled link time).
    #[arg(long, default_value_t = 115_200, value_name = "BAUD")]
    pub baud: u32,
    /// Seconds the device may go without answering before the render fails: without any
    /// message while rendering, without a new acknowledgement while uploading the scene.
    #[arg(long, default_value_t = 120.0, value_name = "SECONDS")]
    pub timeout: f64,
}

/// Scene file and grid build.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Scene and grid")]
pub struct SceneOptions {
    /// Scene file: Wavefront .obj (with .mtl materials), .ply, or a .toml scene file with
    /// analytic primitives, materials, textures and a light (docs/SCENE-FILE.md).
    #[arg(long, value_name = "PATH")]
    pub scene: PathBuf,
    /// Processing elements of the co-processor (1..=255).
    #[arg(long, default_value_t = 4, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=255))]
    pub pes: u16,
    /// Words of memory per PE [default: what the device reports (the simulator: 1048576);
    /// bench: the largest PE image].
    #[arg(long, value_name = "W")]
    pub pe_mem_words: Option<u32>,
    /// Grid resolution multiplier m of GridRT Eq. 6.1 (n_i = floor(m·w_i/s) + 1).
    #[arg(long, default_value_t = 1.0, value_name = "M", value_parser = positive_f64)]
    pub grid_m: f64,
    /// Voxel→PE mapping.
    #[arg(long, value_enum, default_value_t = Mapping::Interleaved)]
    pub mapping: Mapping,
}

fn positive_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("`{s}` is not a positive number")),
    }
}

impl SceneOptions {
    /// Loads the scene: a mesh (.obj, .ply) with defaults or a scene file (.toml,
    /// docs/SCENE-FILE.md).
    pub fn load(&self) -> anyhow::Result<Scene> {
        gridrt_host::scene::load(&self.scene).with_context(|| format!("loading scene {}", self.scene.display()))
    }
}

/// Voxel→PE mapping choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Mapping {
    /// (ix + iy + iz) mod N: consecutive voxels of a ray go to different PEs.
    Interleaved,
    /// N contiguous slabs along x (GridRT's spatial split).
    Slabs,
}

impl From<Mapping> for PeMapping {
    fn from(m: Mapping) -> Self {
        match m {
            Mapping::Interleaved => PeMapping::Interleaved,
            Mapping::Slabs => PeMapping::Slabs,
        }
    }
}

/// Co-processor model choices (simulator and bench).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Co-processor model")]
pub struct ModelOptions {
    /// Intersection kernel every PE runs (f32; `gridrt bench accuracy` compares the
    /// fixed-point formats).
    #[arg(long, visible_alias = "isect", value_enum, default_value_t = Kernel::Watertight)]
    pub kernel: Kernel,
    /// Cycle model of the simulator (does not affect the image).
    #[arg(long, value_enum, default_value_t = Timing::Gridrt)]
    pub timing: Timing,
}

/// Intersection kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Kernel {
    /// Woop–Benthin–Wald watertight test with a conservative t bound.
    Watertight,
    /// Möller–Trumbore.
    MollerTrumbore,
    /// Wald's projection test with precomputed per-triangle data (TriAccel).
    Wald,
    /// Hanika–Keller's projection test with pre-divided edges.
    HanikaKeller,
    /// GridRT's Cramer's-rule test.
    Cramer,
}

impl From<Kernel> for KernelKind {
    fn from(k: Kernel) -> Self {
        match k {
            Kernel::Watertight => KernelKind::Watertight,
            Kernel::MollerTrumbore => KernelKind::MollerTrumbore,
            Kernel::Wald => KernelKind::Wald,
            Kernel::HanikaKeller => KernelKind::HanikaKeller,
            Kernel::Cramer => KernelKind::Cramer,
        }
    }
}

/// Cycle models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Timing {
    /// GridRT's multi-cycle PE: 648 cycles per test at 50 MHz.
    Gridrt,
    /// A pipelined PE.
    Pipelined,
}

impl From<Timing> for TimingProfile {
    fn from(t: Timing) -> Self {
        match t {
            Timing::Gridrt => TimingProfile::GRIDRT,
            Timing::Pipelined => TimingProfile::PIPELINED,
        }
    }
}
