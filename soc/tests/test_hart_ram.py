"""``HartPrivateRam`` in Migen's simulator: the window at ``HART_RAM_BASE`` is answered by the
hart's own RAM, everything else goes on to the bus behind it.

Run with the SoC's Python (``scripts/setup-soc.sh``):
``.toolchain/soc-venv/bin/python -m unittest discover -s soc/tests``.
"""

import sys
import unittest
from pathlib import Path

from migen import Module, run_simulation
from migen.sim import passive

from litex.soc.interconnect import wishbone

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from gridrt_soc.harts import HART_RAM_BASE, HART_RAM_SIZE, HartPrivateRam  # noqa: E402

# Words of the memory on the shared side (its low address bits only: every address maps).
SHARED_WORDS = 64
# Cycles an access may take, with room to spare.
ACCESS_CYCLES = 16


class Bench(Module):
    def __init__(self):
        self.dbus = wishbone.Interface(data_width=32, address_width=32, addressing="word")
        self.submodules.private = HartPrivateRam(self.dbus)
        self.submodules.shared = wishbone.SRAM(SHARED_WORDS * 4, init=[0xA000_0000 + w for w in range(SHARED_WORDS)])
        self.comb += self.private.bus.connect(self.shared.bus)


def access(bench, byte_address, value=None):
    """One Wishbone access of the hart's data bus (a write when ``value`` is given); returns
    the word read. Fails the test if it is not answered within ``ACCESS_CYCLES``."""
    bus = bench.dbus
    yield bus.adr.eq(byte_address // 4)
    yield bus.we.eq(value is not None)
    yield bus.dat_w.eq(value or 0)
    yield bus.sel.eq(0xF)
    yield bus.cyc.eq(1)
    yield bus.stb.eq(1)
    yield
    for _ in range(ACCESS_CYCLES):
        if (yield bus.ack):
            break
        yield
    else:
        raise AssertionError(f"the access to {byte_address:#x} was not answered within {ACCESS_CYCLES} cycles")
    word = yield bus.dat_r
    yield bus.cyc.eq(0)
    yield bus.stb.eq(0)
    yield
    return word


def run(program):
    """Runs ``program(bench, log)``; returns the log: what it recorded and the shared side's
    acknowledged cycles."""
    bench = Bench()
    log = {"shared_acks": 0}

    @passive
    def monitor():
        while True:
            bus = bench.private.bus
            if (yield bus.cyc) and (yield bus.stb) and (yield bus.ack):
                log["shared_acks"] += 1
            yield

    run_simulation(bench, [program(bench, log), monitor()])
    return log


class HartPrivateRamTest(unittest.TestCase):
    def test_the_window_is_the_harts_own_ram_and_never_reaches_the_bus(self):
        top = HART_RAM_BASE + HART_RAM_SIZE - 4

        def program(bench, log):
            yield from access(bench, HART_RAM_BASE, 0x1234_5678)
            yield from access(bench, top, 0x9ABC_DEF0)
            log["base"] = yield from access(bench, HART_RAM_BASE)
            log["top"] = yield from access(bench, top)

        log = run(program)
        self.assertEqual((log["base"], log["top"]), (0x1234_5678, 0x9ABC_DEF0))
        self.assertEqual(log["shared_acks"], 0)

    def test_addresses_outside_the_window_go_to_the_bus(self):
        below, above = HART_RAM_BASE - 4, HART_RAM_BASE + HART_RAM_SIZE

        def program(bench, log):
            log["main"] = yield from access(bench, 0x4000_0008)
            log["below"] = yield from access(bench, below)
            log["above"] = yield from access(bench, above)
            # A write outside the window lands on the shared side, not in the private RAM.
            yield from access(bench, above, 0x5555_AAAA)
            log["above_again"] = yield from access(bench, above)
            log["base"] = yield from access(bench, HART_RAM_BASE)

        log = run(program)
        word = lambda byte_address: 0xA000_0000 + byte_address // 4 % SHARED_WORDS
        self.assertEqual(log["main"], word(0x4000_0008))
        self.assertEqual(log["below"], word(below))
        self.assertEqual(log["above"], word(above))
        self.assertEqual(log["above_again"], 0x5555_AAAA)
        self.assertNotEqual(log["base"], 0x5555_AAAA)
        self.assertEqual(log["shared_acks"], 5)


if __name__ == "__main__":
    unittest.main()
