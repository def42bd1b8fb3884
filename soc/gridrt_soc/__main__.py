"""Command line of the SoC builds; ``cargo xtask soc`` runs it with the project's venv.

    python -m gridrt_soc sim         --build-dir DIR [--rom-image BIN] [--board-files MODE]
    python -m gridrt_soc ulx3s       --build-dir DIR --rom-image BIN [--board-files MODE]
    python -m gridrt_soc board-files [--check]

Every command prints its results as ``KEY: value`` lines (``SIM_DIR``, ``BITSTREAM``,
``REPORT``) for the caller.
"""

import argparse
import sys
import tempfile
from pathlib import Path

from litex.soc.integration.common import get_mem_data

from . import board_files
from .harts import MAX_HARTS
from .soc import CPU_VARIANTS, DEFAULT_FLOAT_HW, DEFAULT_PE_CACHE_LINES, ROM_SIZE, SDRAM_L2_SIZE, ULX3S_HARTS, ULX3S_PES

REPO = Path(__file__).resolve().parents[2]


def rom_words(path, base):
    if path is None:
        return []
    if base != 0:
        raise SystemExit(f"--rom-base {base:#x}: the ROM image must start at the ROM's origin, 0x0")
    if Path(path).stat().st_size > ROM_SIZE:
        raise SystemExit(f"{path}: {Path(path).stat().st_size} bytes do not fit the {ROM_SIZE}-byte ROM")
    return get_mem_data(str(path), endianness="little", data_width=32)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m gridrt_soc", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="cmd", required=True)

    def common(p, rom):
        p.add_argument("--build-dir", type=Path, required=True, help="output folder (under target/)")
        p.add_argument("--rtl-dir", type=Path, default=REPO / "rtl" / "hdl", help="the co-processor's SystemVerilog")
        if rom:
            p.add_argument("--rom-image", type=Path, help="ROM contents (raw binary, little-endian)")
            p.add_argument("--rom-base", type=lambda s: int(s, 0), default=0, help="address of the image's first byte")
        p.add_argument(
            "--board-files",
            choices=("check", "write", "skip"),
            default="check",
            help="compare the firmware's board files with csr.json (default), rewrite them, or neither",
        )
        p.add_argument("--jobs", type=int, default=2)
        p.add_argument(
            "--float-hw",
            choices=tuple(CPU_VARIANTS),
            default=DEFAULT_FLOAT_HW,
            help="floating point in hardware: cfu (default: VexRiscv full+cfu and the f32 CFU) or none (VexRiscv imac:"
            " smaller, no CFU, for small boards); cfu measured 12.5 %% fewer frame cycles on 1 hart, 3.5 %% on 4"
            " (BENCHMARKS.md, 'Whole frame')",
        )
        p.add_argument(
            "--l2-kib",
            type=int,
            default=SDRAM_L2_SIZE // 1024,
            help="KiB of LiteX's L2 cache in front of the SDRAM (a power of two; its data takes 16 DP16KD up to 32 KiB, 32 at 64 KiB)",
        )
        p.add_argument(
            "--harts",
            type=int,
            default=1,
            choices=range(1, MAX_HARTS + 1),
            help=f"CPUs, 1 to {MAX_HARTS}: the first and workers that trace rows of each frame beside it",
        )
        p.add_argument(
            "--pe-cache-lines",
            type=int,
            default=DEFAULT_PE_CACHE_LINES,
            help=f"N (a power of two, 4..4096; default {DEFAULT_PE_CACHE_LINES}): each PE's 2^20 words in the SDRAM's"
            " upper half, read through a cache of N 8-word lines (rtl/README.md 4.6); 0: PE memories in block RAM"
            " (16384 words each)",
        )

    sim = sub.add_parser("sim", help="generate and compile the Verilator simulation")
    common(sim, rom=True)
    sim.add_argument("--trace", action="store_true", help="build with Verilator --trace (slower)")
    sim.add_argument("--clk-hz", type=int, default=None, help="the clock the UART's pacing assumes (default: the SoC's)")
    sim.add_argument("--baud", type=int, default=0, help="SoC -> host line rate in simulated time (0: unpaced)")
    sim.add_argument("--rx-baud", type=int, default=0, help="host -> SoC line rate in simulated time (0: unpaced)")
    sim.add_argument(
        "--rx-overrun",
        action="store_true",
        help="with --rx-baud: a byte that arrives while the UART's receive FIFO is full is lost, as on a board",
    )
    ulx3s = sub.add_parser("ulx3s", help="build the ULX3S bitstream (yosys, nextpnr-ecp5, ecppack)")
    common(ulx3s, rom=True)
    ulx3s.set_defaults(harts=ULX3S_HARTS)
    ulx3s.add_argument("--device", default="LFE5U-85F", choices=("LFE5U-25F", "LFE5U-45F", "LFE5U-85F"))
    ulx3s.add_argument("--seed", type=int, default=1, help="nextpnr placement seed")
    ulx3s.add_argument("--baud", type=int, default=3_000_000, help="UART rate (the FT231X bridge goes up to 3 Mbaud)")
    ulx3s.add_argument(
        "--pes",
        type=int,
        default=ULX3S_PES,
        help=f"co-processor PEs (default {ULX3S_PES}; with --pe-cache-lines 0 each takes 40 of the 85F's 208 block RAMs"
        " and 3 fit beside the SoC's memories, BENCHMARKS.md)",
    )
    gen = sub.add_parser("board-files", help="write (or --check) the firmware's board files from csr.json")
    gen.add_argument("--check", action="store_true")

    args = parser.parse_args(argv)
    lines = getattr(args, "pe_cache_lines", 0)
    if lines and (lines & (lines - 1) or not 4 <= lines <= 4096):
        parser.error(f"--pe-cache-lines {lines}: expected 0 or a power of two in 4..4096")
    if args.cmd == "sim" and args.rx_overrun and not args.rx_baud:
        parser.error("--rx-overrun needs --rx-baud (an unpaced line cannot overrun)")
    if args.cmd == "sim":
        from . import sim

        words = rom_words(args.rom_image, args.rom_base)
        clk_hz = args.clk_hz or sim.SYS_CLK_FREQ
        gateware = sim.prepare(
            args.build_dir,
            args.rtl_dir,
            words,
            args.board_files,
            args.jobs,
            args.trace,
            clk_hz,
            args.baud,
            args.rx_baud,
            args.rx_overrun,
            args.float_hw,
            args.l2_kib * 1024,
            args.harts,
            args.pe_cache_lines,
        )
        print(f"SIM_DIR: {gateware}")
    elif args.cmd == "ulx3s":
        from . import ulx3s

        words = rom_words(args.rom_image, args.rom_base)
        result = ulx3s.build(
            args.build_dir,
            args.rtl_dir,
            words,
            args.board_files,
            args.device,
            args.seed,
            args.pes,
            args.baud,
            args.float_hw,
            args.l2_kib * 1024,
            args.harts,
            args.pe_cache_lines,
        )
        print(f"BITSTREAM: {result['bitstream']}")
        print(f"REPORT: {result['report']}")
        print(f"BAUD: {result['baud']}")
        print(f"BAUD_ERROR_PPM: {result['baud_error_ppm']:.4f}")
        print(f"BAUD_JITTER: {result['baud_jitter']:.4f}")
    elif args.cmd == "board-files":
        from . import sim

        # The simulation SoC has the memory map of every target; only its csr.json is needed
        # (no RTL sources, no build).
        with tempfile.TemporaryDirectory(prefix="gridrt-soc-map-") as tmp:
            soc = sim.make_soc(None)
            from litex.soc.integration.builder import Builder

            builder = Builder(soc, output_dir=tmp, compile_software=False, csr_json=str(Path(tmp) / "csr.json"))
            builder.build(build=True, run=False, sim_config=None, interactive=False)
            drift = board_files.apply(
                board_files.render(Path(tmp) / "csr.json", soc), "check" if args.check else "write"
            )
        return 1 if (drift and args.check) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
