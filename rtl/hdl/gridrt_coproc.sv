// gridrt_coproc: the GridRT ray-intersection co-processor (SPEC.md §4; rtl/README.md).
//
// Two AXI4-Stream-style word streams carry the FSL packets: s_axis (requests, from the
// soft-core) and m_axis (replies). The FSL control bit is tlast. FSL's "full" on the
// request side is !s_axis_tready, its "exists" on the reply side is m_axis_tvalid (§4.1 of
// the README). `idle` is high when the co-processor waits for input with nothing to send.
//
// Parameters: PES processing elements (1..16); PES_PER_PIPELINE of them share one
// intersection pipeline (1, 2 or 4), each issuing a test every PES_PER_PIPELINE cycles; PE_MEM_WORDS
// words per PE (4 banks with 4 PEs per pipeline, else 16); MAX_LIST longest list. Bit-exact
// twin: gridrt-coproc with kernel watertight, format fixed64-q23 (see rtl/README.md §3 for
// the arithmetic), timing profile `TimingProfile::rtl(PES_PER_PIPELINE)`.
module gridrt_coproc #(
    parameter int PES = 4,
    parameter int PES_PER_PIPELINE = 4,
    parameter int PE_MEM_WORDS = 16384,
    parameter int MAX_LIST = 256
) (
    input  logic        clk,
    input  logic        rst,
    input  logic [31:0] s_axis_tdata,
    input  logic        s_axis_tlast,
    input  logic        s_axis_tvalid,
    output logic        s_axis_tready,
    output logic [31:0] m_axis_tdata,
    output logic        m_axis_tlast,
    output logic        m_axis_tvalid,
    input  logic        m_axis_tready,
    output logic        idle
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
    // A record crosses to its pipeline in parts (pe.sv): three of 4 words read one by one
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

    ctrl #(.PES(PES), .WORDS(PE_MEM_WORDS), .MAX_LIST(MAX_LIST)) u_ctrl (
        .clk, .rst,
        .s_tdata(s_axis_tdata), .s_tlast(s_axis_tlast), .s_tvalid(s_axis_tvalid), .s_tready(s_axis_tready),
        .m_tdata(m_axis_tdata), .m_tlast(m_axis_tlast), .m_tvalid(m_axis_tvalid), .m_tready(m_axis_tready),
        .idle,
        .pe_a_addr(a_addr), .pe_a_we(a_we), .pe_a_wdata(a_wdata), .pe_a_rdata(a_rdata),
        .pe_ref_off(ref_off),
        .pe_ray_begin(ray_begin), .pe_q_push(q_push), .pe_q_k(q_k), .pe_q_first(q_first),
        .pe_q_count(q_count), .pe_q_hi(q_hi),
        .pe_start(start), .pe_stop(stop), .pe_any(any), .pe_t_max(t_max), .pe_o(o), .pe_kz(kz),
        .pe_sx(sx), .pe_sy(sy), .pe_dz_neg(dz_neg), .pe_dz_abs(dz_abs), .pe_texp(texp),
        .pe_ray_overflow(ray_overflow), .pe_issued(issued),
        .pe_open_k(open_k), .pe_hit_k(hit_k), .pe_res_k(res_k), .pe_res_t(res_t), .pe_res_tri(res_tri));

    for (genvar p = 0; p < PES; p++) begin : g_pe
        pe #(.WORDS(PE_MEM_WORDS), .MAX_LIST(MAX_LIST), .ISSUE_INTERVAL(PES_PER_PIPELINE), .PARTS(PARTS),
             .PART_W(PART_W), .RESULT_LATENCY(RESULT_LATENCY)) u_pe (
            .clk, .rst,
            .c_a_addr(a_addr[p]), .c_a_we(a_we[p]), .c_a_wdata(a_wdata), .a_rdata(a_rdata[p]),
            .ref_off(ref_off[p]),
            .ray_begin, .q_push(q_push[p]), .q_k, .q_first, .q_count, .q_hi,
            .start, .stop, .any, .t_max,
            .issued(issued[p]),
            .t_valid(t_valid[p]), .t_part(t_part[p]), .t_chunk(t_chunk[p]),
            .r_valid(r_valid[p]), .r_kind(r_kind[p]), .r_t(r_t[p]),
            .open_k(open_k[p]), .hit_k(hit_k[p]),
            .res_k, .res_t(res_t[p]), .res_tri(res_tri[p]));
    end

    // PEs q·PES_PER_PIPELINE .. (q+1)·PES_PER_PIPELINE - 1 share pipeline q (rtl/README.md §4.3).
    for (genvar q = 0; q < PIPES; q++) begin : g_pipe
        localparam int L0 = q * PES_PER_PIPELINE;
        isect_share #(.LANES(PES_PER_PIPELINE), .PARTS(PARTS), .PART_W(PART_W), .PIPE_LATENCY(PIPE_LATENCY)) u_share (
            .clk,
            .in_valid(t_valid[L0 +: PES_PER_PIPELINE]), .in_part(t_part[L0 +: PES_PER_PIPELINE]),
            .in_chunk(t_chunk[L0 +: PES_PER_PIPELINE]),
            .o0($signed(o[0])), .o1($signed(o[1])), .o2($signed(o[2])), .kz, .sx, .sy, .dz_neg, .dz_abs,
            .texp, .ray_overflow,
            .out_valid(r_valid[L0 +: PES_PER_PIPELINE]), .out_kind(r_kind[L0 +: PES_PER_PIPELINE]),
            .out_t(r_t[L0 +: PES_PER_PIPELINE]));
    end
endmodule
