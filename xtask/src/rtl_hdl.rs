//! What `cargo xtask rtl sim` ([`crate::rtl`]) and `cargo xtask rtl synth`
//! ([`crate::rtl_synth`]) share: the co-processor's build parameters and the HDL sources.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

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
    /// 0: each PE's memory is block RAM (`--pe-mem-words` of it). N > 0: each PE keeps its
    /// `--pe-mem-words` in an external memory (the `mem_*` port; SDRAM on the board) and reads
    /// it through a direct-mapped cache of N lines of 8 words (rtl/README.md §4.6). Needs
    /// `--pes-per-pipeline 4`.
    #[arg(long, default_value_t = 0, value_name = "LINES")]
    pub pe_cache_lines: u32,
    /// Stop the intersection pipe's data registers while no test is in flight
    /// (rtl/README.md §3.4). Default: true for `rtl sim` (they are most of Verilator's time),
    /// false for `rtl synth` (a clock enable on every data register does not route on the
    /// ECP5). Answers and cycles are the same either way.
    #[arg(long, value_name = "BOOL")]
    pub stop_when_empty: Option<bool>,
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
        if self.pe_cache_lines != 0 {
            if !self.pe_cache_lines.is_power_of_two() || !(4..=4096).contains(&self.pe_cache_lines) {
                bail!("--pe-cache-lines must be 0 or a power of two in 4..=4096");
            }
            if self.pe_cache_lines * 8 >= self.pe_mem_words {
                bail!("--pe-cache-lines × 8 words must be smaller than --pe-mem-words");
            }
            if self.pes_per_pipeline != 4 {
                bail!("--pe-cache-lines needs --pes-per-pipeline 4");
            }
        }
        Ok(())
    }

    /// These parameters with `--stop-when-empty` given, `default` where it was not.
    pub fn with_stop_default(mut self, default: bool) -> Self {
        self.stop_when_empty.get_or_insert(default);
        self
    }

    fn stop(&self) -> bool {
        self.stop_when_empty.unwrap_or(false)
    }

    /// The Verilog parameter overrides.
    pub fn defines(&self) -> Vec<(String, u32)> {
        vec![
            ("PES".into(), self.pes),
            ("PES_PER_PIPELINE".into(), self.pes_per_pipeline),
            ("PE_MEM_WORDS".into(), self.pe_mem_words),
            ("MAX_LIST".into(), self.max_list),
            ("STOP_WHEN_EMPTY".into(), u32::from(self.stop())),
            ("PE_CACHE".into(), u32::from(self.pe_cache_lines != 0)),
            ("CACHE_LINES".into(), if self.pe_cache_lines != 0 { self.pe_cache_lines } else { 512 }),
        ]
    }

    /// A short name for build folders (`-stop` when the pipe stops when empty).
    pub fn tag(&self) -> String {
        format!(
            "p{}-s{}-m{}-l{}{}{}",
            self.pes,
            self.pes_per_pipeline,
            self.pe_mem_words,
            self.max_list,
            if self.pe_cache_lines != 0 { format!("-c{}", self.pe_cache_lines) } else { String::new() },
            if self.stop() { "-stop" } else { "" }
        )
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

/// The WebAssembly Yosys and nextpnr map a `/tmp` of their own: a checkout under `/tmp` cannot
/// write their logs or netlists there. Says so in one line before any tool starts.
pub fn check_not_under_tmp() -> Result<()> {
    let root = root();
    let real = std::fs::canonicalize(&root).unwrap_or(root);
    if real.starts_with("/tmp") {
        bail!(
            "{}: the WebAssembly Yosys/nextpnr see their own /tmp, so synthesis cannot run from a checkout under /tmp; \
             clone the repository elsewhere (e.g. under $HOME)",
            real.display()
        );
    }
    Ok(())
}
