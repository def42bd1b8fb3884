//! `cargo xtask firmware`: build firmware/image for the soft-core.

use crate::elf;
use crate::toolchain::{self, Target, Toolchain, ToolchainChoice};
use anyhow::Result;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Board: memory map plus console/link drivers (a `board-*` feature of the image).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Board {
    /// QEMU `virt`: RAM at 0x8000_0000, NS16550A UART (repo-root memory.x).
    QemuVirt,
    /// Small FPGA SoC: BRAM at 0x0, AXI UART Lite, AXI4-Stream FIFO (boards/fpga-soc.x).
    FpgaSoc,
    /// The LiteX SoC of soc/ (VexRiscv RV32IMAC, LiteX UART, the RTL co-processor): the
    /// bootloader in ROM, the app in main RAM (boards/litex*.x, from the SoC's csr.json).
    Litex,
}

impl Board {
    fn feature(self) -> &'static str {
        match self {
            Board::QemuVirt => "board-qemu-virt",
            Board::FpgaSoc => "board-fpga-soc",
            Board::Litex => "board-litex",
        }
    }

    /// The name in the banner, the ELF copies and `--board`.
    pub fn name(self) -> &'static str {
        match self {
            Board::QemuVirt => "qemu-virt",
            Board::FpgaSoc => "fpga-soc",
            Board::Litex => "litex",
        }
    }
}

/// Which binary of the image package.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Bin {
    App,
    Bootloader,
}

impl Bin {
    fn name(self) -> &'static str {
        match self {
            Bin::App => "app",
            Bin::Bootloader => "bootloader",
        }
    }
}

/// Where the app is linked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Layout {
    /// At the start of RAM, booted directly (QEMU `-kernel`, or a debugger/bitstream).
    Standalone,
    /// In the application region above the bootloader, for `gridrt flash`
    /// (boards/<board>-bootloaded.x). Ignored for the bootloader binary.
    Bootloaded,
}

/// Build options shared by `firmware` and `qemu`.
#[derive(Args, Clone, Debug)]
pub struct BuildOpts {
    /// Instruction set: soft float (imac) or hard float (imafc).
    #[arg(long, value_enum, default_value_t = Target::Riscv32imac)]
    pub target: Target,
    /// Extra cargo features of the image (comma-separated), e.g. `trap-test`.
    #[arg(long, value_delimiter = ',')]
    pub features: Vec<String>,
    /// Binary to build.
    #[arg(long, value_enum, default_value_t = Bin::App)]
    pub bin: Bin,
    /// Memory layout of the app: standalone, or loaded by the bootloader.
    #[arg(long, value_enum, default_value_t = Layout::Standalone)]
    pub layout: Layout,
    /// Leave out every optional pipeline stage (shadows, reflections, textures, specular):
    /// the minimal feature set. Default: all stages (the image's `all-stages` feature).
    #[arg(long)]
    pub minimal: bool,
    /// Optimised build (the default).
    #[arg(long, conflicts_with = "debug")]
    pub release: bool,
    /// Unoptimised dev-profile build instead of release.
    #[arg(long)]
    pub debug: bool,
    /// How to cross-compile (see scripts/setup-riscv-toolchain.sh).
    #[arg(long, value_enum, default_value_t = ToolchainChoice::Auto)]
    pub toolchain: ToolchainChoice,
    /// Parallel cargo jobs.
    #[arg(short, long)]
    pub jobs: Option<u32>,
}

impl BuildOpts {
    /// Builds the image for `board` and returns the ELF path.
    pub fn build(&self, board: Board) -> Result<PathBuf> {
        let tc = Toolchain::resolve(self.toolchain, self.target)?;
        eprintln!(
            "xtask: building {} for {} on {} with the {}",
            self.bin.name(),
            self.target.triple(),
            board.name(),
            tc.describe()
        );
        let mut features = vec![board.feature().to_string()];
        // --no-default-features below drops the image's default stages too; put them back.
        if !self.minimal {
            features.push("all-stages".to_string());
        }
        if self.layout == Layout::Bootloaded && self.bin == Bin::App {
            features.push("layout-bootloaded".to_string());
        }
        features.extend(self.features.iter().cloned());

        let image = toolchain::image_dir();
        let mut cmd = tc.cargo_build(self.target);
        cmd.current_dir(&image)
            .arg("--manifest-path")
            .arg(image.join("Cargo.toml"))
            .arg("--target-dir")
            .arg(toolchain::image_target_dir())
            .args(["--bin", self.bin.name()])
            // The board is always explicit, so the default board feature must be off.
            .arg("--no-default-features")
            .arg("--features")
            .arg(features.join(","));
        if !self.debug {
            cmd.arg("--release");
        }
        if let Some(j) = self.jobs {
            cmd.arg("--jobs").arg(j.to_string());
        }
        toolchain::run_echoed(&mut cmd)?;

        let built = toolchain::image_target_dir()
            .join(self.target.triple())
            .join(if self.debug { "debug" } else { "release" })
            .join(self.bin.name());
        // Feature sets share one output path; keep a copy per variant so that several
        // variants (e.g. the bootloaded app and the bootloader for a flash test, or the
        // soft-core-only app next to the default one) coexist.
        let extra: String = self.features.iter().map(|f| format!("+{f}")).collect();
        let variant = built.with_file_name(format!(
            "{}-{}{}{}{extra}",
            self.bin.name(),
            board.name(),
            if self.layout == Layout::Bootloaded && self.bin == Bin::App { "-bootloaded" } else { "" },
            if self.minimal { "-minimal" } else { "" },
        ));
        std::fs::copy(&built, &variant)
            .map_err(|e| anyhow::anyhow!("copying {} to {}: {e}", built.display(), variant.display()))?;
        Ok(variant)
    }
}

#[derive(Args, Debug)]
pub struct Cmd {
    #[command(flatten)]
    build: BuildOpts,
    /// Board to build for.
    #[arg(long, value_enum, default_value_t = Board::QemuVirt)]
    board: Board,
}

impl Cmd {
    pub fn run(self) -> Result<()> {
        let elf_path = self.build.build(self.board)?;
        println!("ELF: {}", elf_path.display());
        elf::print_sections(&elf_path)
    }
}
