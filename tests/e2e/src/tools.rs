//! External tools a test needs (QEMU, socat, Verilator, LiteX, Chromium), and the one way to do without
//! them.
//!
//! A test that needs a tool calls [`require`] first. The tool missing is a test failure, with
//! the install script named. Only an explicit opt-out skips such tests:
//!
//! ```sh
//! GRIDRT_SKIP_TOOLS=qemu,socat,verilator,litex,chromium cargo test --workspace    # or GRIDRT_SKIP_TOOLS=all
//! ```
//!
//! The co-simulation tests (gridrt-rtl, `gridrt render --coproc rtl`) check `verilator` with
//! `gridrt_rtl::sim::require_verilator`, the same rule.
//!
//! A skipped test passes, so it says so where a user looks: one line per test on the real
//! standard error (libtest captures only `print!`/`eprint!`, not direct writes), which shows
//! in the `cargo test` output next to the test's `ok`. A test that runs says which tool
//! version it uses, the same way; `.ci/run` counts both kinds of line and fails when a tool's
//! tests were skipped or ran zero times (`scripts/check-tool-tests.sh`).
//!
//! The SoC simulation test is slow (minutes), so it also waits for an opt-in,
//! `GRIDRT_SOC_SIM=1` ([`soc_sim_opted_in`]); `.ci/run` gives it.

use std::io::Write as _;
use std::process::Command;

/// Comma-separated tools whose tests are skipped (`qemu`, `socat`, `verilator`, `litex`,
/// `chromium`, or `all`).
pub const SKIP_VAR: &str = "GRIDRT_SKIP_TOOLS";

/// Start of the line a test skipped by [`SKIP_VAR`] writes.
pub const SKIPPED: &str = "SKIPPED by opt-out";

/// Start of the line a test that uses a tool writes.
pub const USES: &str = "uses tool";

/// A tool some tests need.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tool {
    /// `qemu-system-riscv32`: boots the firmware images.
    Qemu,
    /// `socat`: linked pseudo-terminal pairs.
    Socat,
    /// `verilator`: the RTL co-simulation and the LiteX SoC's simulation.
    Verilator,
    /// LiteX and its simulation libraries in the project's `.toolchain/soc-venv/` (checked with
    /// `scripts/setup-soc.sh --check`).
    Litex,
    /// `chromium` (Debian's), headless: loads `gridrt render --view`'s page.
    Chromium,
}

impl Tool {
    /// Every tool, in the order [`SKIP_VAR`] lists them.
    pub const ALL: [Tool; 5] = [Tool::Qemu, Tool::Socat, Tool::Verilator, Tool::Litex, Tool::Chromium];

    /// The name [`SKIP_VAR`] uses.
    pub fn key(self) -> &'static str {
        match self {
            Tool::Qemu => "qemu",
            Tool::Socat => "socat",
            Tool::Verilator => "verilator",
            Tool::Litex => "litex",
            Tool::Chromium => "chromium",
        }
    }

    /// The program run.
    pub fn program(self) -> &'static str {
        match self {
            Tool::Qemu => "qemu-system-riscv32",
            Tool::Socat => "socat",
            Tool::Verilator => "verilator",
            Tool::Litex => "scripts/setup-soc.sh",
            Tool::Chromium => "chromium",
        }
    }

    /// The script that installs the tool.
    pub fn setup_script(self) -> &'static str {
        match self {
            Tool::Qemu | Tool::Socat => "scripts/setup-qemu.sh",
            Tool::Verilator => "scripts/setup-hdl.sh",
            Tool::Litex => "scripts/setup-soc.sh",
            Tool::Chromium => "scripts/setup-browser.sh",
        }
    }

    fn version_command(self) -> Command {
        match self {
            Tool::Qemu | Tool::Verilator | Tool::Chromium => {
                let mut c = Command::new(self.program());
                c.arg("--version");
                c
            }
            Tool::Socat => {
                let mut c = Command::new(self.program());
                c.arg("-V");
                c
            }
            Tool::Litex => {
                let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
                let mut c = Command::new("bash");
                c.arg(repo.join(self.program())).arg("--check");
                c
            }
        }
    }

    /// First line of the tool's version text, or `None` when it does not run.
    pub fn version(self) -> Option<String> {
        let out = self.version_command().output().ok()?;
        if !out.status.success() {
            return None;
        }
        let text = String::from_utf8_lossy(&out.stdout);
        let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or(self.program());
        Some(line.trim().to_string())
    }
}

/// The tools `value` (a [`SKIP_VAR`] value) opts out of; an unknown name is an error, so a
/// typo does not pass for an opt-out.
pub fn parse_skip_list(value: &str) -> Result<Vec<Tool>, String> {
    let mut tools = Vec::new();
    for name in value.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let name = name.to_ascii_lowercase();
        if name == "all" {
            return Ok(Tool::ALL.to_vec());
        }
        match Tool::ALL.iter().find(|t| t.key() == name) {
            Some(t) if !tools.contains(t) => tools.push(*t),
            Some(_) => {}
            None => {
                let known: Vec<_> = Tool::ALL.iter().map(|t| t.key()).collect();
                return Err(format!("{SKIP_VAR}: unknown tool `{name}` (known: {}, all)", known.join(", ")));
            }
        }
    }
    Ok(tools)
}

/// True when `test` may run with `tool`. False when [`SKIP_VAR`] opts out of the tool: the
/// test should return at once (a line on standard error says it was skipped and why).
///
/// # Panics
/// When the tool does not run and is not opted out (the test fails, naming the install
/// script and the opt-out), or when [`SKIP_VAR`] names an unknown tool.
pub fn require(test: &str, tool: Tool) -> bool {
    let value = std::env::var(SKIP_VAR).unwrap_or_default();
    let skipped = parse_skip_list(&value).unwrap_or_else(|e| panic!("{test}: {e}"));
    if skipped.contains(&tool) {
        say(&format!("{test}: {SKIPPED} {SKIP_VAR}={value}: not run with {}", tool.program()));
        return false;
    }
    match tool.version() {
        Some(v) => {
            say(&format!("{test}: {USES} {}: {v}", tool.program()));
            true
        }
        None => panic!(
            "{test}: {} is not installed or does not run; install it with {}, \
             or skip the tests that need it with {SKIP_VAR}={}",
            tool.program(),
            tool.setup_script(),
            tool.key()
        ),
    }
}

/// Opts in to the SoC simulation test (`GRIDRT_SOC_SIM=1`): a soft-core simulated cycle by
/// cycle takes minutes, so `cargo test --workspace` runs it only when asked (`.ci/run` asks).
pub const SOC_SIM_VAR: &str = "GRIDRT_SOC_SIM";

/// Start of the line a test that waits for an opt-in writes when it is not given.
pub const NOT_OPTED_IN: &str = "SKIPPED without opt-in";

/// True when [`SOC_SIM_VAR`] is `1`; otherwise `test` should return at once (a line on
/// standard error says it was skipped and how to run it).
pub fn soc_sim_opted_in(test: &str) -> bool {
    opted_in(test, SOC_SIM_VAR, "the SoC simulation takes minutes")
}

/// Set to `1` (besides [`SOC_SIM_VAR`]) to run the long SoC tests, 11 minutes (the imac SoC,
/// bun_zipper_res3) to an hour (stanford-bunny) of simulation each: not in CI.
pub const SOC_SIM_LONG_VAR: &str = "GRIDRT_SOC_SIM_LONG";

/// True when [`SOC_SIM_LONG_VAR`] is `1`; otherwise `test` should return at once (a line
/// on standard error says it was skipped and how to run it).
pub fn soc_sim_long_opted_in(test: &str) -> bool {
    opted_in(test, SOC_SIM_LONG_VAR, "a long simulation: 11 minutes to an hour")
}

/// True when `var` is `1`; otherwise says that `test` was skipped, how to run it and why.
fn opted_in(test: &str, var: &str, why: &str) -> bool {
    if std::env::var(var).is_ok_and(|v| v.trim() == "1") {
        return true;
    }
    say(&format!("{test}: {NOT_OPTED_IN} {var}=1 ({why})"));
    false
}

/// One line on the process's standard error, past libtest's output capture, in one write
/// (so it does not interleave with libtest's own lines).
fn say(line: &str) {
    let _ = std::io::stderr().write_all(format!("{line}\n").as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skip_list_names_tools_or_all_and_refuses_typos() {
        assert_eq!(parse_skip_list(""), Ok(vec![]));
        assert_eq!(parse_skip_list("qemu"), Ok(vec![Tool::Qemu]));
        assert_eq!(parse_skip_list(" SOCAT , qemu,socat"), Ok(vec![Tool::Socat, Tool::Qemu]));
        assert_eq!(parse_skip_list("verilator"), Ok(vec![Tool::Verilator]));
        assert_eq!(parse_skip_list("all"), Ok(Tool::ALL.to_vec()));
        let e = parse_skip_list("qemu,qemuu").unwrap_err();
        assert!(
            e.contains("unknown tool `qemuu`") && e.contains("known: qemu, socat, verilator, litex, chromium, all"),
            "{e}"
        );
        assert_eq!(parse_skip_list("litex,verilator"), Ok(vec![Tool::Litex, Tool::Verilator]));
        assert_eq!(parse_skip_list("chromium"), Ok(vec![Tool::Chromium]));
    }
}
