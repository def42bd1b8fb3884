//! Selects the memory map for the board feature and passes riscv-rt's linker scripts.
//!
//! The linker contract is documented in the repo-root `memory.x` and in README.md.

use std::{env, fs, path::PathBuf};

/// (cargo feature env var, board name, memory map relative to this crate).
const BOARDS: &[(&str, &str, &str)] = &[
    (
        "CARGO_FEATURE_BOARD_QEMU_VIRT",
        "qemu-virt",
        "../../memory.x",
    ),
    (
        "CARGO_FEATURE_BOARD_FPGA_SOC",
        "fpga-soc",
        "boards/fpga-soc.x",
    ),
];

fn main() {
    let manifest_dir =
        PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));

    let selected: Vec<_> = BOARDS
        .iter()
        .filter(|(feature, _, _)| env::var_os(feature).is_some())
        .collect();
    let &&(_, board, memory_x) = match selected.as_slice() {
        [one] => one,
        _ => panic!(
            "ERROR(gridrt-firmware-image): enable exactly one board feature (got {}); \
             use `cargo xtask firmware --board NAME`, or `--no-default-features --features board-NAME`",
            selected.iter().map(|(_, b, _)| *b).collect::<Vec<_>>().join(", ")
        ),
    };

    // riscv-rt's link.x expects a file named memory.x on the linker search path.
    let src = manifest_dir.join(memory_x);
    let text =
        fs::read_to_string(&src).unwrap_or_else(|e| panic!("reading {}: {e}", src.display()));
    fs::write(out_dir.join("memory.x"), text).expect("writing memory.x to OUT_DIR");
    println!("cargo:rerun-if-changed={}", src.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-search={}", out_dir.display());
    // memory.x must come before link.x, which uses the REGION_* aliases it defines.
    println!("cargo:rustc-link-arg-bins=-Tmemory.x");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-env=GRIDRT_BOARD={board}");
}
