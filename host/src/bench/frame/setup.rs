//! What a frame bench is asked for: targets, configurations, the soft-core profile, the
//! options, the progress events and the errors.

use std::collections::BTreeMap;
use std::path::PathBuf;

use gridrt_coproc::{KernelKind, NumberFormat, TimingProfile};
use gridrt_shared::msg::PixelEncoding;
use serde::Serialize;

use crate::session::ProgressEvent;

/// A soft-core instruction set the firmware is built for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Target {
    /// RV32IMAC: soft float.
    Riscv32imac,
    /// RV32IMAFC: single-precision hard float.
    Riscv32imafc,
}

impl Target {
    /// Both, in report order.
    pub const ALL: [Target; 2] = [Target::Riscv32imac, Target::Riscv32imafc];

    /// Its name (also `cargo xtask firmware --target`).
    pub fn name(self) -> &'static str {
        match self {
            Target::Riscv32imac => "riscv32imac",
            Target::Riscv32imafc => "riscv32imafc",
        }
    }

    /// Parses [`Target::name`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == s)
    }
}

/// A configuration of the board a row describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Configuration {
    /// No co-processor: the firmware intersects by itself with the same kernel.
    SoftCoreOnly,
    /// GridRT's multi-cycle PEs, at the kernel-true cycles per test.
    Gridrt,
    /// The pipelined PE profile.
    Pipelined,
    /// The RTL co-processor (`rtl/`): its kernel and number format (watertight, fixed64-q23)
    /// and [`TimingProfile::RTL`], which matches its Verilator simulation to the cycle.
    Rtl,
    /// The native path on this CPU, wall time.
    HostNative,
    /// The LiteX SoC (VexRiscv full+cfu or imac, [`SocFloatHw`], + the RTL co-processor)
    /// simulated cycle by cycle in Verilator: every figure measured by the SoC's own counters
    /// (`soc` module).
    Soc,
}

/// Where a configuration's co-processor time comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CoprocCycles {
    /// No co-processor (the soft-core intersects).
    None,
    /// The loopback simulator with this profile (made kernel-true by the simulator).
    Model(TimingProfile),
    /// Not modelled: wall time on this CPU.
    HostWall,
    /// Measured on the simulated SoC, with everything else.
    SocSim,
}

/// The firmware image a soft-core configuration runs on QEMU (`cargo xtask firmware`
/// features).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Image {
    /// The virtual co-processor with the default kernel (watertight f32).
    Coproc,
    /// The virtual co-processor with the RTL's kernel, format and timing (`coproc-rtl`).
    CoprocRtl,
    /// No co-processor (`soft-core-only`).
    SoftCoreOnly,
}

impl Image {
    /// The image's extra cargo features.
    pub fn features(self) -> &'static [&'static str] {
        match self {
            Image::Coproc => &[],
            Image::CoprocRtl => &["coproc-rtl"],
            Image::SoftCoreOnly => &["soft-core-only"],
        }
    }

    /// Its name in progress lines and errors.
    pub fn name(self) -> &'static str {
        match self {
            Image::Coproc => "co-processor",
            Image::CoprocRtl => "co-processor (rtl kernel)",
            Image::SoftCoreOnly => "soft-core-only",
        }
    }
}

impl Configuration {
    /// Every configuration, in report order.
    pub const ALL: [Configuration; 6] = [
        Configuration::SoftCoreOnly,
        Configuration::Gridrt,
        Configuration::Pipelined,
        Configuration::Rtl,
        Configuration::HostNative,
        Configuration::Soc,
    ];

    /// Its name in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Configuration::SoftCoreOnly => "soft-core-only",
            Configuration::Gridrt => "gridrt",
            Configuration::Pipelined => "pipelined",
            Configuration::Rtl => "rtl",
            Configuration::HostNative => "host-native",
            Configuration::Soc => "soc",
        }
    }

    /// Parses [`Configuration::name`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == s)
    }

    /// Where its co-processor time comes from.
    pub fn coproc(self) -> CoprocCycles {
        match self {
            Configuration::SoftCoreOnly => CoprocCycles::None,
            Configuration::Gridrt => CoprocCycles::Model(TimingProfile::GRIDRT),
            Configuration::Pipelined => CoprocCycles::Model(TimingProfile::PIPELINED),
            Configuration::Rtl => CoprocCycles::Model(TimingProfile::RTL),
            Configuration::HostNative => CoprocCycles::HostWall,
            Configuration::Soc => CoprocCycles::SocSim,
        }
    }

    /// The intersection kernel and number format it runs: the RTL's for `rtl`, [`kernel`]
    /// otherwise.
    pub fn kernel(self) -> (KernelKind, NumberFormat) {
        match self {
            Configuration::Rtl | Configuration::Soc => (KernelKind::Watertight, NumberFormat::Fixed64Q23),
            _ => kernel(),
        }
    }

    /// The firmware image its soft-core instructions are measured on (`None`: host-native).
    pub fn image(self) -> Option<Image> {
        match self {
            Configuration::SoftCoreOnly => Some(Image::SoftCoreOnly),
            Configuration::Gridrt | Configuration::Pipelined => Some(Image::Coproc),
            Configuration::Rtl => Some(Image::CoprocRtl),
            Configuration::HostNative | Configuration::Soc => None,
        }
    }

    /// The co-processor's clock, Hz, and where it comes from: the bench's clock, one clock
    /// domain with the soft-core (as in the SoC, where both run on `sys_clk`).
    pub fn coproc_clock(self, clock_mhz: f64) -> (f64, &'static str) {
        (clock_mhz * 1e6, "--clock-mhz (one clock domain with the soft-core, as in the SoC)")
    }

    /// True when it runs on the soft-core (QEMU-measured instructions).
    pub fn on_soft_core(self) -> bool {
        self != Configuration::HostNative
    }
}

/// A soft-core timing profile: cycles = instructions × `cpi`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CpuProfile {
    /// Name (`--cpu-profile`).
    pub name: &'static str,
    /// Cycles per instruction.
    pub cpi: f64,
    /// Where the CPI comes from.
    pub citation: &'static str,
}

impl CpuProfile {
    /// PicoRV32, the one RV32 soft-core whose documentation states a CPI.
    pub const PICORV32: CpuProfile = CpuProfile {
        name: "picorv32",
        cpi: 4.1,
        citation: "YosysHQ/picorv32 README: \"For the Dhrystone benchmark the average CPI is 4.100\" \
                   (ENABLE_FAST_MUL, ENABLE_DIV, BARREL_SHIFTER, look-ahead memory interface; \
                   5.232 without it). PicoRV32 has no FPU: for riscv32imafc the CPI is applied to \
                   the F instructions too, an assumption",
    };

    /// One instruction per cycle: an in-order scalar core that never stalls, the bound of any
    /// single-issue soft-core (VexRiscv documents 1.44 DMIPS/MHz, not a CPI; the SoC issue
    /// measures it).
    pub const CPI1: CpuProfile = CpuProfile {
        name: "cpi1",
        cpi: 1.0,
        citation: "definition: a single-issue core that never stalls (upper bound of a scalar soft-core's speed)",
    };

    /// The SoC's CPU as built: VexRiscv imac (LiteX `imac` variant, 4 KiB caches), its CPI
    /// measured by its own `mcycle`/`minstret` over a whole frame in the SoC's Verilator
    /// simulation (`gridrt bench frame --scene tests/scenes/bun_zipper_res4.obj --configs soc`,
    /// docs/bench-history/2026-11-30-whole-frame-first-soc.md). A run with a `soc` row charges
    /// the riscv32imac rows each stage's CPI measured in that run instead.
    pub const VEXRISCV_IMAC: CpuProfile = CpuProfile {
        name: "vexriscv-imac",
        cpi: 2.73,
        citation: "measured: VexRiscv imac in the LiteX SoC's cycle-accurate simulation, mcycle / minstret over \
                   the firmware's stages of a bun_zipper_res4 frame (docs/bench-history/2026-11-30-whole-frame-first-soc.md). It has no \
                   FPU: for riscv32imafc the CPI is applied to the F instructions too, an assumption",
    };

    /// The presets.
    pub const ALL: [CpuProfile; 3] = [CpuProfile::VEXRISCV_IMAC, CpuProfile::PICORV32, CpuProfile::CPI1];

    /// Parses [`CpuProfile::name`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name == s)
    }
}

/// Cycles per instruction of each firmware stage, measured on a soft-core: the device's
/// per-stage `mcycle` and `minstret` of one frame (`device_counters` `stage_<stage>_cycles` /
/// `stage_<stage>_instret` of a `gridrt render --port … --stats` JSON), e.g. the LiteX SoC's
/// VexRiscv in Verilator (soc/README.md). A core without an FPU measures the soft-float
/// image: it applies to `riscv32imac` only.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeasuredCpi {
    /// The core (`vexriscv-imac`).
    pub core: String,
    /// The stats file it came from.
    pub source: String,
    /// Per stage (`raygen`, `traverse`, `fsl_io`, `shade`, `encode`): `(cycles, instructions)`.
    pub by_stage: BTreeMap<String, (u64, u64)>,
}

impl MeasuredCpi {
    /// Reads the per-stage counters of the stats JSON `text` (from `source`). Every stage
    /// must have counted instructions, and no stage fewer cycles than instructions.
    pub fn from_stats_json(core: &str, source: &str, text: &str) -> Result<Self, String> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("{source}: {e}"))?;
        let counters = &v["device_counters"];
        let mut by_stage = BTreeMap::new();
        for stage in gridrt_firmware::device::Stage::ALL {
            let name = crate::stats::stage_name(stage);
            let get = |what: &str| counters[format!("stage_{name}_{what}")].as_u64();
            match (get("cycles"), get("instret")) {
                (Some(c), Some(i)) if i > 0 && c >= i => {
                    by_stage.insert(name.to_string(), (c, i));
                }
                (c, i) => {
                    return Err(format!(
                        "{source}: stage {name}: {c:?} cycles for {i:?} instructions (need `stage_{name}_cycles` \
                         and `stage_{name}_instret` from a soft-core with mcycle/minstret)"
                    ))
                }
            }
        }
        Ok(Self { core: core.to_string(), source: source.to_string(), by_stage })
    }

    /// Cycles per instruction of `stage` (its name).
    pub fn cpi(&self, stage: &str) -> Option<f64> {
        self.by_stage.get(stage).map(|&(c, i)| c as f64 / i as f64)
    }
}

/// What `gridrt bench frame` measures.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Scene file.
    pub scene: PathBuf,
    /// Frame width.
    pub width: u16,
    /// Frame height.
    pub height: u16,
    /// Clock of the soft-core and the co-processor, MHz (every row, the `soc` row's too).
    pub clock_mhz: f64,
    /// Where it comes from: `"routed"`, `"target"` or `"option"`.
    pub clock_source: &'static str,
    /// Line rate.
    pub baud: u32,
    /// Pixel encoding.
    pub encoding: PixelEncoding,
    /// Grid resolution multiplier m of GridRT Eq. 6.1, for every row.
    pub grid_m: f64,
    /// Most voxels of the grid, for every row (`GridParams::max_voxels`).
    pub grid_max_voxels: u32,
    /// The `soc` row's CPU: floating point in hardware or not.
    pub soc_float_hw: SocFloatHw,
    /// The `soc` row's L2 cache in front of its SDRAM, KiB (None: the SoC's default).
    pub soc_l2_kib: Option<u32>,
    /// The `soc` row's CPUs (1 to 4: workers trace rows beside the first hart).
    pub soc_harts: u32,
    /// The `soc` row's PE memories: 0 block RAM, N the PE images in SDRAM behind caches of N
    /// 8-word lines (and `--sim --coproc rtl` the same).
    pub soc_pe_cache_lines: u32,
    /// Bytes the UART holds while the line drains them (`timeline`).
    pub tx_buffer_bytes: u64,
    /// Soft-core profile.
    pub cpu: CpuProfile,
    /// Per-stage CPI measured on a soft-core without FPU: replaces `cpu` in the
    /// `riscv32imac` rows (`cpu_source` = `"rtl"`).
    pub measured_cpi: Option<MeasuredCpi>,
    /// Configurations, in report order.
    pub configs: Vec<Configuration>,
    /// Soft-core targets, in report order.
    pub targets: Vec<Target>,
    /// host-native: untimed frames first, then the best of `native_runs`.
    pub native_warmup: u32,
    /// host-native: timed frames.
    pub native_runs: u32,
    /// The repository (to build the firmware images with `cargo xtask firmware`).
    pub repo: PathBuf,
}

impl BenchOptions {
    /// The `soc` row's clock and line: the bench's.
    pub fn soc_clock(&self) -> SocClock {
        SocClock { clock_mhz: self.clock_mhz, source: self.clock_source, baud: self.baud }
    }
}

/// Floating point in hardware on the SoC's CPU (`cargo xtask soc sim --float-hw`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SocFloatHw {
    /// VexRiscv imac, f32 in soft float; the firmware for riscv32imac.
    None,
    /// VexRiscv full+cfu with the f32 CFU (`gridrt_cfu_f32`); the firmware for riscv32im
    /// with `cfu-float`. The default, as in `cargo xtask soc sim`: fewer frame cycles,
    /// measured (docs/bench-frame.md, "Where the harts' time goes").
    #[default]
    Cfu,
}

impl SocFloatHw {
    /// Its name in the report and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SocFloatHw::None => "none",
            SocFloatHw::Cfu => "cfu",
        }
    }

    /// The firmware's target (the row's `target`).
    pub fn target(self) -> &'static str {
        match self {
            SocFloatHw::None => "riscv32imac",
            SocFloatHw::Cfu => "riscv32im",
        }
    }

    /// The CPU (the row's `cpu_profile`).
    pub fn cpu(self) -> &'static str {
        match self {
            SocFloatHw::None => "vexriscv-imac",
            SocFloatHw::Cfu => "vexriscv-full+cfu",
        }
    }
}

/// The SoC's clock and line, as the row reports them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SocClock {
    /// The clock the SoC's cycles are converted at, MHz.
    pub clock_mhz: f64,
    /// `"routed"` (a `cargo xtask soc build --json` report's fmax) or `"target"`.
    pub source: &'static str,
    /// The UART's line rate in simulated time (8N1).
    pub baud: u32,
}

impl SocClock {
    /// The routed clock of a `cargo xtask soc build --json` report (`fmax_mhz`), capped at its
    /// target clock (the PLL runs there; a higher fmax is margin, not speed).
    pub fn from_build_report(text: &str, baud: u32) -> Result<Self, String> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
        let fmax = v["fmax_mhz"].as_f64().ok_or("no `fmax_mhz` in the report (nothing was routed?)")?;
        let target = v["target_mhz"].as_f64().unwrap_or(fmax);
        if !(fmax.is_finite() && fmax > 0.0) {
            return Err(format!("fmax_mhz {fmax} is not a clock"));
        }
        Ok(Self { clock_mhz: fmax.min(target), source: "routed", baud })
    }
}

/// What the bench reports while it works.
#[derive(Debug, Clone, PartialEq)]
pub enum BenchEvent {
    /// A step starts.
    Step(String),
    /// Progress of a session (upload, render) of run `run`.
    Session {
        /// Which run.
        run: String,
        /// The event.
        event: ProgressEvent,
    },
}

/// Why the bench could not report.
#[derive(Debug, thiserror::Error)]
pub enum FrameBenchError {
    /// The scene did not load.
    #[error("loading the scene: {0}")]
    Scene(#[from] crate::scene::LoadError),
    /// The grid could not be built.
    #[error("building the grid: {0}")]
    Grid(#[from] crate::grid::GridError),
    /// A session failed.
    #[error(transparent)]
    Session(#[from] crate::session::SessionError),
    /// The pty could not be opened.
    #[error(transparent)]
    Serial(#[from] crate::serial::SerialError),
    /// An image did not build.
    #[error("building the firmware: {0}")]
    Build(String),
    /// QEMU failed.
    #[error("QEMU: {0}")]
    Qemu(String),
    /// A device or run failed otherwise.
    #[error("{0}")]
    Device(String),
    /// Two runs of the same frame disagree.
    #[error("{0}")]
    Mismatch(String),
    /// Images could not be compared.
    #[error(transparent)]
    Compare(#[from] crate::compare::CompareError),
}

/// The kernel every configuration but `rtl` runs (the image's, the simulator's default).
pub fn kernel() -> (KernelKind, NumberFormat) {
    (KernelKind::default(), NumberFormat::F32)
}
