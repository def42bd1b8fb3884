//! `cargo xtask setup`: run the install scripts in scripts/ (toolchain, QEMU, HDL tools, the SoC's).

use crate::toolchain::run_script;
use anyhow::Result;
use clap::Args;

#[derive(Args, Debug)]
pub struct Cmd {
    /// Prepare the Debian toolchain in .toolchain/ even if rustup targets work.
    #[arg(long)]
    debian: bool,
    /// Skip QEMU and socat.
    #[arg(long)]
    no_qemu: bool,
    /// Skip the HDL tools (Verilator, Yosys, nextpnr-ecp5).
    #[arg(long)]
    no_hdl: bool,
    /// Skip the LiteX SoC's tools (LiteX and its simulation libraries, the ECP5 flow for the SoC).
    #[arg(long)]
    no_soc: bool,
}

impl Cmd {
    pub fn run(self) -> Result<()> {
        run_script("setup-riscv-toolchain.sh", self.debian.then_some("--debian"))?;
        if !self.no_qemu {
            run_script("setup-qemu.sh", None)?;
        }
        if !self.no_hdl {
            run_script("setup-hdl.sh", None)?;
        }
        if !self.no_soc {
            run_script("setup-soc.sh", None)?;
        }
        Ok(())
    }
}
