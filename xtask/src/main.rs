//! `cargo xtask`: project automation that plain cargo cannot express.
//!
//! - `cargo xtask setup`     install the RISC-V toolchain, QEMU and the HDL tools (scripts/)
//! - `cargo xtask firmware`  build a soft-core image (firmware/image) and print its sections
//! - `cargo xtask qemu`      boot an image on QEMU `virt` with its UART on a pseudo-terminal
//!   (`--bin bootloader` boots the bootloader, `--elf PATH` any image; prints `serial: PTY`)
//! - `cargo xtask rtl sim`   verilate the co-processor RTL (cached) for the co-simulation
//! - `cargo xtask rtl synth` synthesise it for the ECP5-85F (Yosys + nextpnr-ecp5), JSON report
//!
//! One file per subcommand; `toolchain.rs` decides how to cross-compile.

mod elf;
mod firmware;
mod qemu;
mod rtl;
mod rtl_synth;
mod setup;
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
    /// Install the RISC-V Rust toolchain (rustup target, else Debian packages), QEMU and the HDL tools.
    Setup(setup::Cmd),
    /// Build a firmware image for the soft-core and print its section sizes.
    Firmware(firmware::Cmd),
    /// Boot a firmware image on qemu-system-riscv32 (`virt`), serial on a pty.
    Qemu(qemu::Cmd),
    /// The co-processor RTL: Verilator co-simulation build, ECP5 synthesis.
    Rtl(rtl::Cmd),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().cmd {
        Cmd::Setup(cmd) => cmd.run(),
        Cmd::Firmware(cmd) => cmd.run(),
        Cmd::Qemu(cmd) => cmd.run(),
        Cmd::Rtl(cmd) => cmd.run(),
    }
}
