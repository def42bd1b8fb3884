"""``GridrtSoC``: the SoC every target builds, so that all of them share one memory map.

- CPU: VexRiscv, variant ``full+cfu`` (RV32IM, 4 KiB I- and D-caches, ``mcycle``/``minstret``
  readable: the firmware's stage counters, a CFU port) with the floating-point CFU
  (``soc/hdl/gridrt_cfu_litex.sv``), the firmware built for ``riscv32im-unknown-none-elf``
  with its ``cfu-float`` feature: the default, ``float_hw="cfu"``. With ``float_hw="none"``:
  variant ``imac`` (RV32IMAC, the same caches, no CFU; f32 in soft float), the firmware built
  for ``riscv32imac-unknown-none-elf``.
- ROM (``rom``, 32 KiB at 0x0000_0000, the reset vector): the gridrt bootloader, from the
  bitstream / the simulation's ROM image.
- SRAM (``sram``, 16 KiB at 0x1000_0000): the bootloader's data and stack.
- Main RAM (``main_ram``, 16 MiB at 0x4000_0000): the lower half of the board's SDRAM
  through LiteDRAM (32 MiB of MT48LC16M16, 16 bits wide, behind an 8 KiB L2 cache; in
  simulation LiteDRAM's ``SDRAMPHYModel`` of the same chip). The application region: the
  bootloader initialises the memory controller before anything else (``SDRAM_INIT`` in the
  board files) and writes the application here (``gridrt flash``), which then uses all of
  it. Block RAM is left to the co-processor.
- PE images (the upper 16 MiB of the SDRAM, not on the CPU's bus): with ``pe_cache_lines``
  > 0 the co-processor keeps each PE's memory there, 2²⁰ words per PE, and reads it through a
  cache of that many 8-word lines per PE (rtl/README.md §4.6), on a LiteDRAM port of its
  own; else its PE memories are block RAM (16 384 words each).
- CSRs (0xF000_0000, uncached): ``ctrl``, ``identifier_mem``, ``uart`` (LiteX UART, 64-byte
  FIFOs, a read of ``rxtx`` pops), ``timer0``, ``coproc`` (``coproc.GridrtCoprocCSR``; its
  configuration, PEs and words per PE, is readable there), ``sdram`` (LiteDRAM's DFII),
  ``harts`` (``harts.GridrtHarts``: worker harts and the registers they coordinate
  through) and ``coproc1..3`` (the workers' ports on the co-processor, ``coproc.CoprocPort``).
- Harts: 1 by default; ``harts=N`` (up to 4) adds N − 1 worker VexRiscvs of the same
  variant, which trace rows of each frame beside the first (``firmware/image/src/harts.rs``).
  Then every hart, the first included, has 32 KiB of block RAM of its own at
  ``HART_RAM_BASE`` (``harts.HartPrivateRam``), for the stack it traces rows on.

The firmware's board files are generated from this SoC's csr.json (``board_files``); the
target only brings its clock/reset generator and UART PHY.
"""

from pathlib import Path

from litedram.frontend.wishbone import LiteDRAMWishbone2Native
from litex.soc.cores.uart import UART
from litex.soc.integration.soc_core import SoCCore

from .coproc import CoprocPort, GridrtCoprocCSR
from .harts import HART_RAM_BASE, HART_RAM_SIZE, MAX_HARTS, GridrtHarts, HartPrivateRam

KIB = 1024

# Sizes of the memory map (board_files writes them into the firmware's linker scripts).
ROM_SIZE = 32 * KIB
SRAM_SIZE = 16 * KIB

# Main RAM: the ULX3S's SDRAM chip, modelled the same in simulation (one memory map). The
# module class is LiteDRAM's (``litedram.modules``); the rate 1:1 is GENSDRPHY's.
SDRAM_MODULE = "MT48LC16M16"
SDRAM_RATE = "1:1"
SDRAM_DATA_WIDTH = 16
# LiteX's L2 cache between the CPU's bus and LiteDRAM: its default size. It holds the hot
# code and stack that the CPU's 4 KiB caches miss (docs/bench-frame.md measures 8 and 32
# KiB); a target may build another (``l2_size``, a power of two). Its data is 16 byte-wide
# memories, one DP16KD each up to 32 KiB (2 each at 64 KiB), beside its tags; 32 KiB did not
# route on the ULX3S (docs/bench-frame.md).
SDRAM_L2_SIZE = 8 * KIB
# The SDRAM's halves: main RAM, then the PE images (with PE caches: each PE's memory of
# COPROC_PE_IMAGE_WORDS words, 4 PEs × 4 MiB).
MAIN_RAM_SIZE = 16 * KIB * KIB
PE_IMAGES_OFFSET = MAIN_RAM_SIZE
PE_IMAGES_SIZE = 16 * KIB * KIB
COPROC_PE_IMAGE_WORDS = 1 << 20


def sdram_module(clk_freq):
    """The SDRAM chip's LiteDRAM module (geometry and timings at ``clk_freq``)."""
    from litedram import modules

    return getattr(modules, SDRAM_MODULE)(clk_freq, SDRAM_RATE)

# Every target runs the system clock at this frequency (the simulation nominally), so that
# csr.json and the firmware's board files are the same for all of them.
SYS_CLK_FREQ = int(50e6)

UART_FIFO_DEPTH = 64

# The co-processor configuration (the RTL's defaults: GridRT's 4 PEs). 16384 words per PE cost
# the same block RAM as 8192 on the ECP5 (a true dual-port bank of 32-bit words takes two
# 18-bit-wide DP16KD either way). A target may build fewer PEs (`pes`); the firmware reads
# the configuration from the `coproc` CSRs at run time, so the memory map stays the same.
COPROC_PES = 4
COPROC_PE_MEM_WORDS = 16384
COPROC_MAX_LIST = 256
COPROC_FIFO_DEPTH = 16

# Floating point in hardware: "none" (VexRiscv imac, soft float) or "cfu" (VexRiscv
# full+cfu and the CFU). The CPU variant per choice.
CPU_VARIANTS = {"none": "imac", "cfu": "full+cfu"}
# The default, as in `cargo xtask soc sim|build`: the CFU measured fewer frame cycles than
# the imac (BENCHMARKS.md, "Whole frame"); the imac is the smaller CPU, for small boards.
DEFAULT_FLOAT_HW = "cfu"
# PE memories by default: the PE images in SDRAM behind caches of this many 8-word lines
# (rtl/README.md §4.6), so that scenes beyond block RAM load; 0 is block RAM.
DEFAULT_PE_CACHE_LINES = 512
# The ULX3S build's default size (`cargo xtask soc build` keeps them in step): 4 PEs behind
# the caches above and a second hart fit the LFE5U-85F (BENCHMARKS.md, "The LiteX SoC").
ULX3S_PES = 4
ULX3S_HARTS = 2
# LiteX's `Cfu` module on the CPU's CFU port: a wrapper of rtl/hdl/gridrt_cfu_f32.sv, whose
# sources come with the co-processor's.
CFU_WRAPPER = Path(__file__).resolve().parents[1] / "hdl" / "gridrt_cfu_litex.sv"


class GridrtSoC(SoCCore):
    """VexRiscv + ROM/SRAM/main RAM + UART + timer + the gridrt co-processor.

    ``uart_phy``: the target's UART PHY (``RS232PHY`` on a board, ``RS232PHYModel`` in the
    simulation). ``rom_words``: the ROM image as little-endian 32-bit words (the bootloader),
    padded to ``ROM_SIZE``; empty for an uninitialised ROM (e.g. to export csr.json only).
    ``rtl_dir``: the co-processor's SystemVerilog (rtl/hdl). ``coproc_pes``: the
    co-processor's processing elements. ``simulation``: a Verilator build (the co-processor's
    pipe then stops when empty, ``GridrtCoproc``). ``float_hw``: a key of ``CPU_VARIANTS``.
    ``sdram_phy``: the target's PHY of the SDRAM chip (``GENSDRPHY`` on the board,
    ``SDRAMPHYModel`` in simulation). ``l2_size``: bytes of the L2 cache in front of it.
    ``harts``: CPUs, the first included (``harts.GridrtHarts``: the others are workers of
    the same variant, each with its own port on the co-processor, ``coproc1..3``).
    ``pe_cache_lines``: 0 for PE memories in block RAM; N for PE images in the SDRAM's upper
    half behind caches of N lines (module docstring).
    """

    # Fixed CSR locations: the map must not depend on the order modules are added in.
    csr_map = {
        "ctrl": 0,
        "identifier_mem": 1,
        "uart": 2,
        "timer0": 3,
        "coproc": 4,
        "sdram": 5,
        "harts": 6,
        "coproc1": 7,
        "coproc2": 8,
        "coproc3": 9,
    }

    def __init__(
        self,
        platform,
        uart_phy,
        rtl_dir,
        rom_words=(),
        ident="gridrt SoC",
        coproc_pes=COPROC_PES,
        simulation=False,
        float_hw=DEFAULT_FLOAT_HW,
        *,
        sdram_phy,
        l2_size=SDRAM_L2_SIZE,
        harts=1,
        pe_cache_lines=DEFAULT_PE_CACHE_LINES,
    ):
        if pe_cache_lines and coproc_pes * COPROC_PE_IMAGE_WORDS * 4 > PE_IMAGES_SIZE:
            raise ValueError(f"{coproc_pes} PEs × {COPROC_PE_IMAGE_WORDS} words exceed the SDRAM's {PE_IMAGES_SIZE} bytes for PE images")
        if float_hw not in CPU_VARIANTS:
            raise ValueError(f"float_hw {float_hw!r}: expected one of {', '.join(CPU_VARIANTS)}")
        if l2_size < 1 * KIB or l2_size & (l2_size - 1):
            raise ValueError(f"l2_size {l2_size}: expected a power of two of at least 1 KiB")
        rom_words = list(rom_words)
        if len(rom_words) * 4 > ROM_SIZE:
            raise ValueError(f"ROM image of {len(rom_words) * 4} bytes exceeds the {ROM_SIZE}-byte ROM")
        if rom_words:
            rom_words += [0] * (ROM_SIZE // 4 - len(rom_words))
        SoCCore.__init__(
            self,
            platform,
            SYS_CLK_FREQ,
            cpu_type="vexriscv",
            cpu_variant=CPU_VARIANTS[float_hw],
            cpu_cfu=str(CFU_WRAPPER) if float_hw == "cfu" else None,
            integrated_rom_size=ROM_SIZE,
            integrated_rom_init=rom_words,
            integrated_sram_size=SRAM_SIZE,
            integrated_main_ram_size=0,
            with_uart=False,
            with_timer=True,
            ident=ident,
            ident_version=False,
            bus_interconnect="crossbar" if harts > 1 else "shared",
        )

        # Main RAM in SDRAM (the PHY joins the SoC's module tree here).
        self.sdrphy = sdram_phy
        self.add_sdram(
            "sdram",
            phy=sdram_phy,
            module=sdram_module(SYS_CLK_FREQ),
            size=MAIN_RAM_SIZE,
            l2_cache_size=l2_size,
        )

        # UART: our own instance (not add_uart) for deeper FIFOs and pop-on-read.
        self.uart_phy = uart_phy
        self.uart = UART(uart_phy, tx_fifo_depth=UART_FIFO_DEPTH, rx_fifo_depth=UART_FIFO_DEPTH, rx_fifo_rx_we=True)
        self.add_constant("GRIDRT_UART_FIFO_DEPTH", UART_FIFO_DEPTH)

        # Worker harts and their registers, and each worker's port on the co-processor
        # (coproc1..3; all present with one hart too: one memory map).
        self.harts = GridrtHarts(
            platform, CPU_VARIANTS[float_hw], harts, cfu=str(CFU_WRAPPER) if float_hw == "cfu" else None
        )
        if harts > 1:
            # The first hart's own RAM, as each worker's: its data bus (LiteX's master
            # `cpu_bus1`, VexRiscv's `periph_buses` being [ibus, dbus]) goes through the RAM's
            # decoder; the SoC's bus sees the decoder's other side.
            self.hart0_ram = HartPrivateRam(self.bus.masters["cpu_bus1"])
            self.bus.masters["cpu_bus1"] = self.hart0_ram.bus
        self.add_constant("GRIDRT_HART_RAM_BASE", HART_RAM_BASE)
        self.add_constant("GRIDRT_HART_RAM_SIZE", HART_RAM_SIZE)
        for k, (ibus, dbus) in enumerate(zip(self.harts.ibuses, self.harts.dbuses), start=1):
            self.bus.add_master(name=f"hart{k}_ibus", master=ibus)
            self.bus.add_master(name=f"hart{k}_dbus", master=dbus)
        ports = []
        for k in range(1, MAX_HARTS):
            port = CoprocPort(fifo_depth=COPROC_FIFO_DEPTH)
            setattr(self, f"coproc{k}", port)
            ports.append(port)

        # The co-processor behind CSR FIFOs.
        self.coproc = GridrtCoprocCSR(
            platform,
            rtl_dir,
            pes=coproc_pes,
            pe_mem_words=COPROC_PE_IMAGE_WORDS if pe_cache_lines else COPROC_PE_MEM_WORDS,
            max_list=COPROC_MAX_LIST,
            fifo_depth=COPROC_FIFO_DEPTH,
            stop_when_empty=simulation,
            ports=ports[: harts - 1],
            pe_cache_lines=pe_cache_lines,
            mem_word_base=PE_IMAGES_OFFSET // 4,
            # The one FPGA this SoC builds for is the ECP5 (ulx3s.py).
            en_ecp5_global=not simulation,
        )
        if pe_cache_lines:
            # The PE images' own LiteDRAM port (word addresses from the SDRAM's start), beside
            # the L2's: the CPUs' caches do not see them.
            self.coproc_mem = LiteDRAMWishbone2Native(
                wishbone=self.coproc.core.mem_bus, port=self.sdram.crossbar.get_port(), base_address=0
            )
        self.add_constant("GRIDRT_COPROC_FIFO_DEPTH", COPROC_FIFO_DEPTH)
