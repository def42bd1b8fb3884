//! The Verilated programs: building them (through `cargo xtask rtl sim`, cached) and
//! talking to them over pipes.
//!
//! Both programs read little-endian u32 words on stdin and answer on stdout, so no C++ is
//! linked into Rust and a crashed simulation is just a dead child process.

use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::OnceLock;

/// The co-processor's build parameters (the top level's Verilog parameters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RtlParams {
    /// Processing elements.
    pub pes: u16,
    /// PEs sharing one intersection pipeline (each issues a test every this many cycles).
    pub pes_per_pipeline: u16,
    /// Words of each PE memory.
    pub pe_mem_words: u32,
    /// Longest traversal list.
    pub max_list: u16,
    /// 0: block-RAM PE memories; N: each PE's memory in the harness's external memory
    /// behind a cache of N 8-word lines (`cargo xtask rtl sim --pe-cache-lines`).
    pub pe_cache_lines: u32,
    /// The intersection pipe's data registers stop while no test is in flight (the
    /// simulation's speed; the FPGA build runs them freely). Answers and cycles are the same.
    pub stop_when_empty: bool,
}

impl Default for RtlParams {
    /// The build the tests and `render --coproc rtl` use: 4 PEs of 16 Ki words sharing one
    /// pipeline, lists of 256.
    fn default() -> Self {
        Self {
            pes: 4,
            pes_per_pipeline: 4,
            pe_mem_words: 16384,
            max_list: 256,
            pe_cache_lines: 0,
            stop_when_empty: true,
        }
    }
}

/// What the PE caches did since the program started (`CoprocSim::pe_memory`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeMemoryCounts {
    /// Cycles the co-processor stood still for its caches (line fills, the write buffer,
    /// the tag clear after the reset).
    pub stall_cycles: u64,
    /// Words read from the external memory (line fills).
    pub reads: u32,
    /// Words written to it (LOAD_PE's image and records, written through).
    pub writes: u32,
}

/// Paths of one build's programs.
#[derive(Debug, Clone)]
pub struct Programs {
    /// The co-processor (`rtl/sim/coproc_main.cpp`).
    pub coproc: PathBuf,
    /// The datapath units (`rtl/sim/units_main.cpp`).
    pub units: PathBuf,
}

/// Why the simulation is not available.
#[derive(Debug)]
pub enum SimError {
    /// `cargo xtask rtl sim` failed (Verilator missing, HDL error, …): its output.
    Build(String),
    /// The program could not be started or died.
    Io(std::io::Error),
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Build(s) => write!(f, "building the RTL simulation failed:\n{s}"),
            Self::Io(e) => write!(f, "RTL simulation: {e}"),
        }
    }
}

impl std::error::Error for SimError {}

impl From<std::io::Error> for SimError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// Builds (or reuses) the programs for `params` with `cargo xtask rtl sim`.
pub fn build(params: RtlParams) -> Result<Programs, SimError> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(workspace_root())
        .args(["run", "--quiet", "--package", "xtask", "--", "rtl", "sim"])
        .args(["--pes", &params.pes.to_string()])
        .args(["--pes-per-pipeline", &params.pes_per_pipeline.to_string()])
        .args(["--pe-mem-words", &params.pe_mem_words.to_string()])
        .args(["--max-list", &params.max_list.to_string()])
        .args(["--pe-cache-lines", &params.pe_cache_lines.to_string()])
        .args(["--stop-when-empty", &params.stop_when_empty.to_string()])
        .output()?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        return Err(SimError::Build(format!("{stdout}{}", String::from_utf8_lossy(&out.stderr))));
    }
    let find = |key: &str| stdout.lines().find_map(|l| l.strip_prefix(key).map(|p| PathBuf::from(p.trim())));
    match (find("COPROC_SIM:"), find("UNITS_SIM:")) {
        (Some(coproc), Some(units)) => Ok(Programs { coproc, units }),
        _ => Err(SimError::Build(format!("cargo xtask rtl sim printed no program paths:\n{stdout}"))),
    }
}

/// The default build, made once per process.
pub fn default_programs() -> Result<&'static Programs, &'static SimError> {
    static BUILT: OnceLock<Result<Programs, SimError>> = OnceLock::new();
    BUILT.get_or_init(|| build(RtlParams::default())).as_ref()
}

/// Environment variable listing tools whose tests are skipped (`verilator` or `all`), the
/// project-wide opt-out for tests that need an external tool.
pub const SKIP_VAR: &str = "GRIDRT_SKIP_TOOLS";

/// True when `test` may use Verilator; false (with a line on stderr) when [`SKIP_VAR`] opts
/// out of it.
///
/// # Panics
/// When Verilator does not run and is not opted out: the test fails and says how to install
/// it or opt out.
pub fn require_verilator(test: &str) -> bool {
    let value = std::env::var(SKIP_VAR).unwrap_or_default();
    let skip = value.split(',').map(|s| s.trim().to_ascii_lowercase()).any(|s| s == "verilator" || s == "all");
    let say = |line: &str| {
        let _ = std::io::stderr().write_all(format!("{line}\n").as_bytes());
    };
    if skip {
        say(&format!("{test}: SKIPPED by opt-out {SKIP_VAR}={value}: not run with verilator"));
        return false;
    }
    match Command::new("verilator").arg("--version").output() {
        Ok(o) if o.status.success() => {
            let v = String::from_utf8_lossy(&o.stdout);
            say(&format!("{test}: uses tool verilator: {}", v.lines().next().unwrap_or("").trim()));
            true
        }
        _ => panic!(
            "{test}: verilator is not installed or does not run; install it with scripts/setup-hdl.sh, \
             or skip the tests that need it with {SKIP_VAR}=verilator"
        ),
    }
}

/// A running Verilated program speaking u32 words.
pub struct Pipe {
    child: Child,
    tx: BufWriter<ChildStdin>,
    rx: BufReader<ChildStdout>,
}

impl Pipe {
    /// Starts `program`.
    pub fn spawn(program: &Path) -> Result<Self, SimError> {
        let mut child = Command::new(program).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn()?;
        let tx = BufWriter::new(child.stdin.take().ok_or_else(|| std::io::Error::other("no stdin"))?);
        let rx = BufReader::new(child.stdout.take().ok_or_else(|| std::io::Error::other("no stdout"))?);
        Ok(Self { child, tx, rx })
    }

    /// Queues words for the program.
    pub fn send(&mut self, words: &[u32]) -> Result<(), SimError> {
        for w in words {
            self.tx.write_all(&w.to_le_bytes())?;
        }
        Ok(())
    }

    /// Sends what is queued.
    pub fn flush(&mut self) -> Result<(), SimError> {
        self.tx.flush()?;
        Ok(())
    }

    /// Reads one word (flushes first, so a request never waits in our buffer).
    pub fn recv(&mut self) -> Result<u32, SimError> {
        self.flush()?;
        let mut b = [0u8; 4];
        self.rx.read_exact(&mut b)?;
        Ok(u32::from_le_bytes(b))
    }
}

impl Drop for Pipe {
    fn drop(&mut self) {
        // Closing stdin ends the program; kill it in case it is stuck.
        let _ = self.tx.flush();
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The datapath units program (`rtl/tb/gridrt_units_top.sv`).
pub struct Units {
    pipe: Pipe,
}

/// Unit selectors of the units program.
pub mod unit {
    /// f32 add/sub: (a, b, sub) → y.
    pub const ADD: u32 = 1;
    /// f32 mul: (a, b) → y.
    pub const MUL: u32 = 2;
    /// f32 → fixed: (x, k) → (q lo, q hi, huge).
    pub const TO_FIXED: u32 = 3;
    /// Intersection pipeline: ray header, 9 record words → (kind, t).
    pub const ISECT: u32 = 4;
    /// The CPU's f32 CFU on its handshake bus: header (seed, gap %, stall %),
    /// (function_id, rs1, rs2) → (rd, latency), then the command and response handshake counts.
    pub const CFU: u32 = 5;
}

/// Back-pressure of a CFU run ([`Units::cfu`]): the bus as a CPU drives it, at random.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CfuStress {
    /// Seed of the harness's generator.
    pub seed: u32,
    /// Percent chance, per cycle, of one more idle cycle before a command is offered
    /// (`cmd_valid` low); once offered, a command is held until `cmd_ready`.
    pub gap_pct: u32,
    /// Percent of the cycles with `rsp_ready` low.
    pub stall_pct: u32,
}

/// What a CFU run answered.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CfuRun {
    /// The response words in order (at most one per command).
    pub rd: Vec<u32>,
    /// Each response's latency: the clock edges from its command's handshake to the first
    /// edge with `rsp_valid` high (the earliest edge the response could be taken).
    pub latency: Vec<u32>,
    /// Command handshakes seen (`cmd_valid && cmd_ready`).
    pub commands: u32,
    /// Response handshakes seen (`rsp_valid && rsp_ready`), strays after the last command's
    /// response included.
    pub responses: u32,
}

impl Units {
    /// Starts the units program.
    pub fn spawn(program: &Path) -> Result<Self, SimError> {
        Ok(Self { pipe: Pipe::spawn(program)? })
    }

    /// Runs `vectors` (each `in_words` long) through `unit`; returns `out_words` per vector.
    pub fn run(
        &mut self,
        unit: u32,
        header: &[u32],
        vectors: &[u32],
        in_words: usize,
        out_words: usize,
    ) -> Result<Vec<u32>, SimError> {
        let count = vectors.len() / in_words;
        self.pipe.send(&[unit, count as u32])?;
        self.pipe.send(header)?;
        self.pipe.send(vectors)?;
        (0..count * out_words).map(|_| self.pipe.recv()).collect()
    }

    /// Runs `ops` (function_id, rs1, rs2) through `gridrt_cfu_f32` under `stress`.
    pub fn cfu(&mut self, stress: CfuStress, ops: &[[u32; 3]]) -> Result<CfuRun, SimError> {
        let words: Vec<u32> = ops.iter().flatten().copied().collect();
        let header = [stress.seed, stress.gap_pct, stress.stall_pct];
        // The harness runs until every command is answered (a dropped one ends it through its
        // watchdog: an error here), writes the first response per command, then the counts.
        let out = self.run(unit::CFU, &header, &words, 3, 2)?;
        let commands = self.pipe.recv()?;
        let responses = self.pipe.recv()?;
        let rd = out.iter().step_by(2).copied().collect();
        let latency = out.iter().skip(1).step_by(2).copied().collect();
        Ok(CfuRun { rd, latency, commands, responses })
    }
}

/// Cycle counters of the co-processor program.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimCycles {
    /// Clock cycles simulated since reset.
    pub total: u64,
    /// Of which the co-processor was not idle (receiving, executing or sending).
    pub busy: u64,
}

/// The co-processor program (`rtl/hdl/gridrt_coproc.sv`): FSL words in, FSL words out.
///
/// [`CoprocSim::push`] queues request words; [`CoprocSim::pop`] runs the simulation until
/// every queued word is consumed and the RTL is idle, then returns the reply words in order
/// (`None` when there are none), the same word-level behaviour as
/// `gridrt_coproc::Coprocessor::push`/`pop`.
pub struct CoprocSim {
    pipe: Pipe,
    pending: bool,
    out: std::collections::VecDeque<gridrt_shared::fsl::FslWord>,
}

impl CoprocSim {
    /// Starts the program; `stall` = (percent, seed) makes the harness drop the stream
    /// handshakes at random (the replies must not change).
    pub fn spawn(program: &Path, stall: Option<(u32, u64)>) -> Result<Self, SimError> {
        let args: Vec<String> = match stall {
            None => vec![],
            Some((pct, seed)) => vec!["--stall".into(), pct.to_string(), "--seed".into(), seed.to_string()],
        };
        Self::spawn_with(program, &args)
    }

    /// Starts the program with harness options (`--stall P`, `--seed N`, `--mem-latency N`:
    /// `rtl/sim/coproc_main.cpp`).
    pub fn spawn_with(program: &Path, args: &[String]) -> Result<Self, SimError> {
        let mut child = Command::new(program).args(args).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn()?;
        let tx = BufWriter::new(child.stdin.take().ok_or_else(|| std::io::Error::other("no stdin"))?);
        let rx = BufReader::new(child.stdout.take().ok_or_else(|| std::io::Error::other("no stdout"))?);
        Ok(Self { pipe: Pipe { child, tx, rx }, pending: false, out: Default::default() })
    }

    /// Queues one request word.
    pub fn push(&mut self, w: gridrt_shared::fsl::FslWord) -> Result<(), SimError> {
        self.pipe.send(&[1, w.data, w.control as u32])?;
        self.pending = true;
        Ok(())
    }

    /// Runs the RTL until it has consumed everything queued and is idle.
    pub fn drain(&mut self) -> Result<(), SimError> {
        self.pipe.send(&[2])?;
        let n = self.pipe.recv()?;
        for _ in 0..n {
            let data = self.pipe.recv()?;
            let control = self.pipe.recv()? & 1 == 1;
            self.out.push_back(gridrt_shared::fsl::FslWord { data, control });
        }
        self.pending = false;
        Ok(())
    }

    /// The next reply word (runs the RTL first if words were pushed since the last run).
    pub fn pop(&mut self) -> Result<Option<gridrt_shared::fsl::FslWord>, SimError> {
        if self.out.is_empty() && self.pending {
            self.drain()?;
        }
        Ok(self.out.pop_front())
    }

    /// The PE-memory counters of a build with PE caches (zero otherwise).
    pub fn pe_memory(&mut self) -> Result<PeMemoryCounts, SimError> {
        self.pipe.send(&[4])?;
        let w: Vec<u32> = (0..4).map(|_| self.pipe.recv()).collect::<Result<_, _>>()?;
        Ok(PeMemoryCounts { stall_cycles: (w[1] as u64) << 32 | w[0] as u64, reads: w[2], writes: w[3] })
    }

    /// The cycle counters.
    pub fn cycles(&mut self) -> Result<SimCycles, SimError> {
        self.pipe.send(&[3])?;
        let w: Vec<u32> = (0..4).map(|_| self.pipe.recv()).collect::<Result<_, _>>()?;
        Ok(SimCycles { total: (w[1] as u64) << 32 | w[0] as u64, busy: (w[3] as u64) << 32 | w[2] as u64 })
    }
}
