//! `gridrt ports`: list the machine's serial ports.

use gridrt_host::serial;

/// List serial ports (USB adapters, on-board UARTs).
///
/// Pseudo-terminals are not listed: `cargo xtask qemu` prints QEMU's, and `socat` prints
/// (or links) its own.
#[derive(Debug, clap::Parser)]
pub struct Cmd {}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
        let ports = serial::list()?;
        if ports.is_empty() {
            println!("no serial ports found (QEMU's pty is not listed: `cargo xtask qemu` prints its path)");
        }
        for p in ports {
            println!("{:<24} {}", p.path, p.description);
        }
        Ok(())
    }
}
