// isect_share: one intersection pipeline (isect_pipe, one test per cycle) shared by LANES
// PEs, 1 to 4 (rtl/README.md §4.3).
//
// Every PE issues in the exec cycles that are multiples of LANES (pe.sv's timeline), so lane
// l's tests are delayed l cycles here and the lanes take turns: at most one test enters per
// cycle. The lanes' tests are merged by OR (a lane's delayed test is zero when it has none)
// into one register beside the pipeline, so the records from the PE memories reach it in a
// cycle of their own. Lane l's results are held LANES - 1 - l cycles on the way out, so every
// lane sees the same latency, LATENCY + LANES from its in_valid to its out_valid. A lane whose
// in_valid is tied low (a PE count that is not a multiple of LANES) costs nothing.
module isect_share #(
    parameter int TAG_W = 1,
    parameter int LANES = 2
) (
    input  logic                            clk,
    // Tests of the lanes' PEs.
    input  logic [LANES-1:0]                in_valid,
    input  logic [LANES-1:0][TAG_W-1:0]     in_tag,
    input  logic [LANES-1:0][287:0]         in_rec,
    // Ray constants (isect_pipe).
    input  logic signed [33:0]              o0, o1, o2,
    input  logic [1:0]                      kz,
    input  logic signed [24:0]              sx, sy,
    input  logic                            dz_neg,
    input  logic [23:0]                     dz_abs,
    input  logic signed [9:0]               texp,
    input  logic                            ray_overflow,
    // Results to the lanes' PEs.
    output logic [LANES-1:0]                out_valid,
    output logic [LANES-1:0][TAG_W-1:0]     out_tag,
    output logic [LANES-1:0][1:0]           out_kind,
    output logic [LANES-1:0][31:0]          out_t
);
    localparam int LW = (LANES > 1) ? $clog2(LANES) : 1;   // the lane number in the tag
    if (LANES < 1 || LANES > 4) begin : g_bad
        $error("isect_share: LANES must be 1..4");
    end

    // ---------------------------------------------------------------- lanes in turn
    // Lane l's test, l cycles later, zeroed when there is none (so the merge is an OR).
    logic [LANES-1:0]               d_valid;
    logic [LANES-1:0][TAG_W-1:0]    d_tag;
    logic [LANES-1:0][287:0]        d_rec;
    for (genvar l = 0; l < LANES; l++) begin : g_in
        logic [TAG_W+287:0] gated;
        assign gated = in_valid[l] ? {in_tag[l], in_rec[l]} : '0;
        delay #(.W(1 + TAG_W + 288), .N(l)) u_lane (.clk, .d({in_valid[l], gated}),
                                                     .q({d_valid[l], d_tag[l], d_rec[l]}));
    end
`ifndef SYNTHESIS
    // The timeline keeps the lanes apart; a collision would merge two tests.
    always_ff @(posedge clk)
        if (!$onehot0(d_valid)) $fatal(1, "isect_share: two lanes' tests in the same cycle");
`endif

    // The merged test, registered beside the pipeline; the lane number above the PE's tag.
    logic               m_valid;
    logic [LW+TAG_W-1:0] m_tag;
    logic [287:0]       m_rec;
    always_ff @(posedge clk) begin
        logic [LW+TAG_W-1:0] tag;
        logic [287:0]        rec;
        tag = '0;
        rec = '0;
        for (int l = 0; l < LANES; l++) begin
            tag = tag | {(d_valid[l] ? LW'(l) : LW'(0)), d_tag[l]};
            rec = rec | d_rec[l];
        end
        m_valid <= |d_valid;
        m_tag <= tag;
        m_rec <= rec;
    end

    // The ray constants, registered here: one copy next to each pipeline instead of one net
    // from the controller's ray setup across the device to every pipeline (kz alone selects
    // 315 bits per pipeline). They are final when the ray setup ends, at least 8 cycles
    // before the ray's first test reaches K1, and hold until the next ray's setup, after this
    // ray's result: the register's cycle changes no test.
    logic signed [33:0] r_o0, r_o1, r_o2;
    logic [1:0]         r_kz;
    logic signed [24:0] r_sx, r_sy;
    logic               r_dz_neg, r_ray_overflow;
    logic [23:0]        r_dz_abs;
    logic signed [9:0]  r_texp;
    always_ff @(posedge clk) begin
        {r_o0, r_o1, r_o2, r_kz, r_sx, r_sy} <= {o0, o1, o2, kz, sx, sy};
        {r_dz_neg, r_dz_abs, r_texp, r_ray_overflow} <= {dz_neg, dz_abs, texp, ray_overflow};
    end

    logic               p_valid;
    logic [LW+TAG_W-1:0] p_tag;
    logic [1:0]         p_kind;
    logic [31:0]        p_t;
    isect_pipe #(.TAG_W(LW + TAG_W)) u_pipe (
        .clk, .in_valid(m_valid), .in_tag(m_tag), .rec(m_rec),
        .o0(r_o0), .o1(r_o1), .o2(r_o2), .kz(r_kz), .sx(r_sx), .sy(r_sy), .dz_neg(r_dz_neg),
        .dz_abs(r_dz_abs), .texp(r_texp), .ray_overflow(r_ray_overflow),
        .out_valid(p_valid), .out_tag(p_tag), .kind(p_kind), .t(p_t));

    // ---------------------------------------------------------------- results, realigned
    for (genvar l = 0; l < LANES; l++) begin : g_out
        logic mine;
        assign mine = p_valid && (LANES == 1 || p_tag[LW+TAG_W-1 -: LW] == LW'(l));
        delay #(.W(1 + TAG_W + 2 + 32), .N(LANES - 1 - l)) u_lane (
            .clk, .d({mine, p_tag[TAG_W-1:0], p_kind, p_t}),
            .q({out_valid[l], out_tag[l], out_kind[l], out_t[l]}));
    end
endmodule
