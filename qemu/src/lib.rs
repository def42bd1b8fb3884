//! `gridrt-qemu`: boots the soft-core firmware images on QEMU `virt` and hands out their UART.
//! The one launcher that `cargo xtask qemu`, the end-to-end tests and `gridrt bench frame`
//! share, plus the way they all build an image (`cargo xtask firmware`, [`build_firmware`]).
//!
//! # The machine
//! `qemu-system-riscv32 -machine virt -bios none -m 128M -smp 1 -icount shift=0`: one
//! instruction per virtual nanosecond, so `mcycle`/`minstret` are exact and repeatable.
//!
//! # The UART on a pty
//! With [`Serial::Pty`] (the default) QEMU's NS16550A is a real pseudo-terminal that a host
//! tool opens like a USB-serial adapter. QEMU drops output written while no one has the pty
//! open, so [`Machine`] keeps it open itself (never reading): the banner then waits in the tty
//! buffer for whoever opens the pty later. To not lose the first bytes either, QEMU starts
//! paused (`-S`) and is resumed through QMP (on its stdin) once the pty is held. Clients must
//! not flush pending input when they open the pty (`tcsetattr(TCSAFLUSH)`, Python's
//! `tty.setraw` default) or they drop that banner.
//!
//! # Lifetime
//! QEMU gets `PR_SET_PDEATHSIG`: the kernel stops it when the *thread* that booted it ends
//! (so boot it from a thread that outlives the machine, e.g. the main thread), and dropping
//! the [`Machine`] kills it.

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// The emulator program.
pub const PROGRAM: &str = "qemu-system-riscv32";

/// QEMU prints this for `-serial pty`.
const PTY_MARKER: &str = "char device redirected to ";

/// QMP: leave negotiation mode, then resume the paused machine.
const QMP_RESUME: &[u8] = b"{\"execute\":\"qmp_capabilities\"}\n{\"execute\":\"cont\"}\n";

/// How long QEMU may take to report its pty.
const PTY_WAIT: Duration = Duration::from_secs(10);

/// Where the guest UART goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Serial {
    /// A new `/dev/pts/N` ([`Machine::pty`]).
    Pty,
    /// This process's stdin/stdout (quick checks).
    Stdio,
}

/// Which of QEMU's output streams a line came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Standard output.
    Stdout,
    /// Standard error.
    Stderr,
}

/// Receives QEMU's own output lines (not the guest's UART), minus the pty notice and QMP's
/// JSON chatter. Called from reader threads.
pub type LineSink = Arc<dyn Fn(Stream, &str) + Send + Sync>;

/// Why a machine did not boot or an image did not build.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// No ELF at the path.
    #[error("no ELF at {0}")]
    NoElf(PathBuf),
    /// QEMU could not be started.
    #[error("starting {PROGRAM} (install it with scripts/setup-qemu.sh): {0}")]
    Spawn(std::io::Error),
    /// QEMU did not report its pty in time.
    #[error("QEMU did not report its pty within {} s ({status})", PTY_WAIT.as_secs())]
    NoPty {
        /// How QEMU ended.
        status: String,
    },
    /// The pty could not be opened to hold it.
    #[error("opening {path}: {source}")]
    Hold {
        /// The pty.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The machine could not be resumed through QMP.
    #[error("resuming QEMU through QMP: {0}")]
    Qmp(std::io::Error),
    /// `cargo xtask firmware` could not run or failed.
    #[error("cargo xtask firmware {args} failed: {detail}")]
    Build {
        /// Its arguments.
        args: String,
        /// Exit status and the end of its output.
        detail: String,
    },
}

/// What to boot and how ([`Launch::boot`]).
#[derive(Debug, Clone)]
pub struct Launch {
    /// The image (an ELF linked for QEMU `virt`'s RAM, `cargo xtask firmware --board qemu-virt`).
    pub elf: PathBuf,
    /// Where the guest UART goes.
    pub serial: Serial,
    /// Hold the pty open and resume only then, so no guest output is lost (pty only).
    pub hold: bool,
    /// Extra QEMU arguments, appended.
    pub extra_args: Vec<String>,
}

impl Launch {
    /// `elf` with its UART on a held pty.
    pub fn new(elf: impl Into<PathBuf>) -> Self {
        Self { elf: elf.into(), serial: Serial::Pty, hold: true, extra_args: Vec::new() }
    }

    /// The QEMU command line (without the pty hold's `-S -qmp stdio`).
    pub fn command(&self) -> Command {
        let mut cmd = Command::new(PROGRAM);
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
            .arg(&self.elf)
            .args(&self.extra_args);
        cmd
    }

    /// Starts QEMU. With a pty: waits until QEMU names it, holds it if asked and resumes the
    /// paused machine; QEMU's own output lines go to `lines`.
    pub fn boot(&self, lines: LineSink) -> Result<Machine, Error> {
        if !self.elf.is_file() {
            return Err(Error::NoElf(self.elf.clone()));
        }
        let pty = self.serial == Serial::Pty;
        let hold = pty && self.hold;
        let mut cmd = self.command();
        if hold {
            cmd.args(["-S", "-qmp", "stdio"]).stdin(Stdio::piped());
        }
        if pty {
            cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
        }
        // No orphan QEMU keeps the pty.
        end_with_parent(&mut cmd);
        let child = cmd.spawn().map_err(Error::Spawn)?;
        let mut machine = Machine { child, pty: None, hold: None };
        if !pty {
            return Ok(machine);
        }
        // QEMU 7 prints the pty on stdout, newer ones on stderr.
        let (tx, rx) = mpsc::channel();
        if let Some(out) = machine.child.stdout.take() {
            forward_lines(out, Stream::Stdout, tx.clone(), lines.clone());
        }
        if let Some(err) = machine.child.stderr.take() {
            forward_lines(err, Stream::Stderr, tx, lines);
        }
        let path = match rx.recv_timeout(PTY_WAIT) {
            Ok(p) => p,
            Err(_) => {
                let _ = machine.child.kill();
                let status = machine.child.wait().map_or_else(|e| e.to_string(), |s| s.to_string());
                return Err(Error::NoPty { status });
            }
        };
        if hold {
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(&path)
                .map_err(|source| Error::Hold { path: path.clone(), source })?;
            machine.hold = Some(file);
            // QMP stays on the open stdin pipe until QEMU exits.
            let qmp = machine.child.stdin.as_mut().ok_or_else(|| Error::Qmp(std::io::ErrorKind::BrokenPipe.into()))?;
            qmp.write_all(QMP_RESUME).and_then(|()| qmp.flush()).map_err(Error::Qmp)?;
        }
        machine.pty = Some(path);
        Ok(machine)
    }
}

/// A running QEMU; killed when dropped.
#[derive(Debug)]
pub struct Machine {
    child: Child,
    pty: Option<String>,
    hold: Option<File>,
}

impl Machine {
    /// The guest UART's pty (with [`Serial::Pty`]).
    pub fn pty(&self) -> Option<&str> {
        self.pty.as_deref()
    }

    /// QEMU's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// QEMU's exit status once it has ended.
    pub fn try_wait(&mut self) -> std::io::Result<Option<ExitStatus>> {
        self.child.try_wait()
    }

    /// Stops QEMU and waits for it.
    pub fn kill(&mut self) -> std::io::Result<ExitStatus> {
        let _ = self.child.kill();
        self.child.wait()
    }
}

impl Drop for Machine {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.hold = None;
    }
}

/// Makes the child `cmd` starts receive SIGTERM when the thread that started it ends (Linux
/// `PR_SET_PDEATHSIG`; it survives the `exec` of `cargo run`), so that a killed parent leaves
/// no orphan simulator or emulator running.
pub fn end_with_parent(cmd: &mut Command) {
    use std::os::unix::process::CommandExt;
    // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

/// First line of `qemu-system-riscv32 --version`, or `None` when it does not run.
pub fn version() -> Option<String> {
    let out = Command::new(PROGRAM).arg("--version").output().ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines().find(|l| !l.trim().is_empty()).map(|l| l.trim().to_string())
}

/// Reads `stream` line by line on a thread: sends the pty path of a [`PTY_MARKER`] line to
/// `tx`, hands every other line but QMP's JSON to `lines`.
fn forward_lines<R: std::io::Read + Send + 'static>(
    stream: R,
    which: Stream,
    tx: mpsc::Sender<String>,
    lines: LineSink,
) {
    std::thread::spawn(move || {
        for line in BufReader::new(stream).lines().map_while(Result::ok) {
            match pty_of(&line) {
                Some(path) => {
                    let _ = tx.send(path.to_string());
                }
                // QMP's greeting, replies and events (JSON) are noise here.
                None if line.starts_with('{') => {}
                None => lines(which, &line),
            }
        }
    });
}

/// The pty a QEMU output line names, if it is the `-serial pty` notice.
fn pty_of(line: &str) -> Option<&str> {
    line.split(PTY_MARKER).nth(1).and_then(|rest| rest.split_whitespace().next())
}

/// Builds a firmware image with `cargo xtask firmware ARGS` in the repository at `repo` and
/// returns the ELF path it prints (`ELF: PATH`). `cargo_args` go between `cargo run` and
/// `--package xtask` (e.g. `["--quiet", "--profile", "test"]`). Uses `$CARGO` when set.
pub fn build_firmware(repo: &Path, cargo_args: &[&str], args: &[&str]) -> Result<PathBuf, Error> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let fail = |detail: String| Error::Build { args: args.join(" "), detail };
    let out = Command::new(cargo)
        .current_dir(repo)
        .arg("run")
        .args(cargo_args)
        .args(["--package", "xtask", "--", "firmware"])
        .args(args)
        .output()
        .map_err(|e| fail(format!("cannot run cargo: {e}")))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(30).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        return Err(fail(format!("{}\n{}", out.status, tail.join("\n"))));
    }
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("ELF: "))
        .map(|p| PathBuf::from(p.trim()))
        .ok_or_else(|| fail("it printed no `ELF: PATH` line".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pty_notice_of_qemu_7_and_later_is_recognised() {
        assert_eq!(pty_of("char device redirected to /dev/pts/7 (label serial0)"), Some("/dev/pts/7"));
        assert_eq!(
            pty_of("qemu-system-riscv32: char device redirected to /dev/pts/12 (label serial0)"),
            Some("/dev/pts/12")
        );
        assert_eq!(pty_of("{\"QMP\": {}}"), None);
    }

    #[test]
    fn the_command_counts_instructions_exactly_and_boots_the_elf() {
        let cmd = Launch::new("/x/app.elf").command();
        let args: Vec<String> = cmd.get_args().map(|a| a.to_string_lossy().into_owned()).collect();
        let joined = args.join(" ");
        assert!(joined.contains("-icount shift=0"), "{joined}");
        assert!(joined.contains("-machine virt -bios none"), "{joined}");
        assert!(joined.ends_with("-serial pty -kernel /x/app.elf"), "{joined}");
    }

    #[test]
    fn a_missing_elf_is_refused_before_qemu_starts() {
        let e = Launch::new("/nonexistent/app").boot(Arc::new(|_, _| {})).unwrap_err();
        assert!(matches!(e, Error::NoElf(_)), "{e}");
    }
}
