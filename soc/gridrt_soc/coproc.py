"""The gridrt co-processor in a LiteX SoC.

``GridrtCoproc`` instantiates ``gridrt_coproc`` (rtl/hdl/gridrt_coproc.sv, SPEC.md §4) with
its two word streams as LiteX stream endpoints: ``sink`` carries requests into the
co-processor, ``source`` carries its replies; ``last`` is the FSL control bit (tlast).

``GridrtCoprocCSR`` puts a FIFO on each stream and exposes both to the CPU as CSRs, the
register interface the firmware's ``bsp::litex_coproc`` driver speaks:

============  ======  ===========================================================================
register      access  meaning
============  ======  ===========================================================================
``req``       W       push the written word as a request word, control bit 0
``req_last``  W       push the written word as a request word, control bit 1 (ends a request)
``rsp``       R       the reply word at the head of the reply FIFO; the read pops it
``status``    R       ``req_space`` free request slots, ``rsp_level`` reply words waiting,
                      ``rsp_last`` control bit of the head reply word, ``idle`` (co-processor),
                      ``req_overflow`` / ``rsp_underflow`` (sticky: a push into a full request
                      FIFO was dropped / a read of an empty reply FIFO returned 0)
``ctrl``      W       ``reset``: pulse; resets the co-processor and both FIFOs, clears the
                      sticky bits
``pes``       R       processing elements of this build (the RTL's ``PES``)
``pe_mem_w``  R       words of memory per PE (the RTL's ``PE_MEM_WORDS``; register
                      ``pe_mem_words``)
============  ======  ===========================================================================

The configuration is read at run time, so one firmware image serves every build of the SoC
(the simulation's 4 PEs and a smaller FPGA's 2) and the memory map does not depend on it.

A request word costs the CPU one CSR write (the driver caches ``req_space``); a reply word
one ``status`` read (its control bit) and one ``rsp`` read.
"""

from pathlib import Path

from migen import ClockSignal, If, Instance, Mux, ResetInserter, ResetSignal, Signal

from litex.gen import LiteXModule
from litex.soc.interconnect import stream
from litex.soc.interconnect.csr import CSR, CSRField, CSRStatus, CSRStorage

# The stream of 32-bit FSL words; `last` (every LiteX endpoint has it) is the control bit.
WORD_LAYOUT = [("data", 32)]


def hdl_sources(rtl_dir):
    """The SystemVerilog files of the co-processor RTL, sorted."""
    files = sorted(Path(rtl_dir).glob("*.sv"))
    if not any(f.name == "gridrt_coproc.sv" for f in files):
        raise FileNotFoundError(f"no gridrt_coproc.sv in {rtl_dir} (the co-processor RTL)")
    return files


class GridrtCoproc(LiteXModule):
    """``gridrt_coproc`` with LiteX stream endpoints.

    Parameters are the RTL's: ``pes`` processing elements, ``pe_mem_words`` words of block
    RAM per PE, ``max_list`` longest traversal list, ``stop_when_empty`` the intersection
    pipe's data registers stop while no test is in flight (True for the Verilator target, whose
    time they are; False on an FPGA, where a clock enable on each of them does not route;
    rtl/README.md §3.4). ``reset`` (in) resets the core
    synchronously, with the system reset. ``rtl_dir`` None adds no sources (enough to export
    the memory map).
    """

    def __init__(self, platform, rtl_dir, pes=4, pe_mem_words=8192, max_list=256, stop_when_empty=False):
        self.sink = stream.Endpoint(WORD_LAYOUT)
        self.source = stream.Endpoint(WORD_LAYOUT)
        self.idle = Signal()
        self.reset = Signal()

        self.pes = pes
        self.pe_mem_words = pe_mem_words
        self.max_list = max_list

        # # #

        self.specials += Instance(
            "gridrt_coproc",
            p_PES=pes,
            p_PE_MEM_WORDS=pe_mem_words,
            p_MAX_LIST=max_list,
            p_STOP_WHEN_EMPTY=int(stop_when_empty),
            i_clk_i=ClockSignal("sys"),
            i_rst_i=ResetSignal("sys") | self.reset,
            i_s_axis_tdata_i=self.sink.data,
            i_s_axis_tlast_i=self.sink.last,
            i_s_axis_tvalid_i=self.sink.valid,
            o_s_axis_tready_o=self.sink.ready,
            o_m_axis_tdata_o=self.source.data,
            o_m_axis_tlast_o=self.source.last,
            o_m_axis_tvalid_o=self.source.valid,
            i_m_axis_tready_i=self.source.ready,
            o_idle_o=self.idle,
        )
        if rtl_dir is not None:
            for f in hdl_sources(rtl_dir):
                platform.add_source(str(f), language="systemverilog")


class GridrtCoprocCSR(LiteXModule):
    """The co-processor behind CSR FIFOs (module docstring: the register interface).

    ``fifo_depth`` words per direction (a power of two, at most 128 so that the levels fit
    their status fields). ``stop_when_empty``: ``GridrtCoproc``'s.
    """

    def __init__(
        self, platform, rtl_dir, pes=4, pe_mem_words=8192, max_list=256, fifo_depth=16, stop_when_empty=False
    ):
        assert fifo_depth & (fifo_depth - 1) == 0 and 2 <= fifo_depth <= 128
        self.fifo_depth = fifo_depth

        self._req = CSR(32, name="req")
        self._req_last = CSR(32, name="req_last")
        self._rsp = CSR(32, name="rsp")
        self._status = CSRStatus(
            fields=[
                CSRField("req_space", size=8, description="Free request FIFO slots."),
                CSRField("rsp_level", size=8, description="Reply words waiting."),
                CSRField("rsp_last", size=1, description="Control bit of the head reply word."),
                CSRField("idle", size=1, description="The co-processor waits for input with nothing to send."),
                CSRField("req_overflow", size=1, description="Sticky: a request word was dropped (FIFO full)."),
                CSRField("rsp_underflow", size=1, description="Sticky: ``rsp`` was read with no reply waiting."),
            ],
            name="status",
        )
        self._ctrl = CSRStorage(
            fields=[
                CSRField(
                    "reset", size=1, pulse=True, description="Reset the co-processor and both FIFOs; clear the sticky bits."
                ),
            ],
            name="ctrl",
        )

        self._pes = CSRStatus(8, reset=pes, name="pes", description="Processing elements.")
        self._pe_mem_words = CSRStatus(32, reset=pe_mem_words, name="pe_mem_words", description="Words per PE memory.")

        # # #

        soft_reset = self._ctrl.fields.reset
        self.core = core = GridrtCoproc(platform, rtl_dir, pes, pe_mem_words, max_list, stop_when_empty)
        self.req_fifo = req_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        self.rsp_fifo = rsp_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        self.comb += [
            core.reset.eq(soft_reset),
            req_fifo.reset.eq(soft_reset),
            rsp_fifo.reset.eq(soft_reset),
            req_fifo.source.connect(core.sink),
            core.source.connect(rsp_fifo.sink),
        ]

        # CPU -> request FIFO: a write to `req` or `req_last` pushes one word.
        req_space = Signal(8)
        self.comb += [
            req_space.eq(fifo_depth - req_fifo.level),
            req_fifo.sink.valid.eq(self._req.re | self._req_last.re),
            req_fifo.sink.data.eq(self._req.r | self._req_last.r),
            req_fifo.sink.last.eq(self._req_last.re),
        ]

        # Reply FIFO -> CPU: `rsp` shows the head word; its read strobe pops it.
        self.comb += [
            self._rsp.w.eq(Mux(rsp_fifo.source.valid, rsp_fifo.source.data, 0)),
            rsp_fifo.source.ready.eq(self._rsp.we),
        ]

        overflow = Signal()
        underflow = Signal()
        self.sync += [
            If(soft_reset,
                overflow.eq(0),
                underflow.eq(0),
            ).Else(
                If(req_fifo.sink.valid & ~req_fifo.sink.ready, overflow.eq(1)),
                If(self._rsp.we & ~rsp_fifo.source.valid, underflow.eq(1)),
            )
        ]
        self.comb += [
            self._status.fields.req_space.eq(req_space),
            self._status.fields.rsp_level.eq(rsp_fifo.level),
            self._status.fields.rsp_last.eq(rsp_fifo.source.valid & rsp_fifo.source.last),
            self._status.fields.idle.eq(core.idle),
            self._status.fields.req_overflow.eq(overflow),
            self._status.fields.rsp_underflow.eq(underflow),
        ]
