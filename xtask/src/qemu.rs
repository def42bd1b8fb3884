//! `cargo xtask qemu`: boot an image on QEMU `virt` and expose its UART.
//!
//! With `--serial pty` (the default) QEMU's NS16550A is a real pseudo-terminal that the
//! host tool (serialport) opens like a USB-serial adapter. QEMU drops output written while
//! no one has the pty open, so we keep it open ourselves (never reading): the banner then
//! waits in the tty buffer for whoever opens the pty later. To not lose the first bytes
//! either, QEMU starts paused (`-S`) and we resume it through QMP (on its stdin) once we
//! hold the pty. Clients must not flush pending input when they open the pty
//! (`tcsetattr(TCSAFLUSH)`, Python's `tty.setraw` default) or they drop that banner.

use crate::firmware::{Board, BuildOpts};
use crate::toolchain::{self, display_command};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::mpsc;
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

/// QMP: leave negotiation mode, then resume the paused machine.
const QMP_RESUME: &[u8] = b"{\"execute\":\"qmp_capabilities\"}\n{\"execute\":\"cont\"}\n";

/// QEMU prints this for `-serial pty`.
const PTY_MARKER: &str = "char device redirected to ";

impl Cmd {
    pub fn run(self) -> Result<()> {
        let elf = match &self.elf {
            Some(p) => p.clone(),
            None => self.build.build(Board::QemuVirt)?,
        };
        if !elf.is_file() {
            bail!("no ELF at {}", elf.display());
        }
        if Command::new("qemu-system-riscv32").arg("--version").output().is_err() {
            eprintln!("xtask: qemu-system-riscv32 not found; running scripts/setup-qemu.sh");
            toolchain::run_script("setup-qemu.sh", None)?;
        }

        let mut cmd = Command::new("qemu-system-riscv32");
        let hold = self.serial == Serial::Pty && !self.no_hold;
        cmd.args(["-machine", "virt", "-bios", "none", "-m", "128M", "-smp", "1"])
            .args(["-display", "none", "-monitor", "none"])
            // One instruction per virtual ns: exact, repeatable mcycle/minstret.
            .args(["-icount", "shift=0"])
            .args([
                "-serial",
                match self.serial {
                    Serial::Pty => "pty",
                    Serial::Stdio => "stdio",
                },
            ])
            .arg("-kernel")
            .arg(&elf)
            .args(&self.qemu_args);
        if hold {
            cmd.args(["-S", "-qmp", "stdio"]).stdin(Stdio::piped());
        }
        // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
        // It makes the kernel stop QEMU if xtask dies, so no orphan keeps the pty.
        unsafe {
            cmd.pre_exec(|| {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        if self.serial == Serial::Pty {
            cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
        }
        eprintln!("xtask: {}", display_command(&cmd));
        let mut child = cmd.spawn().context("starting qemu-system-riscv32")?;
        let started = Instant::now();

        // Forward QEMU's output and fish out the pty path (QEMU 7 prints it on stdout,
        // newer ones on stderr).
        let mut _pty_hold = None;
        if self.serial == Serial::Pty {
            let (tx, rx) = mpsc::channel();
            if let Some(out) = child.stdout.take() {
                forward_lines(out, tx.clone(), |l| println!("{l}"));
            }
            if let Some(err) = child.stderr.take() {
                forward_lines(err, tx, |l| eprintln!("{l}"));
            }
            let pty = match rx.recv_timeout(Duration::from_secs(10)) {
                Ok(p) => p,
                Err(_) => {
                    let _ = child.kill();
                    let status = child.wait()?;
                    bail!("QEMU did not report its pty within 10 s ({status})");
                }
            };
            if hold {
                _pty_hold = Some(
                    std::fs::OpenOptions::new()
                        .read(true)
                        .write(true)
                        .open(&pty)
                        .with_context(|| format!("opening {pty}"))?,
                );
                // QMP stays on the open stdin pipe until QEMU exits.
                let qmp = child.stdin.as_mut().context("QEMU QMP pipe")?;
                qmp.write_all(QMP_RESUME).context("resuming QEMU through QMP")?;
                qmp.flush()?;
            }
            println!("serial: {pty}");
            eprintln!("xtask: QEMU running (pid {}); Ctrl-C to stop", child.id());
        }

        let deadline = self.timeout_s.map(|s| started + Duration::from_secs_f64(s));
        loop {
            if let Some(status) = child.try_wait()? {
                if status.success() {
                    return Ok(());
                }
                bail!("QEMU exited with {status}");
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                child.kill()?;
                child.wait()?;
                eprintln!("xtask: stopped QEMU after {:.1} s (--timeout-s)", started.elapsed().as_secs_f64());
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Reads `stream` line by line on a thread: sends the pty path of a [`PTY_MARKER`] line
/// to `tx`, hands every other line to `forward`.
fn forward_lines<R: std::io::Read + Send + 'static>(stream: R, tx: mpsc::Sender<String>, forward: fn(&str)) {
    std::thread::spawn(move || {
        for line in BufReader::new(stream).lines().map_while(Result::ok) {
            match line.split(PTY_MARKER).nth(1).and_then(|rest| rest.split_whitespace().next()) {
                Some(path) => {
                    let _ = tx.send(path.to_string());
                }
                // QMP's greeting, replies and events (JSON) are noise here.
                None if line.starts_with('{') => {}
                None => forward(&line),
            }
        }
    });
}
