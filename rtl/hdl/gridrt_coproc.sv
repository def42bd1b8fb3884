// gridrt_coproc: the GridRT ray-intersection co-processor (SPEC.md §4; rtl/README.md).
//
// Two AXI4-Stream-style word streams carry the FSL packets: s_axis (requests, from the
// soft-core) and m_axis (replies). The FSL control bit is tlast. FSL's "full" on the
// request side is !s_axis_tready_o, its "exists" on the reply side is m_axis_tvalid_o (§2 of
// the README). `idle_o` is high when the co-processor waits for input with nothing to send.
// The reset rst_i is synchronous and active high.
//
// Parameters: PES processing elements (1..16); PES_PER_PIPELINE of them share one
// intersection pipeline (1, 2 or 4), each issuing a test every PES_PER_PIPELINE cycles; PE_MEM_WORDS
// words per PE (4 banks with 4 PEs per pipeline, else 16); MAX_LIST longest list. Bit-exact
// twin: gridrt-coproc with kernel watertight, format fixed64-q23 (see rtl/README.md §3 for
// the arithmetic), timing profile `TimingProfile::rtl(PES_PER_PIPELINE)`. STOP_WHEN_EMPTY
// (rtl/README.md §3.4): 1 in the Verilator builds, 0 (the default) for the FPGA; the answers
// and cycles do not depend on it.
module gridrt_coproc #(
    parameter int PES = 4,
    parameter int PES_PER_PIPELINE = 4,
    parameter int PE_MEM_WORDS = 16384,
    parameter int MAX_LIST = 256,
    parameter int STOP_WHEN_EMPTY = 0,
    // 1: each PE's memory is a cache (CACHE_LINES lines of 8 words) of its image in an
    // external memory on the mem_* port, PE p's word w at word address p·PE_MEM_WORDS + w
    // (rtl/README.md §4.6); 0: block RAM, the mem_* port unused.
    parameter int PE_CACHE = 0,
    parameter int CACHE_LINES = 512,
    // 1 (ECP5 builds with PE_CACHE): the clock enable reaches its ~30 000 registers through a
    // global network (a DCCA, as a clock does) instead of a fabric net (rtl/README.md §4.6).
    // Yosys only (`SYNTHESIS`); simulations see the plain net.
    parameter int EN_ECP5_GLOBAL = 0
) (
    input  logic        clk_i,
    input  logic        rst_i,
    input  logic [31:0] s_axis_tdata_i,
    input  logic        s_axis_tlast_i,
    input  logic        s_axis_tvalid_i,
    output logic        s_axis_tready_o,
    output logic [31:0] m_axis_tdata_o,
    output logic        m_axis_tlast_o,
    output logic        m_axis_tvalid_o,
    input  logic        m_axis_tready_i,
    output logic        idle_o,
    // The external memory (PE_CACHE): one 32-bit word per request, the request held until
    // ack, a read's word with its ack; word addresses.
    output logic        mem_req_o,
    output logic        mem_we_o,
    output logic [31:0] mem_addr_o,
    output logic [31:0] mem_wdata_o,
    input  logic        mem_ack_i,
    input  logic [31:0] mem_rdata_i,
    // Cycles the co-processor stood still for its PE memory (PE_CACHE; 0 otherwise).
    output logic [31:0] stall_cycles_o
);
    localparam int AW = $clog2(PE_MEM_WORDS);
    if (PES_PER_PIPELINE != 1 && PES_PER_PIPELINE != 2 && PES_PER_PIPELINE != 4) begin : g_bad_sharing
        $error("gridrt_coproc: PES_PER_PIPELINE must be 1, 2 or 4");
    end
    localparam int KW = $clog2(MAX_LIST);

    logic [PES-1:0][AW-1:0]  a_addr, ref_off;
    logic [PES-1:0]          a_we;
    logic [31:0]             a_wdata;
    logic [PES-1:0][31:0]    a_rdata, issued, res_t;
    logic                    ray_begin, start, stop, any, dz_neg, ray_overflow;
    logic [PES-1:0]          q_push;
    logic [KW-1:0]           q_k, res_k;
    logic [AW-1:0]           q_first, q_count;
    logic [31:0]             q_hi, t_max;
    logic [2:0][33:0]        o;
    logic [1:0]              kz;
    logic signed [24:0]      sx, sy;
    logic [23:0]             dz_abs;
    logic signed [9:0]       texp;
    logic [PES-1:0][KW:0]    open_k, hit_k;
    logic [PES-1:0][AW-1:0]  res_tri;
    // Tests and results between the PEs and their shared pipelines; indices PES and above are
    // the unused lanes of the last pipeline when PES is not a multiple of PES_PER_PIPELINE.
    // A record crosses to its pipeline in parts (gridrt_pe.sv): three of 4 words read one by one
    // when four PEs share a pipeline, else PES_PER_PIPELINE parts of one read.
    localparam int PIPES = (PES + PES_PER_PIPELINE - 1) / PES_PER_PIPELINE;
    localparam int LANES = PIPES * PES_PER_PIPELINE;
    localparam int PARTS = (PES_PER_PIPELINE == 4) ? 3 : PES_PER_PIPELINE;
    localparam int PART_W = (PES_PER_PIPELINE == 4) ? 128 : 288 / PES_PER_PIPELINE;
    localparam int PIPE_LATENCY = 57;   // isect_pipe's stages (checked there)
    localparam int RESULT_LATENCY = PIPE_LATENCY + PES_PER_PIPELINE;   // isect_share's
    logic [LANES-1:0]              t_valid, r_valid;
    logic [LANES-1:0][1:0]         t_part;
    logic [LANES-1:0][PART_W-1:0]  t_chunk;
    logic [LANES-1:0][1:0]         r_kind;
    logic [LANES-1:0][31:0]        r_t;
    for (genvar p = PES; p < LANES; p++) begin : g_no_pe
        assign t_valid[p] = 1'b0;
        assign t_part[p] = '0;
        assign t_chunk[p] = '0;
    end

    // ---------------------------------------------------------------- the clock enable
    // With PE caches the co-processor stops (en low) while a cache fetches what a read
    // missed; the freeze controller steps the caches through FILL and the two REPLAY cycles
    // (gridrt_pe_cache.sv). Words cross the streams only while it runs: the request side
    // is not ready and the reply side goes through a register of its own while it stands.
    localparam logic [1:0] PHASE_RUN = 2'd0, PHASE_FILL = 2'd1, PHASE_REPLAY_R = 2'd2, PHASE_REPLAY_R2 = 2'd3;
    logic [1:0]     phase_q;
    logic           en;
    logic [PES-1:0] pc_hold, pc_ready;
    logic           c_tready, c_tvalid, c_tlast, c_mready, c_idle;
    logic [31:0]    c_tdata;
    if (PE_CACHE != 0) begin : g_freeze
        logic [1:0]  phase_d;
        logic        run_q;   // phase_q == PHASE_RUN, a register of its own: en comes straight from it
        logic [31:0] stall_q;
        always_comb begin
            phase_d = phase_q;
            case (phase_q)
                PHASE_RUN:       if (|pc_hold) phase_d = PHASE_FILL;
                PHASE_FILL:      if (&pc_ready) phase_d = PHASE_REPLAY_R;
                PHASE_REPLAY_R:  phase_d = PHASE_REPLAY_R2;
                default:         phase_d = (|pc_hold) ? PHASE_FILL : PHASE_RUN;
            endcase
        end
        always_ff @(posedge clk_i) begin
            if (rst_i) begin
                phase_q <= PHASE_RUN;
                run_q <= 1'b1;
                stall_q <= '0;
            end else begin
                phase_q <= phase_d;
                run_q <= phase_d == PHASE_RUN;
                if (phase_q != PHASE_RUN) stall_q <= stall_q + 1'b1;
            end
        end
        if (EN_ECP5_GLOBAL != 0) begin : g_en_global
`ifdef SYNTHESIS
            DCCA u_en_dcca (.CLKI(run_q), .CE(1'b1), .CLKO(en));
`else
            assign en = run_q;
`endif
        end else begin : g_en_fabric
            assign en = run_q;
        end
        assign stall_cycles_o = stall_q;
        // The reply register: filled from the controller only while it runs.
        logic        o_valid_q, o_last_q;
        logic [31:0] o_data_q;
        assign c_mready = en && (!o_valid_q || m_axis_tready_i);
        always_ff @(posedge clk_i) begin
            if (rst_i) o_valid_q <= 1'b0;
            else if (c_mready) o_valid_q <= c_tvalid;
            else if (m_axis_tready_i) o_valid_q <= 1'b0;
            if (c_mready && c_tvalid) begin
                o_data_q <= c_tdata;
                o_last_q <= c_tlast;
            end
        end
        assign m_axis_tvalid_o = o_valid_q;
        assign m_axis_tdata_o = o_data_q;
        assign m_axis_tlast_o = o_last_q;
        assign s_axis_tready_o = en && c_tready;
        assign idle_o = c_idle && en && !o_valid_q;
    end else begin : g_no_freeze
        assign phase_q = PHASE_RUN;
        assign en = 1'b1;
        assign stall_cycles_o = '0;
        assign c_mready = m_axis_tready_i;
        assign m_axis_tvalid_o = c_tvalid;
        assign m_axis_tdata_o = c_tdata;
        assign m_axis_tlast_o = c_tlast;
        assign s_axis_tready_o = c_tready;
        assign idle_o = c_idle;
    end

    // The PEs' memory requests, one at a time (the lowest PE first; a grant lasts one word).
    logic [PES-1:0]         m_req, m_we, m_ack;
    logic [PES-1:0][AW-1:0] m_addr;
    logic [PES-1:0][31:0]   m_wdata;
    if (PE_CACHE != 0) begin : g_mem_arb
        localparam int PW = (PES > 1) ? $clog2(PES) : 1;
        logic          busy_q;
        logic [PW-1:0] who_q, pick;
        always_comb begin
            pick = '0;
            for (int p = PES - 1; p >= 0; p--) if (m_req[p]) pick = PW'(p);
        end
        always_ff @(posedge clk_i) begin
            if (rst_i) busy_q <= 1'b0;
            else if (busy_q && mem_ack_i) busy_q <= 1'b0;
            else if (!busy_q && |m_req) busy_q <= 1'b1;
            if (!busy_q) who_q <= pick;
        end
        assign mem_req_o = busy_q;
        assign mem_we_o = m_we[who_q];
        assign mem_addr_o = 32'(who_q) * 32'(PE_MEM_WORDS) + 32'(m_addr[who_q]);
        assign mem_wdata_o = m_wdata[who_q];
        for (genvar p = 0; p < PES; p++) begin : g_ack
            assign m_ack[p] = busy_q && mem_ack_i && who_q == PW'(p);
        end
    end else begin : g_no_mem
        assign mem_req_o = 1'b0;
        assign mem_we_o = 1'b0;
        assign mem_addr_o = '0;
        assign mem_wdata_o = '0;
        assign m_ack = '0;
    end

    gridrt_ctrl #(.PES(PES), .WORDS(PE_MEM_WORDS), .MAX_LIST(MAX_LIST)) u_ctrl (
        .clk_i, .en_i(en), .rst_i,
        .s_tdata_i(s_axis_tdata_i), .s_tlast_i(s_axis_tlast_i), .s_tvalid_i(s_axis_tvalid_i && en), .s_tready_o(c_tready),
        .m_tdata_o(c_tdata), .m_tlast_o(c_tlast), .m_tvalid_o(c_tvalid), .m_tready_i(c_mready),
        .idle_o(c_idle),
        .pe_a_addr_o(a_addr), .pe_a_we_o(a_we), .pe_a_wdata_o(a_wdata), .pe_a_rdata_i(a_rdata),
        .pe_ref_off_o(ref_off),
        .pe_ray_begin_o(ray_begin), .pe_q_push_o(q_push), .pe_q_k_o(q_k), .pe_q_first_o(q_first),
        .pe_q_count_o(q_count), .pe_q_hi_o(q_hi),
        .pe_start_o(start), .pe_stop_o(stop), .pe_any_o(any), .pe_t_max_o(t_max), .pe_origin_o(o), .pe_kz_o(kz),
        .pe_sx_o(sx), .pe_sy_o(sy), .pe_dz_neg_o(dz_neg), .pe_dz_abs_o(dz_abs), .pe_texp_o(texp),
        .pe_ray_overflow_o(ray_overflow), .pe_issued_i(issued),
        .pe_open_k_i(open_k), .pe_hit_k_i(hit_k), .pe_res_k_o(res_k), .pe_res_t_i(res_t), .pe_res_tri_i(res_tri));

    for (genvar p = 0; p < PES; p++) begin : g_pe
        gridrt_pe #(.WORDS(PE_MEM_WORDS), .MAX_LIST(MAX_LIST), .ISSUE_INTERVAL(PES_PER_PIPELINE), .PARTS(PARTS),
             .PART_W(PART_W), .RESULT_LATENCY(RESULT_LATENCY), .PE_CACHE(PE_CACHE), .CACHE_LINES(CACHE_LINES)) u_pe (
            .clk_i, .en_i(en), .rst_i,
            .c_a_addr_i(a_addr[p]), .c_a_we_i(a_we[p]), .c_a_wdata_i(a_wdata), .a_rdata_o(a_rdata[p]),
            .pc_phase_i(phase_q), .pc_hold_o(pc_hold[p]), .pc_ready_o(pc_ready[p]),
            .m_req_o(m_req[p]), .m_we_o(m_we[p]), .m_addr_o(m_addr[p]), .m_wdata_o(m_wdata[p]),
            .m_ack_i(m_ack[p]), .m_rdata_i(mem_rdata_i),
            .ref_off_i(ref_off[p]),
            .ray_begin_i(ray_begin), .q_push_i(q_push[p]), .q_k_i(q_k), .q_first_i(q_first), .q_count_i(q_count), .q_hi_i(q_hi),
            .start_i(start), .stop_i(stop), .any_i(any), .t_max_i(t_max),
            .issued_o(issued[p]),
            .t_valid_o(t_valid[p]), .t_part_o(t_part[p]), .t_chunk_o(t_chunk[p]),
            .r_valid_i(r_valid[p]), .r_kind_i(r_kind[p]), .r_t_i(r_t[p]),
            .open_k_o(open_k[p]), .hit_k_o(hit_k[p]),
            .res_k_i(res_k), .res_t_o(res_t[p]), .res_tri_o(res_tri[p]));
    end

    // PEs q·PES_PER_PIPELINE .. (q+1)·PES_PER_PIPELINE - 1 share pipeline q (rtl/README.md §4.3).
    for (genvar q = 0; q < PIPES; q++) begin : g_pipe
        localparam int L0 = q * PES_PER_PIPELINE;
        gridrt_isect_share #(.LANES(PES_PER_PIPELINE), .PARTS(PARTS), .PART_W(PART_W), .PIPE_LATENCY(PIPE_LATENCY),
                             .STOP_WHEN_EMPTY(STOP_WHEN_EMPTY)) u_share (
            .clk_i, .en_i(en), .rst_i,
            .in_valid_i(t_valid[L0 +: PES_PER_PIPELINE]), .in_part_i(t_part[L0 +: PES_PER_PIPELINE]),
            .in_chunk_i(t_chunk[L0 +: PES_PER_PIPELINE]),
            .o0_i($signed(o[0])), .o1_i($signed(o[1])), .o2_i($signed(o[2])), .kz_i(kz), .sx_i(sx), .sy_i(sy), .dz_neg_i(dz_neg), .dz_abs_i(dz_abs),
            .texp_i(texp), .ray_overflow_i(ray_overflow),
            .out_valid_o(r_valid[L0 +: PES_PER_PIPELINE]), .out_kind_o(r_kind[L0 +: PES_PER_PIPELINE]),
            .out_t_o(r_t[L0 +: PES_PER_PIPELINE]));
    end

`ifndef SYNTHESIS
    // The clock enable is high exactly in RUN (it has a register of its own, run_q).
    EnIsRun: assert property (@(posedge clk_i) disable iff (rst_i) en == (phase_q == PHASE_RUN))
        else $error("gridrt_coproc: en_i out of step with the freeze controller");

    // AXI4-Stream handshakes: a word once offered (tvalid) stays offered, unchanged, until it
    // is taken (tready). The request side checks the source, the reply side this design.
    SAxisValidHeld: assert property (@(posedge clk_i) disable iff (rst_i)
        s_axis_tvalid_i && !s_axis_tready_o |=> s_axis_tvalid_i)
        else $error("gridrt_coproc: s_axis_tvalid_i dropped before s_axis_tready_o");
    SAxisDataStable: assert property (@(posedge clk_i) disable iff (rst_i)
        s_axis_tvalid_i && !s_axis_tready_o |=> $stable({s_axis_tlast_i, s_axis_tdata_i}))
        else $error("gridrt_coproc: s_axis word changed while waiting for s_axis_tready_o");
    MAxisValidHeld: assert property (@(posedge clk_i) disable iff (rst_i)
        m_axis_tvalid_o && !m_axis_tready_i |=> m_axis_tvalid_o)
        else $error("gridrt_coproc: m_axis_tvalid_o dropped before m_axis_tready_i");
    MAxisDataStable: assert property (@(posedge clk_i) disable iff (rst_i)
        m_axis_tvalid_o && !m_axis_tready_i |=> $stable({m_axis_tlast_o, m_axis_tdata_o}))
        else $error("gridrt_coproc: m_axis word changed while waiting for m_axis_tready_i");
`endif
endmodule
