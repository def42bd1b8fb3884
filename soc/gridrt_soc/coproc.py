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

from migen import Case, ClockSignal, If, Instance, Mux, ResetInserter, ResetSignal, Signal

from litex.gen import LiteXModule
from litex.soc.interconnect import stream, wishbone
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

    Parameters are the RTL's: ``pes`` processing elements, ``pe_mem_words`` words of memory
    per PE (block RAM, or with ``pe_cache_lines`` > 0 an external memory on ``mem_bus``, a
    Wishbone master, read through a cache of that many 8-word lines per PE: rtl/README.md
    §4.6; ``mem_word_base`` is the images' first word on that bus; ``en_ecp5_global``: the
    caches' clock enable on an ECP5 global network, for the FPGA build), ``max_list`` longest traversal list, ``stop_when_empty`` the intersection
    pipe's data registers stop while no test is in flight (True for the Verilator target, whose
    time they are; False on an FPGA, where a clock enable on each of them does not route;
    rtl/README.md §3.4). ``reset`` (in) resets the core
    synchronously, with the system reset. ``rtl_dir`` None adds no sources (enough to export
    the memory map).
    """

    def __init__(
        self, platform, rtl_dir, pes=4, pe_mem_words=8192, max_list=256, stop_when_empty=False, pe_cache_lines=0,
        mem_word_base=0, en_ecp5_global=False,
    ):
        self.sink = stream.Endpoint(WORD_LAYOUT)
        self.source = stream.Endpoint(WORD_LAYOUT)
        self.idle = Signal()
        self.reset = Signal()

        self.pes = pes
        self.pe_mem_words = pe_mem_words
        self.max_list = max_list
        # With PE caches: the PE images' memory, PE p's word w at word mem_word_base +
        # p·pe_mem_words + w of this bus (rtl/README.md §4.6).
        self.mem_bus = wishbone.Interface(data_width=32, adr_width=30, addressing="word") if pe_cache_lines else None

        # # #

        if pe_cache_lines:
            mem_req, mem_we = Signal(), Signal()
            mem_addr = Signal(32)
            mem_ports = dict(
                o_mem_req_o=mem_req,
                o_mem_we_o=mem_we,
                o_mem_addr_o=mem_addr,
                o_mem_wdata_o=self.mem_bus.dat_w,
                i_mem_ack_i=self.mem_bus.ack,
                i_mem_rdata_i=self.mem_bus.dat_r,
            )
            self.comb += [
                self.mem_bus.cyc.eq(mem_req),
                self.mem_bus.stb.eq(mem_req),
                self.mem_bus.we.eq(mem_we),
                self.mem_bus.sel.eq(0b1111),
                self.mem_bus.adr.eq(mem_word_base + mem_addr),
            ]
        else:
            # PE memories in block RAM: the external memory port is unused.
            mem_ports = dict(i_mem_ack_i=0, i_mem_rdata_i=0)
        self.specials += Instance(
            "gridrt_coproc",
            p_PES=pes,
            p_PE_MEM_WORDS=pe_mem_words,
            p_MAX_LIST=max_list,
            p_STOP_WHEN_EMPTY=int(stop_when_empty),
            p_PE_CACHE=int(bool(pe_cache_lines)),
            p_CACHE_LINES=pe_cache_lines or 512,
            p_EN_ECP5_GLOBAL=int(en_ecp5_global),  # the RTL uses it only with PE_CACHE
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
            **mem_ports,
        )
        if rtl_dir is not None:
            for f in hdl_sources(rtl_dir):
                platform.add_source(str(f), language="systemverilog")


class CoprocPort(LiteXModule):
    """One more hart's window on the co-processor: a request FIFO and a reply FIFO behind the
    CSRs ``req``, ``req_last``, ``rsp`` and ``status`` (the first four of
    ``GridrtCoprocCSR``'s, at the same offsets, with the same meaning; the ``idle`` bit is the
    co-processor's). It has no ``ctrl``: only the first hart resets the co-processor.
    ``GridrtCoprocCSR`` arbitrates between its own FIFOs and these, one packet at a time.
    """

    def __init__(self, fifo_depth=16):
        assert fifo_depth & (fifo_depth - 1) == 0 and 2 <= fifo_depth <= 128
        _fifo_regs(self)
        self.reset = Signal()
        self.idle = Signal()

        # # #

        self.req_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        self.rsp_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        self.comb += [self.req_fifo.reset.eq(self.reset), self.rsp_fifo.reset.eq(self.reset)]
        _fifo_csrs(self, fifo_depth, self.reset, self.idle)


def _fifo_regs(m):
    """Gives ``m`` a port's four FIFO registers, in their order: ``req``, ``req_last``, ``rsp``,
    ``status`` (module docstring)."""
    m._req = CSR(32, name="req")
    m._req_last = CSR(32, name="req_last")
    m._rsp = CSR(32, name="rsp")
    m._status = _status_csr()


def _status_csr():
    return CSRStatus(
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


def _fifo_csrs(m, fifo_depth, clear, idle):
    """Connects ``m``'s ``_req``/``_req_last``/``_rsp``/``_status`` CSRs to its FIFOs."""
    req_fifo, rsp_fifo = m.req_fifo, m.rsp_fifo
    # CPU -> request FIFO: a write to `req` or `req_last` pushes one word.
    m.comb += [
        req_fifo.sink.valid.eq(m._req.re | m._req_last.re),
        req_fifo.sink.data.eq(m._req.r | m._req_last.r),
        req_fifo.sink.last.eq(m._req_last.re),
    ]
    # Reply FIFO -> CPU: `rsp` shows the head word; its read strobe pops it.
    m.comb += [
        m._rsp.w.eq(Mux(rsp_fifo.source.valid, rsp_fifo.source.data, 0)),
        rsp_fifo.source.ready.eq(m._rsp.we),
    ]
    overflow = Signal()
    underflow = Signal()
    m.sync += [
        If(clear,
            overflow.eq(0),
            underflow.eq(0),
        ).Else(
            If(req_fifo.sink.valid & ~req_fifo.sink.ready, overflow.eq(1)),
            If(m._rsp.we & ~rsp_fifo.source.valid, underflow.eq(1)),
        )
    ]
    m.comb += [
        m._status.fields.req_space.eq(fifo_depth - req_fifo.level),
        m._status.fields.rsp_level.eq(rsp_fifo.level),
        m._status.fields.rsp_last.eq(rsp_fifo.source.valid & rsp_fifo.source.last),
        m._status.fields.idle.eq(idle),
        m._status.fields.req_overflow.eq(overflow),
        m._status.fields.rsp_underflow.eq(underflow),
    ]


class PacketArbiter(LiteXModule):
    """Shares the co-processor's two streams between ``n`` ports, one request packet and its
    reply packet at a time.

    A port is granted when it offers a word and no packet is in flight; it keeps the grant
    until its request packet's last word went in *and* the reply packet's last word came out
    (an ERROR may come before the request's end: the co-processor then drops the rest of the
    packet, SPEC.md §4.5, and no other port's words may reach it meanwhile). The next grant
    goes to the first port with a word after the one last served (round robin). Every request
    packet has exactly one reply packet (SPEC.md §4.1), so the replies reach the hart that
    asked. ``sinks``: each port's request stream; ``sources``: each port's reply stream.
    """

    def __init__(self, n, core_sink, core_source):
        self.sinks = [stream.Endpoint(WORD_LAYOUT) for _ in range(n)]
        self.sources = [stream.Endpoint(WORD_LAYOUT) for _ in range(n)]
        self.busy = busy = Signal()
        self.grant = grant = Signal(max=max(n, 2))

        # # #

        req_done = Signal()
        rsp_done = Signal()
        for i in range(n):
            sink, source = self.sinks[i], self.sources[i]
            mine = busy & (grant == i)
            self.comb += [
                If(mine & ~req_done,
                    core_sink.valid.eq(sink.valid),
                    core_sink.data.eq(sink.data),
                    core_sink.last.eq(sink.last),
                    sink.ready.eq(core_sink.ready),
                ),
                If(mine & ~rsp_done,
                    source.valid.eq(core_source.valid),
                    source.data.eq(core_source.data),
                    source.last.eq(core_source.last),
                    core_source.ready.eq(source.ready),
                ),
            ]
        # The next grant: the first port with a word after the last one served.
        pick = Signal(max=max(n, 2))
        offer = Signal()
        order = [[(g + 1 + k) % n for k in range(n)] for g in range(n)]
        cases = {}
        for g in range(n):
            chain = None
            for i in reversed(order[g]):
                step = If(self.sinks[i].valid, pick.eq(i), offer.eq(1))
                chain = step if chain is None else step.Else(chain)
            cases[g] = chain
        self.comb += Case(grant, cases)
        req_end = core_sink.valid & core_sink.ready & core_sink.last
        rsp_end = core_source.valid & core_source.ready & core_source.last
        self.sync += [
            If(~busy,
                If(offer,
                    busy.eq(1),
                    grant.eq(pick),
                    req_done.eq(0),
                    rsp_done.eq(0),
                ),
            ).Else(
                If(req_end, req_done.eq(1)),
                If(rsp_end, rsp_done.eq(1)),
                If((req_done | req_end) & (rsp_done | rsp_end), busy.eq(0)),
            )
        ]


class GridrtCoprocCSR(LiteXModule):
    """The co-processor behind CSR FIFOs (module docstring: the register interface).

    ``fifo_depth`` words per direction (a power of two, at most 128 so that the levels fit
    their status fields). ``stop_when_empty``: ``GridrtCoproc``'s. ``ports``: more harts'
    ``CoprocPort``s; a ``PacketArbiter`` shares the co-processor between them and this
    block's own FIFOs, whose ``ctrl`` resets everything. ``pe_cache_lines``, ``mem_word_base``,
    ``en_ecp5_global``: ``GridrtCoproc``'s.
    """

    def __init__(
        self,
        platform,
        rtl_dir,
        pes=4,
        pe_mem_words=8192,
        max_list=256,
        fifo_depth=16,
        stop_when_empty=False,
        ports=(),
        pe_cache_lines=0,
        mem_word_base=0,
        en_ecp5_global=False,
    ):
        assert fifo_depth & (fifo_depth - 1) == 0 and 2 <= fifo_depth <= 128
        self.fifo_depth = fifo_depth

        _fifo_regs(self)
        self._ctrl = CSRStorage(
            fields=[
                CSRField(
                    "reset",
                    size=1,
                    pulse=True,
                    description="Reset the co-processor, the arbiter and every port's FIFOs; clear the sticky bits.",
                ),
            ],
            name="ctrl",
        )

        self._pes = CSRStatus(8, reset=pes, name="pes", description="Processing elements.")
        self._pe_mem_words = CSRStatus(32, reset=pe_mem_words, name="pe_mem_words", description="Words per PE memory.")

        # # #

        soft_reset = self._ctrl.fields.reset
        self.core = core = GridrtCoproc(
            platform, rtl_dir, pes, pe_mem_words, max_list, stop_when_empty, pe_cache_lines, mem_word_base, en_ecp5_global
        )
        self.req_fifo = req_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        self.rsp_fifo = rsp_fifo = ResetInserter()(stream.SyncFIFO(WORD_LAYOUT, fifo_depth))
        all_ports = [self, *ports]
        self.arbiter = arbiter = ResetInserter()(PacketArbiter(len(all_ports), core.sink, core.source))
        idle = Signal()
        self.comb += [
            core.reset.eq(soft_reset),
            arbiter.reset.eq(soft_reset),
            req_fifo.reset.eq(soft_reset),
            rsp_fifo.reset.eq(soft_reset),
            idle.eq(core.idle & ~arbiter.busy),
        ]
        for port, sink, source in zip(all_ports, arbiter.sinks, arbiter.sources):
            self.comb += [port.req_fifo.source.connect(sink), source.connect(port.rsp_fifo.sink)]
        for port in ports:
            self.comb += [port.reset.eq(soft_reset), port.idle.eq(idle)]
        _fifo_csrs(self, fifo_depth, soft_reset, idle)
