//! `gridrt flash`: write an application ELF through the device's bootloader, verify it,
//! start it, and check that it answers.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use gridrt_host::flash::{flash, FlashConfig, FlashImage};
use gridrt_host::serial;
use gridrt_host::session::{Session, SessionConfig};

use super::progress::CliProgress;

/// Flash an application through the bootloader.
///
/// The ELF must be linked for the bootloader's application region
/// (`cargo xtask firmware --bin app --layout bootloaded`). Its loadable segments are sent in
/// CRC-checked chunks, several in flight, each acknowledged selectively; only chunks the
/// bootloader did not get are sent again, and the chunk size follows the line's error rate.
/// The bootloader reads the image back from memory and reports its CRC-32,
/// which must equal ours; then it jumps to the entry point and the application must answer
/// Hello. A refused image (wrong format version, too large, outside the region, bad CRC) is
/// reported with the bootloader's reason; the bootloader keeps running. Every wait is
/// derived from --baud and the bytes expected. When stdout is not a terminal, a progress
/// line is printed every few seconds.
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    /// Application ELF.
    #[arg(value_name = "APP.elf")]
    elf: PathBuf,
    /// Serial port of the board or of QEMU's pty (see `cargo xtask qemu --bin bootloader`)
    /// [default: `port` of gridrt.toml].
    #[arg(short = 'p', long, value_name = "PATH", env = "GRIDRT_PORT")]
    port: Option<String>,
    /// Baud rate [default: `baud` of gridrt.toml, else 115200].
    #[arg(short = 'b', long, value_name = "BAUD", env = "GRIDRT_BAUD")]
    baud: Option<u32>,
    /// Allowance per exchange on top of the wire time derived from --baud (USB adapter,
    /// operating system, bootloader).
    #[arg(long, default_value_t = 30, value_name = "MS")]
    turnaround: u64,
    /// Write and verify, but do not start the application.
    #[arg(long)]
    no_boot: bool,
    /// Do not check that the started application answers Hello.
    #[arg(long)]
    no_check: bool,
    /// Seconds the started application has to answer Hello (a board's start is short;
    /// its simulation, `cargo xtask soc sim`, runs hundreds of times slower).
    #[arg(long, default_value_t = 15, value_name = "SECONDS", value_parser = clap::value_parser!(u64).range(1..=3600))]
    boot_wait: u64,
}

impl Cmd {
    /// Runs the command.
    pub fn run(mut self) -> anyhow::Result<()> {
        let config = super::config::load()?;
        let Some(port_name) = self.port.take().or(config.port) else {
            anyhow::bail!("no board given: use --port PATH (or GRIDRT_PORT, or `port` in gridrt.toml)");
        };
        let baud = self.baud.or(config.baud).unwrap_or(super::common::DEFAULT_BAUD);
        super::common::check_port_exists(&port_name)?;
        let bytes = std::fs::read(&self.elf).with_context(|| format!("reading {}", self.elf.display()))?;
        let image = FlashImage::from_elf(&bytes).with_context(|| format!("{}", self.elf.display()))?;
        println!(
            "image      {}: {} bytes at {:#010x}, entry {:#010x}, CRC-32 {:#010x}, {} loadable segments",
            self.elf.display(),
            image.data.len(),
            image.load_addr,
            image.entry,
            image.crc,
            image.segments.len()
        );
        let mut port = serial::open(&port_name, baud, serial::DEFAULT_READ_TIMEOUT)?;
        let session =
            SessionConfig::new(port_name.clone()).baud(baud).turnaround(Duration::from_millis(self.turnaround));
        let cfg = FlashConfig { session, boot: !self.no_boot };
        let mut progress = CliProgress::default();
        let report = flash(&mut port, &image, &cfg, &mut |e| {
            if let gridrt_host::flash::FlashEvent::Connected(info) = e {
                println!(
                    "bootloader firmware {}.{}.{} on board {}, max payload {}",
                    info.firmware[0], info.firmware[1], info.firmware[2], info.board, info.max_payload
                );
            }
            progress.handle_flash(e)
        });
        if report.is_err() {
            progress.abandon();
        }
        drop(progress);
        let report = report?;
        println!(
            "verified   {} bytes, CRC-32 {:#010x} read back by the bootloader ({:.1} s, {} chunks resent)",
            report.bytes,
            report.crc,
            report.elapsed.as_secs_f64(),
            report.resent
        );
        if !report.booted {
            println!("not started (--no-boot)");
            return Ok(());
        }
        println!("booting    entry {:#010x}", image.entry);
        if self.no_check {
            return Ok(());
        }
        let cfg = SessionConfig::new(port_name.clone())
            .baud(baud)
            .turnaround(Duration::from_millis(self.turnaround))
            .hello_timeout(Duration::from_secs(self.boot_wait));
        let mut session = Session::new(&mut port, cfg);
        let info = session.hello(&mut |_| {}).context("the started application did not answer Hello")?;
        println!(
            "running    application firmware {}.{}.{} on board {}: {} PEs x {} words, up to {} voxels",
            info.firmware[0],
            info.firmware[1],
            info.firmware[2],
            info.board,
            info.pe_count,
            info.pe_mem_words,
            info.voxel_capacity
        );
        Ok(())
    }
}
