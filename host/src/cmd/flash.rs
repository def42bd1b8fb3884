//! `gridrt flash`: write an application ELF through the device's bootloader, verify it,
//! start it, and check that it answers.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use gridrt_host::flash::{flash, FlashConfig, FlashEvent, FlashImage};
use gridrt_host::serial;
use gridrt_host::session::{Session, SessionConfig};
use indicatif::{ProgressBar, ProgressStyle};

/// Flash an application through the bootloader.
///
/// The ELF must be linked for the bootloader's application region
/// (`cargo xtask firmware --bin app --layout bootloaded`). Its loadable segments are sent in
/// CRC-checked, acknowledged chunks; the bootloader reads the image back from memory and
/// reports its CRC-32, which must equal ours; then it jumps to the entry point and the
/// application must answer Hello. A refused image (wrong format version, too large, outside
/// the region, bad CRC) is reported with the bootloader's reason; the bootloader keeps
/// running.
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    /// Application ELF.
    #[arg(value_name = "APP.elf")]
    elf: PathBuf,
    /// Serial port of the board or of QEMU's pty (see `cargo xtask qemu --bin bootloader`).
    #[arg(long, value_name = "PATH")]
    port: String,
    /// Baud rate.
    #[arg(long, default_value_t = 115_200, value_name = "BAUD")]
    baud: u32,
    /// Seconds to wait for each answer of the bootloader before sending again.
    #[arg(long, default_value_t = 2.0, value_name = "SECONDS")]
    reply_timeout: f64,
    /// Write and verify, but do not start the application.
    #[arg(long)]
    no_boot: bool,
    /// Do not check that the started application answers Hello.
    #[arg(long)]
    no_check: bool,
}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
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
        let mut port = serial::open(&self.port, self.baud, serial::DEFAULT_READ_TIMEOUT)?;
        let cfg = FlashConfig {
            reply_timeout: Duration::from_secs_f64(self.reply_timeout.max(0.05)),
            boot: !self.no_boot,
            ..FlashConfig::new(self.port.clone())
        };
        let mut bar: Option<ProgressBar> = None;
        let report = flash(&mut port, &image, &cfg, &mut |e| match e {
            FlashEvent::Connected(info) => println!(
                "bootloader firmware {}.{}.{} on board {}, max payload {}",
                info.firmware[0], info.firmware[1], info.firmware[2], info.board, info.max_payload
            ),
            FlashEvent::Started { total } => {
                let pb = ProgressBar::new(total);
                if let Ok(style) =
                    ProgressStyle::with_template("flash  [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} {msg}")
                {
                    pb.set_style(style.progress_chars("=> "));
                }
                bar = Some(pb);
            }
            FlashEvent::Written { bytes, .. } => {
                if let Some(b) = &bar {
                    b.set_position(bytes);
                }
            }
            FlashEvent::Resent { offset } => {
                if let Some(b) = &bar {
                    b.set_message(format!("(resending from {offset})"));
                }
            }
            FlashEvent::Verified { .. } | FlashEvent::Booting { .. } => {
                if let Some(b) = bar.take() {
                    b.finish_and_clear();
                }
            }
        });
        if let Some(b) = bar.take() {
            b.abandon();
        }
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
        // The application starts up first; a slow (simulated) board takes longer.
        let hello = Duration::from_secs(15).max(Duration::from_secs_f64(self.reply_timeout.max(0.05)));
        let cfg = SessionConfig::new(self.port.clone()).hello_timeout(hello);
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
