//! Option groups shared by subcommands (`#[clap(flatten)]`ed).

use std::path::PathBuf;

use anyhow::Context;
use gridrt_coproc::{KernelKind, NumberFormat, TimingProfile};
use gridrt_host::grid::PeMapping;
use gridrt_host::scene::Scene;

/// Built-in baud rate (the firmware's default line rate).
pub const DEFAULT_BAUD: u32 = 115_200;

/// Where the device is.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Connection")]
pub struct PortOptions {
    /// Use the in-process loopback simulator (firmware device loop + co-processor model),
    /// reached only through an in-memory UART byte stream.
    #[arg(long)]
    pub sim: bool,
    /// Serial port of a board or of QEMU's pty (e.g. /dev/ttyUSB0, /dev/pts/3). Repeat it for
    /// several boards: the frame is split into row bands that the boards take from a shared
    /// queue as they finish, and merged. [default: `port` of gridrt.toml]
    #[arg(short = 'p', long, value_name = "PATH", env = "GRIDRT_PORT")]
    pub port: Vec<String>,
    /// Render on N simulated boards at once (implies --sim), splitting the frame as with
    /// several --port.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=64))]
    pub sim_devices: Option<u16>,
    /// Deliver the simulated boards' output no faster than --baud (8N1), so wall time and
    /// load balancing follow the modelled line rate.
    #[arg(long)]
    pub sim_paced: bool,
    /// Baud rate for --port (and the line rate of the modelled link time) [default:
    /// `baud` of gridrt.toml, else 115200].
    #[arg(short = 'b', long, value_name = "BAUD", env = "GRIDRT_BAUD")]
    pub baud: Option<u32>,
    /// The board id the device must report (0 simulator, 1 qemu-virt, 2 FPGA SoC, 3 LiteX)
    /// [default: `board` of gridrt.toml, else any].
    #[arg(long, value_name = "ID")]
    pub board: Option<u8>,
    /// Seconds the render may go without a new pixel (the device's ray work) before it
    /// fails. Every other wait is derived from --baud and the bytes expected.
    #[arg(long, default_value_t = 120.0, value_name = "SECONDS")]
    pub timeout: f64,
    /// Allowance per exchange on top of the wire time derived from --baud (USB adapter,
    /// operating system, device).
    #[arg(long, default_value_t = 30, value_name = "MS")]
    pub turnaround: u64,
}

impl PortOptions {
    /// Applies gridrt.toml (values not given as a flag or in the environment) and checks the
    /// connection: a port or the simulator, not both. `GRIDRT_PORT` is ignored with --sim.
    pub fn resolve(&mut self) -> anyhow::Result<()> {
        let config = super::config::load()?;
        self.resolve_with(&config, std::env::var("GRIDRT_PORT").ok())
    }

    /// [`resolve`](Self::resolve) with a given configuration and `GRIDRT_PORT`.
    pub fn resolve_with(&mut self, config: &super::config::Config, env_port: Option<String>) -> anyhow::Result<()> {
        let sim = self.sim || self.sim_devices.is_some();
        if sim && !self.port.is_empty() {
            let from_env = env_port.is_some_and(|e| self.port == [e]);
            anyhow::ensure!(from_env, "--sim and --port exclude each other: render on the simulator or on a board");
            self.port.clear();
        }
        if !sim && self.port.is_empty() {
            match &config.port {
                Some(p) => self.port.push(p.clone()),
                None => anyhow::bail!(
                    "no board given: use --port PATH (or GRIDRT_PORT, or `port` in gridrt.toml), or --sim for the simulator"
                ),
            }
        }
        self.baud = Some(self.baud.or(config.baud).unwrap_or(DEFAULT_BAUD));
        anyhow::ensure!(self.baud != Some(0), "--baud 0: the baud rate must be positive");
        self.board = self.board.or(config.board);
        Ok(())
    }

    /// The baud rate in force ([`resolve`](Self::resolve) applies gridrt.toml).
    pub fn baud(&self) -> u32 {
        self.baud.unwrap_or(DEFAULT_BAUD)
    }

    /// Fails with a one-line error naming a `--port` that does not exist.
    pub fn check_ports_exist(&self) -> anyhow::Result<()> {
        for p in &self.port {
            check_port_exists(p)?;
        }
        Ok(())
    }
}

/// Fails with a one-line error when serial port `path` does not exist (Unix device paths;
/// other systems open it to find out).
pub fn check_port_exists(path: &str) -> anyhow::Result<()> {
    if cfg!(unix) && !std::path::Path::new(path).exists() {
        anyhow::bail!("serial port {path} does not exist (`gridrt ports` lists the machine's ports)");
    }
    Ok(())
}

/// The grid's resolution: GridRT Eq. 6.1's multiplier and the most voxels it may give
/// (`render`, `bench rays`, `bench frame`, `bench pe-cache`, ...).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct GridResolution {
    /// Grid resolution multiplier m of GridRT Eq. 6.1 (n_i = floor(m·w_i/s) + 1): smaller means
    /// fewer, fuller voxels (fewer 3D-DDA steps for the soft-core, more tests for the
    /// co-processor).
    #[arg(long, default_value_t = 1.0, value_name = "M", value_parser = positive_f64)]
    pub grid_m: f64,
    /// Most voxels of the grid: a mesh whose Eq. 6.1 grid holds more gets the largest m below
    /// --grid-m that fits [default: 16581375 = 255³, no cap]. A coarser grid costs the
    /// soft-core fewer 3D-DDA steps per ray and the co-processor more tests: it pays where PE
    /// memory is fast (block RAM, the simulator's model), and costs a board whose PE images sit
    /// in SDRAM behind caches (docs/bench-firmware.md, "Cost independent of mesh size").
    #[arg(long, default_value_t = gridrt_host::grid::MAX_VOXELS, hide_default_value = true, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub grid_max_voxels: u32,
}

/// Scene file and grid build.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Scene and grid")]
pub struct SceneOptions {
    /// Scene file: Wavefront .obj (with .mtl materials), .ply, or a .toml scene file with
    /// analytic primitives, materials, textures and a light (docs/SCENE-FILE.md).
    #[arg(short = 's', long, value_name = "PATH")]
    pub scene: PathBuf,
    /// Processing elements of the co-processor (1..=255).
    #[arg(long, default_value_t = 4, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=255))]
    pub pes: u16,
    /// Words of memory per PE [default: what the device reports (the simulator: 1048576);
    /// bench: the largest PE image].
    #[arg(long, value_name = "W")]
    pub pe_mem_words: Option<u32>,
    #[command(flatten)]
    pub grid: GridResolution,
    /// Voxel→PE mapping.
    #[arg(long, value_enum, default_value_t = Mapping::Interleaved)]
    pub mapping: Mapping,
}

/// `--pe-cache-lines` (render) and `--soc-pe-cache-lines` (bench frame): 0, or a power of two
/// in 4..=4096.
pub(crate) fn pe_cache_lines(s: &str) -> Result<u32, String> {
    let n: u32 = s.parse().map_err(|_| format!("`{s}` is not a number of lines"))?;
    if n == 0 || (n.is_power_of_two() && (4..=4096).contains(&n)) {
        Ok(n)
    } else {
        Err(format!("{n}: expected 0 or a power of two in 4..=4096"))
    }
}

pub(crate) fn positive_f64(s: &str) -> Result<f64, String> {
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

/// Co-processor choices of the simulator (and the bench).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Co-processor")]
pub struct ModelOptions {
    /// What computes in the simulator: the Rust model, or the RTL co-processor in Verilator
    /// (built on first use by `cargo xtask rtl sim`; watertight in fixed64-q23, its own
    /// cycles).
    #[arg(long, value_enum, default_value_t = Coproc::Model)]
    pub coproc: Coproc,
    /// Intersection kernel every PE runs [default: watertight].
    #[arg(long, visible_alias = "isect", value_enum)]
    pub kernel: Option<Kernel>,
    /// Number format of the kernel [default: f32; with --coproc rtl: fixed64-q23].
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Cycle model of the simulator (does not affect the image) [default: gridrt; with
    /// --coproc rtl: rtl, the RTL's measured cycles].
    #[arg(long, value_enum)]
    pub timing: Option<Timing>,
    /// Threads the simulated board traces a frame's rows on (0 = every core; 1 = the
    /// device thread alone, as firmware does). The bytes it sends do not depend on it.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub sim_threads: u16,
    /// 0 keeps each PE's memory in block RAM; N keeps it in an external memory read through
    /// a cache of N 8-word lines per PE (a power of two, 4..=4096; the SoC's PE caches,
    /// rtl/README.md section 4.6). The image is the same either way. With --coproc rtl the
    /// RTL counts the cycles it stands still for its caches; with --coproc model (and
    /// --timing rtl) the model counts them, as the RTL would with the Verilator harness's
    /// memory. Printed in the summary, not in the co-processor cycles.
    #[arg(long, default_value_t = 0, value_name = "LINES", value_parser = pe_cache_lines)]
    pub pe_cache_lines: u32,
    /// With --pe-cache-lines: the external memory's latency in cycles, the same for every
    /// request (the Verilator harness's --mem-latency). Real SDRAM varies: on the SoC the
    /// model's stall cycles are an estimate.
    #[arg(long, default_value_t = 8, value_name = "CYCLES", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub pe_mem_latency: u32,
}

impl ModelOptions {
    /// The simulated board: `pes` PEs of `pe_mem_words` words (default: the simulator's, or
    /// the RTL build's 16 384), with the chosen co-processor. The RTL computes one pair,
    /// watertight / fixed64-q23, with its own timing: asking it for another is an error.
    pub fn sim_config(&self, pes: u16, pe_mem_words: Option<u32>) -> anyhow::Result<gridrt_loopback::SimConfig> {
        let kernel = self.kernel.unwrap_or(Kernel::Watertight);
        match self.coproc {
            Coproc::Model => {
                let timing = self.timing.unwrap_or(Timing::Gridrt);
                if self.pe_cache_lines != 0 && timing != Timing::Rtl {
                    anyhow::bail!(
                        "--pe-cache-lines with --coproc model times the RTL's caches: give --timing rtl (the RTL's timeline)"
                    );
                }
                let d = gridrt_loopback::SimConfig::default();
                let config = gridrt_loopback::SimConfig {
                    pe_count: pes,
                    pe_mem_words: pe_mem_words.unwrap_or(d.pe_mem_words),
                    timing: timing.into(),
                    kernel: kernel.into(),
                    format: self.format.unwrap_or(Format::F32).into(),
                    threads: self.sim_threads,
                    pe_cache_lines: self.pe_cache_lines,
                    pe_mem_latency: self.pe_mem_latency,
                    ..d
                };
                if let Some(caches) = config.pe_caches() {
                    caches.validate(&config.coproc()).map_err(|e| {
                        anyhow::anyhow!(
                            "--pe-cache-lines {} with {} PEs of {} words: {e}",
                            self.pe_cache_lines,
                            config.pe_count,
                            config.pe_mem_words
                        )
                    })?;
                }
                Ok(config)
            }
            Coproc::Rtl => {
                let rtl = gridrt_loopback::SimConfig::RTL;
                let format = self.format.unwrap_or(Format::Fixed64Q23);
                if KernelKind::from(kernel) != rtl.kernel || NumberFormat::from(format) != rtl.format {
                    anyhow::bail!(
                        "--coproc rtl computes {} / {}; use --coproc model for --kernel {} --format {}",
                        rtl.kernel.name(),
                        rtl.format.name(),
                        KernelKind::from(kernel).name(),
                        NumberFormat::from(format).name()
                    );
                }
                if self.timing.is_some_and(|t| t != Timing::Rtl) {
                    anyhow::bail!("--coproc rtl counts its own cycles: --timing rtl (or leave it out)");
                }
                let lines = self.pe_cache_lines;
                let words = pe_mem_words.unwrap_or(rtl.pe_mem_words);
                if lines != 0 && u64::from(lines) * 8 >= u64::from(words) {
                    anyhow::bail!("--pe-cache-lines {lines}: a cache of {lines} × 8 words must be smaller than --pe-mem-words {words}");
                }
                Ok(gridrt_loopback::SimConfig {
                    pe_count: pes,
                    pe_mem_words: pe_mem_words.unwrap_or(rtl.pe_mem_words),
                    pe_cache_lines: lines,
                    pe_mem_latency: self.pe_mem_latency,
                    ..rtl
                })
            }
        }
    }

    /// Kernel, format and timing for the stats: what `config` computes with.
    pub fn facts(config: &gridrt_loopback::SimConfig) -> gridrt_host::stats::CoprocFacts {
        gridrt_host::stats::CoprocFacts {
            coproc: match config.backend {
                gridrt_loopback::Backend::Model => "model",
                gridrt_loopback::Backend::Rtl => "rtl",
            }
            .to_string(),
            kernel: config.kernel.name().to_string(),
            format: config.format.name().to_string(),
            timing: config.timing.name.to_string(),
        }
    }
}

/// Co-processors of the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Coproc {
    /// The Rust model (gridrt-coproc).
    Model,
    /// The RTL (rtl/hdl) in Verilator.
    Rtl,
}

/// Number formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// IEEE-754 single precision.
    F32,
    /// Q8.23 fixed point in the scene's box, wide intermediates (the RTL's format).
    #[value(name = "fixed64-q23")]
    Fixed64Q23,
    /// Q15.16 fixed point, 32-bit intermediates.
    #[value(name = "fixed32-q16")]
    Fixed32Q16,
}

impl From<Format> for NumberFormat {
    fn from(f: Format) -> Self {
        match f {
            Format::F32 => NumberFormat::F32,
            Format::Fixed64Q23 => NumberFormat::Fixed64Q23,
            Format::Fixed32Q16 => NumberFormat::Fixed32Q16,
        }
    }
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
    /// GridRT's multi-cycle PE at 50 MHz, charged at the running kernel's cycles per test
    /// (watertight f32: 1188; GridRT's own program: 648).
    Gridrt,
    /// A pipelined PE.
    Pipelined,
    /// The RTL co-processor's measured timeline.
    Rtl,
}

impl From<Timing> for TimingProfile {
    fn from(t: Timing) -> Self {
        match t {
            Timing::Gridrt => TimingProfile::GRIDRT,
            Timing::Pipelined => TimingProfile::PIPELINED,
            Timing::Rtl => TimingProfile::RTL,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        model: ModelOptions,
    }

    fn sim(args: &[&str]) -> anyhow::Result<gridrt_loopback::SimConfig> {
        let cli = Cli::try_parse_from(std::iter::once("t").chain(args.iter().copied()))?;
        cli.model.sim_config(4, Some(16384))
    }

    /// `--pe-cache-lines` with the model times the RTL's caches, so it needs the RTL's
    /// timeline; the memory latency reaches the board either way.
    #[test]
    fn pe_cache_lines_with_the_model_need_the_rtl_timing_and_carry_the_latency() {
        assert!(sim(&["--pe-cache-lines", "512"]).is_err());
        let m = sim(&["--pe-cache-lines", "512", "--timing", "rtl", "--pe-mem-latency", "23"]).unwrap();
        assert_eq!((m.pe_cache_lines, m.pe_mem_latency, m.farm_threads()), (512, 23, 1));
        let r = sim(&["--coproc", "rtl", "--pe-cache-lines", "16", "--pe-mem-latency", "1"]).unwrap();
        assert_eq!((r.pe_cache_lines, r.pe_mem_latency), (16, 1));
        assert_eq!(sim(&[]).unwrap().pe_mem_latency, 8);
        assert!(sim(&["--pe-mem-latency", "0"]).is_err());
    }
}
