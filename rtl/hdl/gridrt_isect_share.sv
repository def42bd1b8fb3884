// gridrt_isect_share: one intersection pipeline (isect_pipe, one test per cycle) shared by LANES
// PEs, 1, 2 or 4 (rtl/README.md §4.3).
//
// A lane's PE sends a test's record in PARTS parts of PART_W bits (in_part numbers them, the
// last may be partly unused); the parts before the last wait in registers here, so the long
// wires from each PE memory carry one part. Every PE issues in the exec cycles that are
// multiples of LANES and sends its last part at the same offset from its issue (gridrt_pe.sv's
// timeline), so lane l's assembled tests are delayed l cycles and the lanes take turns: at
// most one test enters per cycle. The lanes' tests are merged by OR (a lane's delayed record
// is zero when it has none) into one register beside the pipeline. Lane l's results are held
// LANES - 1 - l cycles on the way out, so every lane sees the same latency, LATENCY =
// PIPE_LATENCY + LANES from its last part to its result, in the order of its tests (the PE
// keeps each test's tag). A lane whose in_valid is tied low (a PE count that is not a
// multiple of LANES) costs nothing.
module gridrt_isect_share #(
    parameter int LANES = 2,
    parameter int PARTS = 1,
    parameter int PART_W = 288,
    parameter int PIPE_LATENCY = 57,     // isect_pipe's, checked there
    parameter int STOP_WHEN_EMPTY = 0, // isect_pipe's
    localparam int LATENCY = PIPE_LATENCY + LANES
) (
    input  logic                            clk_i,
    input  logic                            en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                            rst_i,      // synchronous, active high: clears the valid bits
    // Tests of the lanes' PEs: a record's parts, low bits first, each with in_valid.
    input  logic [LANES-1:0]                in_valid_i,
    input  logic [LANES-1:0][1:0]           in_part_i,
    input  logic [LANES-1:0][PART_W-1:0]    in_chunk_i,
    // Ray constants (isect_pipe).
    input  logic signed [33:0]              o0_i, o1_i, o2_i,
    input  logic [1:0]                      kz_i,
    input  logic signed [24:0]              sx_i, sy_i,
    input  logic                            dz_neg_i,
    input  logic [23:0]                     dz_abs_i,
    input  logic signed [9:0]               texp_i,
    input  logic                            ray_overflow_i,
    // Results to the lanes' PEs.
    output logic [LANES-1:0]                out_valid_o,
    output logic [LANES-1:0][1:0]           out_kind_o,
    output logic [LANES-1:0][31:0]          out_t_o
);
    localparam int LW = (LANES > 1) ? $clog2(LANES) : 1;   // the lane number, the pipeline's tag
    if (LANES != 1 && LANES != 2 && LANES != 4) begin : g_bad_lanes
        $error("isect_share: LANES must be 1, 2 or 4");
    end
    if (PARTS < 1 || PARTS > 3 || PARTS * PART_W < 288 || (PARTS - 1) * PART_W >= 288) begin : g_bad_parts
        $error("isect_share: PARTS parts of PART_W bits must hold 288, the last one in use");
    end

    // ---------------------------------------------------------------- lanes in turn
    // Lane l's test, assembled in the cycle of its last part, then l cycles later, zeroed
    // when there is none (so the merge is an OR).
    logic [LANES-1:0]           d_valid;
    logic [LANES-1:0][287:0]    d_rec;
    for (genvar l = 0; l < LANES; l++) begin : g_in
        logic         whole_valid;
        logic [287:0] whole;
        assign whole_valid = in_valid_i[l] && in_part_i[l] == 2'(PARTS - 1);
        if (PARTS == 1) begin : g_one
            assign whole = in_chunk_i[l][287:0];
        end else begin : g_parts
            logic [(PARTS-1)*PART_W-1:0] early;      // the parts before the last
            logic [PARTS*PART_W-1:0]     all;
            for (genvar q = 0; q < PARTS - 1; q++) begin : g_early
                always_ff @(posedge clk_i)
                    if (en_i && (in_valid_i[l] && in_part_i[l] == 2'(q))) early[q*PART_W +: PART_W] <= in_chunk_i[l];
            end
            assign all = {in_chunk_i[l], early};
            assign whole = all[287:0];
        end
        gridrt_delay_rst #(.W(1), .N(l)) u_lane_valid (.clk_i, .en_i, .rst_i, .d_i(whole_valid), .q_o(d_valid[l]));
        gridrt_delay #(.W(288), .N(l)) u_lane (.clk_i, .en_i(en_i), .d_i(whole_valid ? whole : 288'd0), .q_o(d_rec[l]));
    end
`ifndef SYNTHESIS
    // The timeline keeps the lanes apart; a collision would merge two tests.
    LanesApart: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) $onehot0(d_valid))
        else $fatal(1, "gridrt_isect_share: two lanes' tests in the same cycle");
`endif

    // The merged test, registered beside the pipeline; its lane number rides along as the tag.
    logic          m_valid;
    logic [LW-1:0] m_lane;
    logic [287:0]  m_rec;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [LW-1:0] lane;
        logic [287:0]  rec;
        lane = '0;
        rec = '0;
        for (int l = 0; l < LANES; l++) begin
            lane = lane | (d_valid[l] ? LW'(l) : LW'(0));
            rec = rec | d_rec[l];
        end
        m_lane <= lane;
        m_rec <= rec;
    end
    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) m_valid <= 1'b0;
        else m_valid <= |d_valid;
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
    always_ff @(posedge clk_i) if (en_i) begin
        {r_o0, r_o1, r_o2, r_kz, r_sx, r_sy} <= {o0_i, o1_i, o2_i, kz_i, sx_i, sy_i};
        {r_dz_neg, r_dz_abs, r_texp, r_ray_overflow} <= {dz_neg_i, dz_abs_i, texp_i, ray_overflow_i};
    end

    logic          p_valid;
    logic [LW-1:0] p_lane;
    logic [1:0]    p_kind;
    logic [31:0]   p_t;
    gridrt_isect_pipe #(.TAG_W(LW), .LATENCY(PIPE_LATENCY), .STOP_WHEN_EMPTY(STOP_WHEN_EMPTY)) u_pipe (
        .clk_i, .en_i, .rst_i, .in_valid_i(m_valid), .in_tag_i(m_lane), .rec_i(m_rec),
        .o0_i(r_o0), .o1_i(r_o1), .o2_i(r_o2), .kz_i(r_kz), .sx_i(r_sx), .sy_i(r_sy), .dz_neg_i(r_dz_neg),
        .dz_abs_i(r_dz_abs), .texp_i(r_texp), .ray_overflow_i(r_ray_overflow),
        .out_valid_o(p_valid), .out_tag_o(p_lane), .kind_o(p_kind), .t_o(p_t));

    // ---------------------------------------------------------------- results, realigned
    for (genvar l = 0; l < LANES; l++) begin : g_out
        logic mine;
        assign mine = p_valid && (LANES == 1 || p_lane == LW'(l));
        gridrt_delay_rst #(.W(1), .N(LANES - 1 - l)) u_lane_valid (.clk_i, .en_i, .rst_i, .d_i(mine), .q_o(out_valid_o[l]));
        gridrt_delay #(.W(2 + 32), .N(LANES - 1 - l)) u_lane (
            .clk_i, .en_i(en_i), .d_i({p_kind, p_t}), .q_o({out_kind_o[l], out_t_o[l]}));
    end
endmodule
