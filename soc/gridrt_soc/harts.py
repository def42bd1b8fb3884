"""Worker harts: more VexRiscv CPUs beside the SoC's own, sharing its buses and its
co-processor (each through its own ``CoprocPort``), and the CSRs the harts coordinate with.

The first hart (LiteX's CPU) boots from ROM and runs the firmware. A worker is held in reset
until that firmware writes its entry point into ``entry`` and sets ``run``; it then starts
at ``entry`` in main RAM, in code the first hart loaded. The CPUs' data caches are
write-through and not coherent with each other: a hart invalidates its data cache (VexRiscv's
``0x500F``) before it reads what another hart wrote, and the harts signal each other through
the registers below, which are uncached.

============  ======  ===========================================================================
register      access  meaning
============  ======  ===========================================================================
``count``     R       harts of this build, the first included (1: no worker)
``entry``     RW      the workers' reset vector
``run``       RW      bit 0: the workers run (0, the reset value, holds them in reset)
``job``       RW      written by the first hart only: the frame the worker is asked to trace
``taken``     RW      written by the first hart only: the worker's rows it has sent
``done``      RW      written by the worker only: what it has traced of the frame
============  ======  ===========================================================================

What the last three words mean is the firmware's (``gridrt_firmware::harts``); the gateware
only stores them. The memory map is the same for every build: the registers exist with one
hart, ``count`` says 1.
"""

from migen import Signal

from litex.gen import LiteXModule
from litex.soc.cores.cpu.vexriscv import VexRiscv
from litex.soc.interconnect.csr import CSRStatus, CSRStorage

# Harts a build may have (the registers above serve one worker).
MAX_HARTS = 2


class GridrtHarts(LiteXModule):
    """``harts - 1`` worker CPUs of ``variant`` (with the CFU of ``cfu``, a path, when not
    None) and the registers of the module docstring. ``cpus``: the workers, whose ``ibus``
    and ``dbus`` the SoC adds as bus masters."""

    def __init__(self, platform, variant, harts=1, cfu=None):
        if not 1 <= harts <= MAX_HARTS:
            raise ValueError(f"harts {harts}: expected 1 to {MAX_HARTS}")
        self.count = CSRStatus(8, reset=harts, description="Harts of this build, the first included.")
        self.entry = CSRStorage(32, description="The workers' reset vector.")
        self.run = CSRStorage(1, description="The workers run while 1; 0 holds them in reset.")
        self.job = CSRStorage(32, description="Written by the first hart: the worker's job.")
        self.taken = CSRStorage(32, description="Written by the first hart: the worker's rows it has sent.")
        self.done = CSRStorage(32, description="Written by the worker: its progress.")

        # # #

        self.cpus = []
        for k in range(1, harts):
            cpu = VexRiscv(platform, variant)
            cpu.set_reset_address(0)
            entry = Signal(32)
            self.comb += [entry.eq(self.entry.storage), cpu.reset.eq(~self.run.storage)]
            cpu.cpu_params.update(i_externalResetVector=entry)
            if cfu is not None:
                cpu.add_cfu(cfu)
            setattr(self, f"cpu{k}", cpu)
            self.cpus.append(cpu)
