"""A worker hart's private instruction cache: a read-only, direct-mapped cache between one
VexRiscv's instruction bus and the SoC bus.

Why: every hart's 4 KiB instruction cache misses on the firmware's hot path, and with
several harts those refills queue for the one path into main RAM (the shared bus and the L2
in front of the SDRAM; docs/bench-frame.md, "Harts"). A worker's refills that hit here never
reach the shared bus. (LiteX's ``wishbone.Cache`` is write-back and its tags have no valid
bit to clear, so after a new firmware is flashed it could answer with the old code.)

- Lines of 32 bytes (8 words), as VexRiscv's own; the line a request falls in is read from
  the bus word by word (classic Wishbone cycles), then the request is answered from it.
- A hit answers two cycles after the request (the tag and data memories are read
  synchronously: block RAM).
- Code does not change while a worker runs, so nothing is written back or snooped. Every
  line is invalidated after reset and while ``flush`` is high (the worker held in reset):
  new firmware flashed between two runs is fetched afresh. Requests wait while lines are
  cleared (one per cycle).
- A write request (an instruction bus never makes one) passes through to the bus.
"""

from migen import FSM, Cat, If, Memory, NextState, NextValue, Signal

from litex.gen import LiteXModule
from litex.soc.interconnect import wishbone

# Bytes per line, and words (32-bit) per line.
LINE_BYTES = 32
LINE_WORDS = LINE_BYTES // 4


class HartInstructionCache(LiteXModule):
    """``size`` bytes (a power of two, at least two lines). ``cpu``: the slave side, for the
    hart's instruction bus; ``bus``: the master side, on the SoC bus; ``flush``: input,
    invalidates every line while high."""

    def __init__(self, size):
        lines = size // LINE_BYTES
        if lines < 2 or lines & (lines - 1):
            raise ValueError(f"instruction cache of {size} bytes: expected a power of two of at least {2 * LINE_BYTES}")
        self.cpu = cpu = wishbone.Interface(data_width=32, address_width=32, addressing="word")
        self.bus = bus = wishbone.Interface(data_width=32, address_width=32, addressing="word")
        self.flush = Signal()

        # # #

        offset_bits = (LINE_WORDS - 1).bit_length()
        index_bits = (lines - 1).bit_length()
        tag_bits = len(cpu.adr) - offset_bits - index_bits

        # Tag memory: a line's tag and its valid bit (the top bit).
        tags = Memory(tag_bits + 1, lines)
        data = Memory(32, lines * LINE_WORDS)
        tag_rd, tag_wr = tags.get_port(), tags.get_port(write_capable=True)
        data_rd, data_wr = data.get_port(), data.get_port(write_capable=True)
        self.specials += tags, data, tag_rd, tag_wr, data_rd, data_wr

        word = cpu.adr[:offset_bits]
        index = cpu.adr[offset_bits : offset_bits + index_bits]
        tag = cpu.adr[offset_bits + index_bits :]
        # The memories are read at the request's address every cycle; the answer is there the
        # next (the master holds the address until its acknowledge).
        self.comb += [tag_rd.adr.eq(index), data_rd.adr.eq(Cat(word, index))]
        hit = Signal()
        self.comb += hit.eq(tag_rd.dat_r == Cat(tag, 1))

        refill = Signal(offset_bits)
        clear = Signal(index_bits)

        self.fsm = fsm = FSM(reset_state="CLEAR")
        fsm.act(
            "CLEAR",
            tag_wr.adr.eq(clear),
            tag_wr.dat_w.eq(0),
            tag_wr.we.eq(1),
            NextValue(clear, clear + 1),
            If(~self.flush & (clear == lines - 1), NextState("IDLE")),
            If(self.flush, NextValue(clear, 0)),
        )
        fsm.act(
            "IDLE",
            If(self.flush, NextValue(clear, 0), NextState("CLEAR")).Elif(
                cpu.cyc & cpu.stb, If(cpu.we, NextState("PASS")).Else(NextState("TEST"))
            ),
        )
        fsm.act(
            "TEST",
            If(
                hit,
                cpu.ack.eq(1),
                cpu.dat_r.eq(data_rd.dat_r),
                NextState("IDLE"),
            ).Else(
                NextValue(refill, 0),
                NextState("REFILL"),
            ),
        )
        # The whole line, word 0 first; the tag is written with the last word.
        fsm.act(
            "REFILL",
            bus.cyc.eq(1),
            bus.stb.eq(1),
            bus.adr.eq(Cat(refill, cpu.adr[offset_bits:])),
            bus.sel.eq(0xF),
            If(
                bus.ack,
                data_wr.adr.eq(Cat(refill, index)),
                data_wr.dat_w.eq(bus.dat_r),
                data_wr.we.eq(1),
                NextValue(refill, refill + 1),
                If(
                    refill == LINE_WORDS - 1,
                    tag_wr.adr.eq(index),
                    tag_wr.dat_w.eq(Cat(tag, 1)),
                    tag_wr.we.eq(1),
                    # Back to IDLE: the request, still held, is read again and hits.
                    NextState("IDLE"),
                ),
            ).Elif(
                bus.err,
                cpu.err.eq(1),
                NextState("IDLE"),
            ),
        )
        fsm.act(
            "PASS",
            bus.cyc.eq(cpu.cyc),
            bus.stb.eq(cpu.stb),
            bus.we.eq(cpu.we),
            bus.adr.eq(cpu.adr),
            bus.sel.eq(cpu.sel),
            bus.dat_w.eq(cpu.dat_w),
            bus.cti.eq(cpu.cti),
            bus.bte.eq(cpu.bte),
            cpu.dat_r.eq(bus.dat_r),
            cpu.ack.eq(bus.ack),
            cpu.err.eq(bus.err),
            If(bus.ack | bus.err | ~cpu.cyc, NextState("IDLE")),
        )
