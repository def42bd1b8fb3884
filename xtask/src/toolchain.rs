//! Paths of the repository and the choice of cross-compiler.
//!
//! Two ways to build for the soft-core, tried in this order (DESIGN.md §6):
//! 1. the rustup target (`rustup target add ...`): plain `cargo build --target`;
//! 2. Debian's rustc-web unpacked into `.toolchain/` by scripts/setup-riscv-toolchain.sh:
//!    `core` is built from its sources with `-Zbuild-std`, which needs `RUSTC_BOOTSTRAP=1`.

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root (xtask lives one level below it).
pub fn repo_root() -> PathBuf {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.parent().unwrap_or(manifest_dir).to_path_buf()
}

/// The firmware image package (its own cargo workspace).
pub fn image_dir() -> PathBuf {
    repo_root().join("firmware").join("image")
}

/// Target directory of the image builds (fixed, so the ELF path is known).
pub fn image_target_dir() -> PathBuf {
    image_dir().join("target")
}

/// Where scripts/setup-riscv-toolchain.sh unpacks the Debian toolchain.
fn debian_dir() -> PathBuf {
    repo_root().join(".toolchain")
}

/// Instruction sets of the soft-core we build for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Target {
    /// RV32IMAC, soft float (ilp32).
    Riscv32imac,
    /// RV32IMAFC, single-precision hard float (ilp32f).
    Riscv32imafc,
    /// RV32IM, soft float (ilp32): the SoC's VexRiscv `full+cfu`, whose f32 add and
    /// multiply run in the co-processor RTL's units behind its CFU port (`--features
    /// cfu-float`).
    Riscv32im,
}

impl Target {
    pub fn triple(self) -> &'static str {
        match self {
            Target::Riscv32imac => "riscv32imac-unknown-none-elf",
            Target::Riscv32imafc => "riscv32imafc-unknown-none-elf",
            Target::Riscv32im => "riscv32im-unknown-none-elf",
        }
    }
}

/// Which toolchain to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ToolchainChoice {
    /// The rustup target if installed, else the Debian toolchain; set one up if neither is.
    Auto,
    /// Only the rustup target.
    Rustup,
    /// Only the Debian toolchain in .toolchain/.
    Debian,
}

/// A resolved toolchain.
#[derive(Clone, Debug)]
pub enum Toolchain {
    Rustup,
    Debian { root: PathBuf },
}

impl Toolchain {
    /// Finds a toolchain for `target`, running the setup script when none is there.
    pub fn resolve(choice: ToolchainChoice, target: Target) -> Result<Self> {
        if let Some(tc) = Self::find(choice, target) {
            return Ok(tc);
        }
        let flag = match choice {
            ToolchainChoice::Auto => None,
            ToolchainChoice::Rustup => Some("--rustup-only"),
            ToolchainChoice::Debian => Some("--debian"),
        };
        eprintln!("xtask: no toolchain for {} yet; running the setup script", target.triple());
        run_script("setup-riscv-toolchain.sh", flag)?;
        Self::find(choice, target)
            .with_context(|| format!("the setup script ran but no toolchain for {} is usable", target.triple()))
    }

    fn find(choice: ToolchainChoice, target: Target) -> Option<Self> {
        let rustup = || rustup_has_target(target).then_some(Toolchain::Rustup);
        let debian = || debian_ready().then(|| Toolchain::Debian { root: debian_dir() });
        match choice {
            ToolchainChoice::Auto => rustup().or_else(debian),
            ToolchainChoice::Rustup => rustup(),
            ToolchainChoice::Debian => debian(),
        }
    }

    /// A human-readable name for the build log.
    pub fn describe(&self) -> String {
        match self {
            Toolchain::Rustup => "rustup target".into(),
            Toolchain::Debian { .. } => "Debian rustc in .toolchain/ with -Zbuild-std=core".into(),
        }
    }

    /// `cargo build` for `target` with everything this toolchain needs (env, -Z flags).
    pub fn cargo_build(&self, target: Target) -> Command {
        // The cargo that runs xtask; with rustup it belongs to the active toolchain.
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.arg("build").arg("--target").arg(target.triple());
        if let Toolchain::Debian { root } = self {
            let lib = root.join("usr/lib/x86_64-linux-gnu");
            let ld_path = match std::env::var_os("LD_LIBRARY_PATH") {
                Some(old) if !old.is_empty() => {
                    let mut p = lib.into_os_string();
                    p.push(":");
                    p.push(old);
                    p
                }
                _ => lib.into_os_string(),
            };
            let linker_var = format!("CARGO_TARGET_{}_LINKER", target.triple().to_uppercase().replace('-', "_"));
            cmd.env("RUSTC", root.join("usr/bin/rustc"))
                // -Zbuild-std is unstable; Debian's rustc is a stable release.
                .env("RUSTC_BOOTSTRAP", "1")
                .env("LD_LIBRARY_PATH", ld_path)
                // The Debian rustc has no rust-lld; use lld-22's ld.lld.
                .env(linker_var, root.join("usr/lib/llvm-22/bin/ld.lld"))
                .arg("-Zbuild-std=core")
                // No libc on the target: compiler_builtins must provide memcpy & co.
                .arg("-Zbuild-std-features=compiler-builtins-mem");
        }
        cmd
    }
}

fn rustup_has_target(target: Target) -> bool {
    let out = Command::new("rustup").args(["target", "list", "--installed"]).current_dir(image_dir()).output();
    match out {
        Ok(out) if out.status.success() => {
            String::from_utf8_lossy(&out.stdout).lines().any(|l| l.trim() == target.triple())
        }
        _ => false,
    }
}

fn debian_ready() -> bool {
    let root = debian_dir();
    let stamped = std::fs::read_dir(&root)
        .map(|dir| dir.filter_map(|e| e.ok()).any(|e| e.file_name().to_string_lossy().starts_with(".installed-")))
        .unwrap_or(false);
    stamped && root.join("usr/bin/rustc").is_file() && root.join("usr/lib/llvm-22/bin/ld.lld").exists()
}

/// Runs `scripts/<name>` with bash, failing if it fails.
pub fn run_script(name: &str, arg: Option<&str>) -> Result<()> {
    let path = repo_root().join("scripts").join(name);
    let mut cmd = Command::new("bash");
    cmd.arg(&path).args(arg);
    let status = cmd.status().with_context(|| format!("running {}", path.display()))?;
    if !status.success() {
        bail!("{} failed ({status})", path.display());
    }
    Ok(())
}

/// Runs a command, echoing it first, failing on a non-zero exit.
pub fn run_echoed(cmd: &mut Command) -> Result<()> {
    eprintln!("xtask: {}", display_command(cmd));
    let status = cmd.status().with_context(|| format!("starting {:?}", cmd.get_program()))?;
    if !status.success() {
        bail!("{:?} failed ({status})", cmd.get_program());
    }
    Ok(())
}

/// The command line with the environment it sets, as one could paste it in a shell.
pub fn display_command(cmd: &Command) -> String {
    let mut s = String::new();
    for (k, v) in cmd.get_envs() {
        if let Some(v) = v {
            s.push_str(&format!("{}={} ", k.to_string_lossy(), v.to_string_lossy()));
        }
    }
    s.push_str(&cmd.get_program().to_string_lossy());
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}
