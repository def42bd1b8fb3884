"""Worker harts: more VexRiscv CPUs beside the SoC's own, sharing its buses and its
co-processor (each through its own ``CoprocPort``), and the CSRs the harts coordinate with.

The first hart (LiteX's CPU) boots from ROM and runs the firmware. The workers are held in
reset until that firmware writes ``entry`` and sets ``run``; worker k (1, 2, …) then starts
at ``entry + 8·(k − 1)``, in code the first hart loaded into main RAM (a table of 8-byte
stubs, one per worker, so that each knows its number). The CPUs' data caches are
write-through and not coherent with each other: a hart invalidates its data cache
(VexRiscv's ``0x500F``) before it reads what another hart wrote, and the harts signal each
other through the registers below, which are uncached.

=============  ======  ==========================================================================
register       access  meaning
=============  ======  ==========================================================================
``count``      R       harts of this build, the first included (1: no worker)
``entry``      RW      the first worker's reset vector (worker k: ``entry + 8·(k − 1)``)
``run``        RW      bit 0: the workers run (0, the reset value, holds them in reset)
``job``        RW      written by the first hart: the frame the workers are asked to trace
``ticket``     RW      a read returns the counter and adds 1 to it (rows are claimed so, one
                       bus access each, so no two harts get the same); a write sets it
``sent``       RW      written by the first hart: the rows of the frame it has sent
``ready``      R       bit s: row slot s holds a traced row not yet sent
``ready_set``  W       sets the bits written as 1 in ``ready``
``ready_clr``  W       clears the bits written as 1 in ``ready``
``done1..3``   RW      written by worker k only: its state (``done{k}``)
=============  ======  ==========================================================================

What the words mean is the firmware's (``gridrt_firmware::bsp::harts``); the gateware only
stores them. The memory map is the same for every build: the registers exist with one hart,
``count`` says 1.

Each worker also has, for itself alone: an instruction cache (``icache.py``) in front of its
instruction bus, and 32 KiB of block RAM at ``HART_RAM_BASE`` for its stack
(``HartPrivateRam``), which a decoder on its data bus reaches without the shared bus (its
stores, write-through, stay off it). With workers, the first hart has such a RAM too (the
SoC adds it, ``soc.py``): its firmware traces its rows on a stack there.
"""

from migen import If, Signal

from litex.gen import LiteXModule
from litex.soc.cores.cpu.vexriscv import VexRiscv
from litex.soc.interconnect import wishbone
from litex.soc.interconnect.csr import CSR, CSRStatus, CSRStorage

from .icache import HartInstructionCache

# Harts a build may have; the map has registers (and co-processor ports) for all of them.
MAX_HARTS = 4
# Bytes between two workers' entry stubs.
ENTRY_STRIDE = 8
# Row slots the `ready` bitmap tracks.
SLOTS = 16
# Bytes of each worker's private instruction cache (``icache.HartInstructionCache``; 0: none).
WORKER_ICACHE_SIZE = 8 * 1024
# Each worker's private RAM, its stack: the same addresses for every worker, outside the SoC's
# memory map (only the worker's own data bus reaches it). The firmware's worker needs about
# 25 KiB of stack (its row tracer holds the request buffer and the origin's plane table).
HART_RAM_BASE = 0x2000_0000
HART_RAM_SIZE = 32 * 1024


class HartPrivateRam(LiteXModule):
    """``HART_RAM_SIZE`` bytes of block RAM at ``HART_RAM_BASE`` for one hart alone: a decoder
    on the hart's data bus ``dbus`` answers the accesses to that window from the RAM (one
    cycle, no other master) and passes the rest to ``bus``, the master side the SoC adds to
    its bus in place of ``dbus``."""

    def __init__(self, dbus):
        self.ram = ram = wishbone.SRAM(HART_RAM_SIZE)
        self.bus = bus = wishbone.Interface(data_width=32, address_width=32, addressing="word")

        # # #

        low = (HART_RAM_SIZE // 4 - 1).bit_length()
        window = HART_RAM_BASE // 4 >> low
        slaves = [(lambda a: a[low:] == window, ram.bus), (lambda a: a[low:] != window, bus)]
        self.decoder = wishbone.Decoder(dbus, slaves)


class GridrtHarts(LiteXModule):
    """``harts - 1`` worker CPUs of ``variant`` (with the CFU of ``cfu``, a path, when not
    None) and the registers of the module docstring. ``cpus``: the workers; ``ibuses`` and
    ``dbuses``: their buses, which the SoC adds as bus masters (an instruction bus through
    the worker's own ``icache_size``-byte instruction cache, ``icache.HartInstructionCache``,
    unless that is 0; a data bus past the worker's private RAM at ``HART_RAM_BASE``)."""

    def __init__(self, platform, variant, harts=1, cfu=None, icache_size=WORKER_ICACHE_SIZE):
        if not 1 <= harts <= MAX_HARTS:
            raise ValueError(f"harts {harts}: expected 1 to {MAX_HARTS}")
        self.count = CSRStatus(8, reset=harts, description="Harts of this build, the first included.")
        self.entry = CSRStorage(32, description="The first worker's reset vector; worker k starts 8·(k − 1) bytes later.")
        self.run = CSRStorage(1, description="The workers run while 1; 0 holds them in reset.")
        self.job = CSRStorage(32, description="Written by the first hart: the workers' job.")
        self._ticket = CSR(16, name="ticket")
        self.sent = CSRStorage(16, description="Written by the first hart: rows of the frame it has sent.")
        self.ready = CSRStatus(SLOTS, description="Bit s: row slot s holds a traced row not yet sent.")
        self._ready_set = CSR(SLOTS, name="ready_set")
        self._ready_clr = CSR(SLOTS, name="ready_clr")
        for k in range(1, MAX_HARTS):
            setattr(self, f"done{k}", CSRStorage(32, name=f"done{k}", description=f"Written by worker {k}: its state."))

        # # #

        # The ticket counter: a read (`we`: the CSR was read) takes a number, a write sets it.
        ticket = Signal(16)
        self.comb += self._ticket.w.eq(ticket)
        self.sync += If(self._ticket.re, ticket.eq(self._ticket.r)).Elif(self._ticket.we, ticket.eq(ticket + 1))
        # The ready bitmap (one CSR access per cycle: a set and a clear never coincide).
        ready = Signal(SLOTS)
        self.comb += self.ready.status.eq(ready)
        self.sync += [
            If(self._ready_set.re, ready.eq(ready | self._ready_set.r)),
            If(self._ready_clr.re, ready.eq(ready & ~self._ready_clr.r)),
        ]

        self.cpus, self.ibuses, self.dbuses = [], [], []
        for k in range(1, harts):
            cpu = VexRiscv(platform, variant)
            cpu.set_reset_address(0)
            entry = Signal(32)
            self.comb += [entry.eq(self.entry.storage + ENTRY_STRIDE * (k - 1)), cpu.reset.eq(~self.run.storage)]
            cpu.cpu_params.update(i_externalResetVector=entry)
            if cfu is not None:
                cpu.add_cfu(cfu)
            setattr(self, f"cpu{k}", cpu)
            self.cpus.append(cpu)
            ram = HartPrivateRam(cpu.dbus)
            setattr(self, f"ram{k}", ram)
            self.dbuses.append(ram.bus)
            if icache_size:
                icache = HartInstructionCache(icache_size)
                # Cleared while the worker is held in reset: each run fetches the code anew.
                self.comb += [cpu.ibus.connect(icache.cpu), icache.flush.eq(cpu.reset)]
                setattr(self, f"icache{k}", icache)
                self.ibuses.append(icache.bus)
            else:
                self.ibuses.append(cpu.ibus)
