//! `cargo xtask soc sim`: the SoC in Verilator, its UART on a pseudo-terminal.
//!
//! The simulation (`target/soc/sim-cfu/gateware/obj_dir/Vsim`; `sim/` for `--float-hw none`)
//! runs the bootloader from ROM.
//! Its `serial2pty` module opens the pty, keeps it open (output waits in the tty buffer for
//! a client; nothing is lost) and applies flow control both ways. We print
//! `serial: /dev/pts/N`; with `--flash` we first flash the app through the bootloader with
//! `gridrt flash`, as a user would. The simulator gets `PR_SET_PDEATHSIG`, so it stops when
//! this command is killed.

use crate::firmware::{Bin, BuildOpts, Layout};
use crate::soc_tools::{
    build_firmware, parse_harts, parse_l2_kib, parse_pe_cache_lines, python, result, run_logged, soc_target_dir,
    FloatHw, RtlDir, DEFAULT_L2_KIB, DEFAULT_PE_CACHE_LINES,
};
use crate::toolchain::{display_command, ToolchainChoice};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::io::{BufRead, BufReader};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct SimCmd {
    #[command(flatten)]
    rtl: RtlDir,
    /// Flash the app through the bootloader (`gridrt flash`) before printing the pty.
    #[arg(long)]
    flash: bool,
    /// With --flash: this application ELF instead of the one built for `--board litex`.
    #[arg(long, value_name = "APP.elf", requires = "flash")]
    app: Option<PathBuf>,
    /// Also make a symlink to the pty here.
    #[arg(long, value_name = "PATH")]
    link: Option<PathBuf>,
    /// Stop the simulation after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    timeout_s: Option<f64>,
    /// Build the firmware without the optional pipeline stages.
    #[arg(long)]
    minimal: bool,
    /// How to cross-compile (see scripts/setup-riscv-toolchain.sh).
    #[arg(long, value_enum, default_value_t = ToolchainChoice::Auto)]
    toolchain: ToolchainChoice,
    /// Parallel jobs of the firmware and simulator builds.
    #[arg(short, long, default_value_t = 2)]
    jobs: u32,
    /// Build the simulator with Verilator's --trace (waveforms; several times slower).
    #[arg(long)]
    trace: bool,
    /// The UART line from the SoC to the host, in simulated time: each byte takes 10 bit
    /// times at this rate (8N1), as on a board (`gridrt bench frame --configs soc` sets the
    /// board's 115 200). 0 (default) = unpaced, a byte per clock at most: a simulation runs
    /// ~250× slower than the board, and a paced line then answers slower than `gridrt`'s
    /// default waits allow.
    #[arg(long, default_value_t = 0)]
    baud: u32,
    /// The line from the host to the SoC; 0 (default) = unpaced, so that flashing and scene
    /// uploads do not cost simulated minutes.
    #[arg(long, default_value_t = 0)]
    rx_baud: u32,
    /// With --rx-baud: a byte that arrives while the SoC's receive FIFO is full is lost, as
    /// a board's UART loses it (no flow control); the simulator counts the lost bytes.
    #[arg(long, requires = "rx_baud")]
    rx_overrun: bool,
    /// The clock the line's bit times are counted in, MHz (default: the SoC's 50 MHz; give
    /// the routed clock of a bitstream to time its link).
    #[arg(long)]
    clock_mhz: Option<f64>,
    /// Floating point in hardware: cfu (default: VexRiscv full+cfu with the f32 CFU; the
    /// firmware for riscv32im with `cfu-float`) or none (VexRiscv imac, soft float: a smaller
    /// CPU and no CFU, for small boards). cfu is the default because it measured 12.5 % fewer
    /// frame cycles than none on 1 hart and 3.5 % on 4 (docs/bench-frame.md, "Where the
    /// harts' time goes"). Each has its own build folder, target/soc/sim-cfu and
    /// target/soc/sim.
    #[arg(long, value_enum, default_value_t = FloatHw::Cfu)]
    float_hw: FloatHw,
    /// KiB of LiteX's L2 cache in front of the SDRAM that holds main RAM (a power of two).
    /// Another size than the default has its own build folder (target/soc/sim-…-l2-N).
    #[arg(long, default_value_t = DEFAULT_L2_KIB, value_parser = parse_l2_kib, value_name = "KIB")]
    l2_kib: u32,
    /// CPUs, 1 to 4: the first and workers (VexRiscvs of the same variant, each with its own
    /// port on the co-processor) that trace rows of each frame beside it. 2 has its own build folder
    /// (target/soc/sim-…-harts-2).
    #[arg(long, default_value_t = 1, value_parser = parse_harts, value_name = "N")]
    harts: u32,
    /// Each PE's 2²⁰ words in the SDRAM's upper half, read through a cache of this many
    /// 8-word lines (a power of two, 4..=4096; default 512, 16 KiB per PE; rtl/README.md
    /// §4.6), so that scenes beyond block RAM load; 0: PE memories in block RAM, 16 384 words
    /// each (the SoC before PE caches). Another value has its own build folder
    /// (target/soc/sim-…-pec-N, `-bram` for 0).
    #[arg(long, default_value_t = DEFAULT_PE_CACHE_LINES, value_parser = parse_pe_cache_lines, value_name = "LINES")]
    pe_cache_lines: u32,
}

/// serial2pty prints this for its pty.
const PTY_MARKER: &str = "serial2pty: ";

impl SimCmd {
    /// The build folder's name under target/soc: one per CPU, L2 size and hart count, so
    /// that each Verilated SoC stays cached.
    fn build_dir_name(&self) -> String {
        let mut name = match self.float_hw {
            FloatHw::None => "sim".to_string(),
            other => format!("sim-{}", other.name()),
        };
        if self.l2_kib != DEFAULT_L2_KIB {
            name += &format!("-l2-{}", self.l2_kib);
        }
        if self.harts != 1 {
            name += &format!("-harts-{}", self.harts);
        }
        match self.pe_cache_lines {
            DEFAULT_PE_CACHE_LINES => {}
            0 => name += "-bram",
            n => name += &format!("-pec-{n}"),
        }
        name
    }

    pub fn run(self) -> Result<()> {
        let dir = soc_target_dir().join(self.build_dir_name());
        let opts = BuildOpts {
            target: self.float_hw.target(),
            features: self.float_hw.features(),
            bin: Bin::App,
            layout: Layout::Bootloaded,
            minimal: self.minimal,
            release: true,
            debug: false,
            toolchain: self.toolchain,
            jobs: Some(self.jobs),
        };
        let rom = dir.join("bootloader.bin");
        let (_, built_app) = build_firmware(&opts, &rom)?;

        let mut py = python()?;
        py.args(["sim", "--build-dir"]).arg(&dir).arg("--rtl-dir").arg(self.rtl.dir());
        py.arg("--rom-image").arg(&rom).args(["--jobs", &self.jobs.to_string()]);
        py.args(["--baud", &self.baud.to_string(), "--rx-baud", &self.rx_baud.to_string()]);
        if self.rx_overrun {
            py.arg("--rx-overrun");
        }
        py.args(["--float-hw", self.float_hw.name(), "--l2-kib", &self.l2_kib.to_string()]);
        py.args(["--harts", &self.harts.to_string()]);
        py.args(["--pe-cache-lines", &self.pe_cache_lines.to_string()]);
        if let Some(mhz) = self.clock_mhz {
            if !(mhz.is_finite() && mhz > 0.0 && mhz <= 1000.0) {
                bail!("--clock-mhz {mhz}: expected a clock in (0, 1000] MHz");
            }
            py.args(["--clk-hz", &format!("{:.0}", mhz * 1e6)]);
        }
        if self.trace {
            py.arg("--trace");
        }
        let results =
            run_logged(py, &dir.join("litex.log"), |l| l.starts_with("sim:") || l.starts_with("board-files:"))?;
        let gateware = PathBuf::from(result(&results, "SIM_DIR")?);

        let mut cmd = Command::new(gateware.join("obj_dir/Vsim"));
        cmd.current_dir(&gateware).stdout(Stdio::piped()).stderr(Stdio::piped());
        // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        eprintln!("xtask: {} (in {})", display_command(&cmd), gateware.display());
        let mut child = cmd.spawn().context("starting the Verilator simulation")?;
        let started = Instant::now();
        let (tx, rx) = mpsc::channel();
        for stream in [
            child.stdout.take().map(|s| Box::new(s) as Box<dyn std::io::Read + Send>),
            child.stderr.take().map(|s| Box::new(s) as _),
        ]
        .into_iter()
        .flatten()
        {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stream).lines().map_while(Result::ok) {
                    let pty = line.strip_prefix(PTY_MARKER).filter(|p| p.starts_with('/'));
                    if let Some(path) = pty {
                        let _ = tx.send(path.trim().to_string());
                    } else if !(line.starts_with('[') && line.contains("] loaded")) {
                        // The module loader's chatter is noise; anything else is news.
                        eprintln!("sim: {line}");
                    }
                }
            });
        }
        let pty = match rx.recv_timeout(Duration::from_secs(30)) {
            Ok(p) => p,
            Err(_) => {
                let _ = child.kill();
                let status = child.wait()?;
                bail!("the simulation did not report its pty within 30 s ({status})");
            }
        };
        if let Some(link) = &self.link {
            let _ = std::fs::remove_file(link);
            std::os::unix::fs::symlink(&pty, link).with_context(|| format!("linking {} to {pty}", link.display()))?;
        }
        eprintln!("xtask: simulation running (pid {}): bootloader in ROM, UART on {pty}", child.id());

        if self.flash {
            let app = self.app.clone().unwrap_or(built_app);
            let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
            let mut flash = Command::new(cargo);
            flash
                .current_dir(crate::toolchain::repo_root())
                .args(["run", "--quiet", "--package", "gridrt-host", "--bin", "gridrt", "--", "flash", "--port", &pty])
                // The simulated app's start takes about 13 s of wall time before it answers
                // Hello, close to the default 15 s even before load slows the simulation.
                .args(["--boot-wait", "600"])
                .arg(&app);
            eprintln!("xtask: {}", display_command(&flash));
            let status = flash.status().context("running gridrt flash")?;
            if !status.success() {
                let _ = child.kill();
                let _ = child.wait();
                bail!("gridrt flash failed ({status})");
            }
        } else {
            eprintln!("xtask: flash the application with: gridrt flash --port {pty} {}", built_app.display());
        }
        println!("serial: {pty}");

        let deadline = self.timeout_s.map(|s| started + Duration::from_secs_f64(s));
        loop {
            if let Some(status) = child.try_wait()? {
                if let Some(link) = &self.link {
                    let _ = std::fs::remove_file(link);
                }
                if status.success() {
                    return Ok(());
                }
                bail!("the simulation exited with {status}");
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                child.kill()?;
                child.wait()?;
                if let Some(link) = &self.link {
                    let _ = std::fs::remove_file(link);
                }
                eprintln!("xtask: stopped the simulation after {:.1} s (--timeout-s)", started.elapsed().as_secs_f64());
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        sim: SimCmd,
    }

    fn parse(args: &[&str]) -> SimCmd {
        Cli::try_parse_from(["sim"].iter().chain(args)).unwrap().sim
    }

    #[test]
    fn the_cfu_is_the_default_and_each_variant_has_its_own_build_folder() {
        assert_eq!(parse(&[]).float_hw, FloatHw::Cfu);
        let names: Vec<String> = [
            &[][..],
            &["--float-hw", "none"],
            &["--harts", "2"],
            &["--float-hw", "none", "--harts", "2"],
            &["--l2-kib", "64", "--harts", "4"],
            &["--pe-cache-lines", "64"],
            &["--pe-cache-lines", "0", "--float-hw", "none"],
        ]
        .iter()
        .map(|a| parse(a).build_dir_name())
        .collect();
        assert_eq!(
            names,
            ["sim-cfu", "sim", "sim-cfu-harts-2", "sim-harts-2", "sim-cfu-l2-64-harts-4", "sim-cfu-pec-64", "sim-bram"]
        );
    }

    #[test]
    fn pe_cache_lines_are_zero_or_a_power_of_two_in_range() {
        assert_eq!(parse(&[]).pe_cache_lines, 512);
        for ok in ["0", "4", "512", "4096"] {
            assert!(Cli::try_parse_from(["sim", "--pe-cache-lines", ok]).is_ok(), "{ok}");
        }
        for bad in ["2", "500", "8192", "x"] {
            assert!(Cli::try_parse_from(["sim", "--pe-cache-lines", bad]).is_err(), "{bad}");
        }
    }
}
