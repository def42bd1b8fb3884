//! What the `soc` subcommands share: the project's LiteX virtual environment, the SoC's
//! build folder, logged Python runs, and the firmware build that goes into the SoC's ROM.

use crate::elf;
use crate::firmware::{Bin, Board, BuildOpts, Layout};
use crate::toolchain::{self, repo_root};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Where the co-processor's SystemVerilog is.
#[derive(Args, Debug, Clone)]
pub struct RtlDir {
    /// The co-processor RTL (default: rtl/hdl of this repository).
    #[arg(long, value_name = "DIR")]
    rtl_dir: Option<PathBuf>,
}

impl RtlDir {
    /// The folder, absolute (the SoC scripts run in soc/).
    pub fn dir(&self) -> PathBuf {
        match &self.rtl_dir {
            Some(d) if d.is_relative() => std::env::current_dir().map(|c| c.join(d)).unwrap_or_else(|_| d.clone()),
            Some(d) => d.clone(),
            None => repo_root().join("rtl/hdl"),
        }
    }
}

/// Floating point in hardware on the SoC's CPU (`--float-hw`): the CPU variant, the
/// firmware's target and features that go with it.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloatHw {
    /// VexRiscv imac, soft float (riscv32imac): the smaller CPU.
    None,
    /// VexRiscv full+cfu with the f32 CFU (`gridrt_cfu_f32`): riscv32im, `cfu-float`.
    Cfu,
}

impl FloatHw {
    /// The name in reports and in `python -m gridrt_soc --float-hw`.
    pub fn name(self) -> &'static str {
        match self {
            FloatHw::None => "none",
            FloatHw::Cfu => "cfu",
        }
    }

    /// The firmware's target.
    pub fn target(self) -> toolchain::Target {
        match self {
            FloatHw::None => toolchain::Target::Riscv32imac,
            FloatHw::Cfu => toolchain::Target::Riscv32im,
        }
    }

    /// The app's extra features.
    pub fn features(self) -> Vec<String> {
        match self {
            FloatHw::None => vec![],
            FloatHw::Cfu => vec!["cfu-float".into()],
        }
    }
}

/// KiB of LiteX's L2 cache in front of the SDRAM (main RAM) unless `--l2-kib` says otherwise
/// (`SDRAM_L2_SIZE` of soc/gridrt_soc/soc.py).
pub const DEFAULT_L2_KIB: u32 = 8;

/// Lines of each PE cache unless `--pe-cache-lines` says otherwise (`DEFAULT_PE_CACHE_LINES`
/// of soc/gridrt_soc/soc.py): the PE images in SDRAM, so that scenes beyond block RAM load.
pub const DEFAULT_PE_CACHE_LINES: u32 = 512;

/// Harts a SoC build may have (`MAX_HARTS` of soc/gridrt_soc/harts.py).
pub const MAX_HARTS: u32 = 4;

/// `--harts`: 1 to [`MAX_HARTS`].
pub fn parse_harts(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if (1..=MAX_HARTS).contains(&n) => Ok(n),
        _ => Err(format!("`{s}`: expected 1 to {MAX_HARTS} harts")),
    }
}

/// `--pe-cache-lines`: 0, or a power of two in 4..=4096.
pub fn parse_pe_cache_lines(s: &str) -> Result<u32, String> {
    let n: u32 = s.parse().map_err(|_| format!("`{s}` is not a number of lines"))?;
    if n == 0 || (n.is_power_of_two() && (4..=4096).contains(&n)) {
        Ok(n)
    } else {
        Err(format!("{n}: expected 0 or a power of two in 4..=4096"))
    }
}

/// `--l2-kib`: a power of two from 1 to 256.
pub fn parse_l2_kib(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(k) if k.is_power_of_two() && (1..=256).contains(&k) => Ok(k),
        _ => Err(format!("`{s}`: expected a power of two from 1 to 256 (KiB of L2 cache)")),
    }
}

/// The project's Python environment for LiteX (scripts/setup-soc.sh).
pub fn venv() -> PathBuf {
    repo_root().join(".toolchain/soc-venv")
}

/// Output folder of the SoC builds.
pub fn soc_target_dir() -> PathBuf {
    repo_root().join("target/soc")
}

/// `python -m gridrt_soc` in the project's venv (set up first when missing), run in soc/.
pub fn python() -> Result<Command> {
    let ready = Command::new("bash")
        .arg(repo_root().join("scripts/setup-soc.sh"))
        .arg("--check")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ready {
        eprintln!("xtask: the SoC tools are not set up; running scripts/setup-soc.sh");
        toolchain::run_script("setup-soc.sh", None)?;
    }
    let mut cmd = Command::new(venv().join("bin/python"));
    cmd.current_dir(repo_root().join("soc")).args(["-m", "gridrt_soc"]);
    Ok(cmd)
}

/// How often [`run_logged`] says that its command is still running.
const HEARTBEAT: std::time::Duration = std::time::Duration::from_secs(30);

/// Runs `cmd`, its output going to `log` (LiteX and the tools are verbose); echoes the
/// lines that `keep` selects and returns every `KEY: value` line as (KEY, value).
pub fn run_logged(mut cmd: Command, log: &Path, keep: fn(&str) -> bool) -> Result<Vec<(String, String)>> {
    use std::io::{BufRead, BufReader, Write};
    if let Some(dir) = log.parent() {
        std::fs::create_dir_all(dir)?;
    }
    eprintln!("xtask: {} (log: {})", toolchain::display_command(&cmd), log.display());
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("starting {:?}", cmd.get_program()))?;
    let stderr = child.stderr.take().context("stderr pipe")?;
    let log_err = std::fs::File::create(log.with_extension("stderr.log"))?;
    // Never silent: Yosys and nextpnr run for tens of minutes inside LiteX, their output only
    // in the logs; a heartbeat says how long it has run and the last line either log got.
    let last = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let heartbeat = {
        let (last, done) = (last.clone(), done.clone());
        let start = std::time::Instant::now();
        std::thread::spawn(move || {
            let mut next = HEARTBEAT;
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                std::thread::sleep(std::time::Duration::from_millis(200));
                if start.elapsed() >= next {
                    next += HEARTBEAT;
                    let line = last.lock().map(|l| l.clone()).unwrap_or_default();
                    let line: String = line.trim().chars().take(100).collect();
                    eprintln!("xtask: still running ({:.0} s): {line}", start.elapsed().as_secs_f64());
                }
            }
        })
    };
    let err_thread = {
        let last = last.clone();
        std::thread::spawn(move || {
            let mut log_err = log_err;
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let _ = writeln!(log_err, "{line}");
                if !line.trim().is_empty() {
                    if let Ok(mut l) = last.lock() {
                        *l = line;
                    }
                }
            }
        })
    };
    let mut out = std::fs::File::create(log)?;
    let mut results = vec![];
    for line in BufReader::new(child.stdout.take().context("stdout pipe")?).lines().map_while(Result::ok) {
        writeln!(out, "{line}")?;
        if !line.trim().is_empty() {
            if let Ok(mut l) = last.lock() {
                l.clone_from(&line);
            }
        }
        if let Some((k, v)) =
            line.split_once(": ").filter(|(k, _)| k.chars().all(|c| c.is_ascii_uppercase() || c == '_'))
        {
            results.push((k.to_string(), v.trim().to_string()));
        } else if keep(&line) {
            eprintln!("{line}");
        }
    }
    let _ = err_thread.join();
    let status = child.wait()?;
    done.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = heartbeat.join();
    if !status.success() {
        let err = std::fs::read_to_string(log.with_extension("stderr.log")).unwrap_or_default();
        let tail: Vec<&str> = err.lines().rev().take(25).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        bail!("{:?} failed ({status}); logs {}:\n{}", cmd.get_program(), log.display(), tail.join("\n"));
    }
    Ok(results)
}

/// The value of `key` among `KEY: value` lines.
pub fn result(results: &[(String, String)], key: &str) -> Result<String> {
    results.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone()).with_context(|| format!("no `{key}:` line"))
}

/// Builds the bootloader and the app for the LiteX board; writes the bootloader's ROM
/// image (raw bytes from the ROM's origin) to `rom_bin`. Returns (bootloader ELF, app ELF).
pub fn build_firmware(opts: &BuildOpts, rom_bin: &Path) -> Result<(PathBuf, PathBuf)> {
    let bootloader = BuildOpts { bin: Bin::Bootloader, features: vec![], ..opts.clone() }.build(Board::Litex)?;
    let app = BuildOpts { bin: Bin::App, layout: Layout::Bootloaded, ..opts.clone() }.build(Board::Litex)?;
    let (base, image) = elf::load_image(&bootloader)?;
    if base != 0 {
        bail!("{}: the bootloader starts at {base:#010x}, not at the ROM's origin 0x0", bootloader.display());
    }
    if let Some(dir) = rom_bin.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(rom_bin, &image).with_context(|| format!("writing {}", rom_bin.display()))?;
    eprintln!("xtask: ROM image {} ({} bytes) from {}", rom_bin.display(), image.len(), bootloader.display());
    Ok((bootloader, app))
}
