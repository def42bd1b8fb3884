"""``HartInstructionCache`` in Migen's simulator against a plain memory behind it.

Run with the SoC's Python (``scripts/setup-soc.sh``):
``.toolchain/soc-venv/bin/python -m unittest discover -s soc/tests``.
"""

import random
import sys
import unittest
from pathlib import Path

from migen import Module, run_simulation
from migen.sim import passive

from litex.soc.interconnect import wishbone

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from gridrt_soc.icache import LINE_WORDS, HartInstructionCache  # noqa: E402

# Words of the memory behind the cache: 8 times the cache, so lines alias.
CACHE_BYTES = 256
MEMORY_WORDS = 8 * CACHE_BYTES // 4


class Bench(Module):
    def __init__(self, words):
        self.submodules.cache = HartInstructionCache(CACHE_BYTES)
        self.submodules.memory = wishbone.SRAM(len(words) * 4, init=words)
        self.comb += self.cache.bus.connect(self.memory.bus)


def run(words, program):
    """Runs ``program(bench, log)`` and returns the log: its reads and the memory's bus cycles."""
    bench = Bench(words)
    log = {"reads": [], "bus_acks": 0}

    @passive
    def monitor():
        while True:
            if (yield bench.cache.bus.cyc) and (yield bench.cache.bus.stb) and (yield bench.cache.bus.ack):
                log["bus_acks"] += 1
            yield

    def master():
        yield from program(bench, log)

    run_simulation(bench, [master(), monitor()])
    return log


# Cycles a read may take: a line's refill and the lookups around it, with room to spare.
READ_CYCLES = 64


def read(bench, log, adr):
    """A Wishbone read of ``adr`` through the cache; fails the test if it is not answered
    within ``READ_CYCLES``."""
    cpu = bench.cache.cpu
    yield cpu.adr.eq(adr)
    yield cpu.we.eq(0)
    yield cpu.cyc.eq(1)
    yield cpu.stb.eq(1)
    yield
    for _ in range(READ_CYCLES):
        if (yield cpu.ack):
            break
        yield
    else:
        raise AssertionError(f"the read of word {adr:#x} was not answered within {READ_CYCLES} cycles")
    value = yield cpu.dat_r
    yield cpu.cyc.eq(0)
    yield cpu.stb.eq(0)
    yield
    log["reads"].append((adr, value))
    return value


class HartInstructionCacheTest(unittest.TestCase):
    def setUp(self):
        rng = random.Random(7)
        self.words = [rng.getrandbits(32) for _ in range(MEMORY_WORDS)]

    def test_every_read_answers_the_memory_word_at_its_address(self):
        rng = random.Random(11)
        addresses = [rng.randrange(MEMORY_WORDS) for _ in range(400)]

        def program(bench, log):
            # Wait out the clearing after reset.
            for _ in range(CACHE_BYTES // 32 + 2):
                yield
            for adr in addresses:
                yield from read(bench, log, adr)

        log = run(self.words, program)
        self.assertEqual(log["reads"], [(a, self.words[a]) for a in addresses])

    def test_a_line_is_read_from_the_bus_once_until_another_line_takes_its_place(self):
        def program(bench, log):
            for adr in range(LINE_WORDS):  # one line, word by word
                yield from read(bench, log, adr)
            for adr in range(LINE_WORDS):  # again: all hits
                yield from read(bench, log, adr)
            yield from read(bench, log, CACHE_BYTES // 4)  # the same index, another tag
            yield from read(bench, log, 0)  # evicted: read again

        log = run(self.words, program)
        self.assertEqual(log["bus_acks"], 3 * LINE_WORDS)
        self.assertEqual([v for _, v in log["reads"]][: 2 * LINE_WORDS], self.words[:LINE_WORDS] * 2)

    def test_flush_drops_every_line_so_new_code_is_fetched(self):
        def program(bench, log):
            yield from read(bench, log, 3)
            # New code in memory (the bootloader flashing another app), the worker in reset.
            yield bench.memory.mem[3].eq(0x1234_5678)
            yield bench.cache.flush.eq(1)
            for _ in range(4):
                yield
            yield bench.cache.flush.eq(0)
            yield from read(bench, log, 3)

        log = run(self.words, program)
        self.assertEqual(log["reads"], [(3, self.words[3]), (3, 0x1234_5678)])
        self.assertEqual(log["bus_acks"], 2 * LINE_WORDS)


if __name__ == "__main__":
    unittest.main()
