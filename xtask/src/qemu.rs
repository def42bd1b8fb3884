//! `cargo xtask qemu`: boot an image on QEMU `virt` and expose its UART.
//!
//! The launch itself (command line, pty held open, resume through QMP) is the `gridrt-qemu`
//! library's, shared with the end-to-end tests and `gridrt bench frame`; see its docs for
//! why the pty is held and why clients must not flush pending input when they open it.

use crate::firmware::{Board, BuildOpts};
use crate::toolchain::{self, display_command};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use gridrt_qemu::{Launch, Stream};
use std::path::PathBuf;
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Where the guest UART goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Serial {
    /// A new /dev/pts/N (printed as `serial: /dev/pts/N`).
    Pty,
    /// This terminal's stdin/stdout (quick checks; Ctrl-C still stops QEMU).
    Stdio,
}

#[derive(Args, Debug)]
pub struct Cmd {
    #[command(flatten)]
    build: BuildOpts,
    /// Boot this ELF instead of building one.
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Where the guest UART goes.
    #[arg(long, value_enum, default_value_t = Serial::Pty)]
    serial: Serial,
    /// Stop QEMU after this many seconds (default: run until Ctrl-C or QEMU exits).
    #[arg(long)]
    timeout_s: Option<f64>,
    /// Do not hold the pty open (guest output is then lost until a client opens it).
    #[arg(long)]
    no_hold: bool,
    /// Extra QEMU arguments, after `--`.
    #[arg(last = true)]
    qemu_args: Vec<String>,
}

impl Cmd {
    pub fn run(self) -> Result<()> {
        let elf = match &self.elf {
            Some(p) => p.clone(),
            None => self.build.build(Board::QemuVirt)?,
        };
        if !elf.is_file() {
            bail!("no ELF at {}", elf.display());
        }
        if Command::new(gridrt_qemu::PROGRAM).arg("--version").output().is_err() {
            eprintln!("xtask: {} not found; running scripts/setup-qemu.sh", gridrt_qemu::PROGRAM);
            toolchain::run_script("setup-qemu.sh", None)?;
        }
        let launch = Launch {
            elf,
            serial: match self.serial {
                Serial::Pty => gridrt_qemu::Serial::Pty,
                Serial::Stdio => gridrt_qemu::Serial::Stdio,
            },
            hold: !self.no_hold,
            extra_args: self.qemu_args.clone(),
        };
        eprintln!("xtask: {}", display_command(&launch.command()));
        // QEMU's own output is forwarded (its pty notice becomes `serial: PTY` below).
        let lines = Arc::new(|stream: Stream, line: &str| match stream {
            Stream::Stdout => println!("{line}"),
            Stream::Stderr => eprintln!("{line}"),
        });
        let mut machine = launch.boot(lines)?;
        let started = Instant::now();
        if let Some(pty) = machine.pty() {
            println!("serial: {pty}");
            eprintln!("xtask: QEMU running (pid {}); Ctrl-C to stop", machine.id());
        }

        let deadline = self.timeout_s.map(|s| started + Duration::from_secs_f64(s));
        loop {
            if let Some(status) = machine.try_wait()? {
                if status.success() {
                    return Ok(());
                }
                bail!("QEMU exited with {status}");
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                machine.kill()?;
                eprintln!("xtask: stopped QEMU after {:.1} s (--timeout-s)", started.elapsed().as_secs_f64());
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}
