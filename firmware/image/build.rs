//! Selects the memory maps for the board and layout features and passes riscv-rt's linker
//! scripts, per binary:
//!
//! | binary | layout feature | memory map |
//! | --- | --- | --- |
//! | `app` | (none: standalone) | the board's map (qemu-virt: repo-root `memory.x`) |
//! | `app` | `layout-bootloaded` | `boards/<board>-bootloaded.x` (the application region) |
//! | `bootloader` | any | `boards/<board>-bootloader.x` (below the application region) |
//!
//! The linker contract is documented in the repo-root `memory.x` and in README.md.

use std::{
    env, fs,
    path::{Path, PathBuf},
};

/// (cargo feature env var, board name, standalone app map, bootloaded app map,
/// bootloader map, files the maps `INCLUDE`), relative to this crate.
type Board = (&'static str, &'static str, &'static str, &'static str, &'static str, &'static [&'static str]);

const BOARDS: &[Board] = &[
    (
        "CARGO_FEATURE_BOARD_QEMU_VIRT",
        "qemu-virt",
        "../../memory.x",
        "boards/qemu-virt-bootloaded.x",
        "boards/qemu-virt-bootloader.x",
        &[],
    ),
    (
        "CARGO_FEATURE_BOARD_FPGA_SOC",
        "fpga-soc",
        "boards/fpga-soc.x",
        "boards/fpga-soc-bootloaded.x",
        "boards/fpga-soc-bootloader.x",
        &[],
    ),
    // The LiteX SoC (soc/): the application lives in main RAM in both layouts; the memory
    // regions are generated from the SoC's csr.json (litex-regions.x).
    (
        "CARGO_FEATURE_BOARD_LITEX",
        "litex",
        "boards/litex.x",
        "boards/litex.x",
        "boards/litex-bootloader.x",
        &["boards/litex-regions.x"],
    ),
];

fn copy(manifest_dir: &Path, out_dir: &Path, from: &str, to: &str) {
    let src = manifest_dir.join(from);
    let text = fs::read_to_string(&src).unwrap_or_else(|e| panic!("reading {}: {e}", src.display()));
    fs::write(out_dir.join(to), text).unwrap_or_else(|e| panic!("writing {to} to OUT_DIR: {e}"));
    println!("cargo:rerun-if-changed={}", src.display());
}

fn main() {
    let manifest_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));

    let selected: Vec<_> = BOARDS.iter().filter(|(feature, ..)| env::var_os(feature).is_some()).collect();
    let &&(_, board, standalone, bootloaded, bootloader, includes) = match selected.as_slice() {
        [one] => one,
        _ => panic!(
            "ERROR(gridrt-firmware-image): enable exactly one board feature (got {}); \
             use `cargo xtask firmware --board NAME`, or `--no-default-features --features board-NAME`",
            selected.iter().map(|(_, b, ..)| *b).collect::<Vec<_>>().join(", ")
        ),
    };
    let layout_bootloaded = env::var_os("CARGO_FEATURE_LAYOUT_BOOTLOADED").is_some();
    let app_map = if layout_bootloaded { bootloaded } else { standalone };

    // riscv-rt's link.x needs the REGION_* aliases defined before it is read, so each
    // binary gets its own memory map first, then link.x.
    copy(&manifest_dir, &out_dir, app_map, "memory.x");
    copy(&manifest_dir, &out_dir, bootloader, "bootloader-memory.x");
    for include in includes {
        let name = Path::new(include).file_name().and_then(|n| n.to_str()).expect("an include is a file name");
        copy(&manifest_dir, &out_dir, include, name);
    }
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-search={}", out_dir.display());
    for (bin, map) in [("app", "memory.x"), ("bootloader", "bootloader-memory.x")] {
        println!("cargo:rustc-link-arg-bin={bin}=-T{map}");
        println!("cargo:rustc-link-arg-bin={bin}=-Tlink.x");
    }
    println!("cargo:rustc-env=GRIDRT_BOARD={board}");
    println!("cargo:rustc-env=GRIDRT_APP_LAYOUT={}", if layout_bootloaded { "bootloaded" } else { "standalone" });
}
