//! `cargo xtask`: project automation that plain cargo cannot express.
//!
//! - `cargo xtask setup`     install the RISC-V toolchain, QEMU, the HDL tools and the SoC's (scripts/)
//! - `cargo xtask firmware`  build a soft-core image (firmware/image) and print its sections
//! - `cargo xtask qemu`      boot an image on QEMU `virt` with its UART on a pseudo-terminal
//!   (`--bin bootloader` boots the bootloader, `--elf PATH` any image; prints `serial: PTY`)
//! - `cargo xtask rtl sim`   verilate the co-processor RTL (cached) for the co-simulation
//! - `cargo xtask rtl synth` synthesise it for the ECP5-85F (Yosys + nextpnr-ecp5), JSON report
//! - `cargo xtask soc`       the LiteX SoC (soc/): `sim` in Verilator (prints `serial: PTY`),
//!   `build --board ulx3s` a bitstream, `board-files` the firmware's memory map from csr.json
//!
//! One file per subcommand; `toolchain.rs` decides how to cross-compile.

mod elf;
mod firmware;
mod qemu;
mod rtl;
mod rtl_hdl;
mod rtl_synth;
mod setup;
mod soc;
mod soc_build;
mod soc_sim;
mod soc_tools;
mod toolchain;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "gridrt project automation", version)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Install the RISC-V Rust toolchain (rustup target, else Debian packages), QEMU, the HDL
    /// tools and the LiteX SoC's.
    Setup(setup::Cmd),
    /// Build a firmware image for the soft-core and print its section sizes.
    Firmware(firmware::Cmd),
    /// Boot a firmware image on qemu-system-riscv32 (`virt`), serial on a pty.
    Qemu(qemu::Cmd),
    /// The co-processor RTL: Verilator co-simulation build, ECP5 synthesis.
    Rtl(rtl::Cmd),
    /// The LiteX SoC: Verilator simulation, ECP5 bitstream, board files from csr.json.
    Soc(soc::Cmd),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().cmd {
        Cmd::Setup(cmd) => cmd.run(),
        Cmd::Firmware(cmd) => cmd.run(),
        Cmd::Qemu(cmd) => cmd.run(),
        Cmd::Rtl(cmd) => cmd.run(),
        Cmd::Soc(cmd) => cmd.run(),
    }
}
