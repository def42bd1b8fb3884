// isect_share: one intersection pipeline (isect_pipe, one test per cycle) shared by LANES
// PEs, 1, 2 or 4 (rtl/README.md §4.3).
//
// A lane's PE sends a test's record in PARTS parts of PART_W bits (in_part numbers them, the
// last may be partly unused); the parts before the last wait in registers here, so the long
// wires from each PE memory carry one part. Every PE issues in the exec cycles that are
// multiples of LANES and sends its last part at the same offset from its issue (pe.sv's
// timeline), so lane l's assembled tests are delayed l cycles and the lanes take turns: at
// most one test enters per cycle. The lanes' tests are merged by OR (a lane's delayed record
// is zero when it has none) into one register beside the pipeline. Lane l's results are held
// LANES - 1 - l cycles on the way out, so every lane sees the same latency, LATENCY =
// PIPE_LATENCY + LANES from its last part to its result, in the order of its tests (the PE
// keeps each test's tag). A lane whose in_valid is tied low (a PE count that is not a
// multiple of LANES) costs nothing.
module isect_share #(
    parameter int LANES = 2,
    parameter int PARTS = 1,
    parameter int PART_W = 288,
    parameter int PIPE_LATENCY = 57,     // isect_pipe's, checked there
    localparam int LATENCY = PIPE_LATENCY + LANES
) (
    input  logic                            clk,
    // Tests of the lanes' PEs: a record's parts, low bits first, each with in_valid.
    input  logic [LANES-1:0]                in_valid,
    input  logic [LANES-1:0][1:0]           in_part,
    input  logic [LANES-1:0][PART_W-1:0]    in_chunk,
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
    output logic [LANES-1:0][1:0]           out_kind,
    output logic [LANES-1:0][31:0]          out_t
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
        assign whole_valid = in_valid[l] && in_part[l] == 2'(PARTS - 1);
        if (PARTS == 1) begin : g_one
            assign whole = in_chunk[l][287:0];
        end else begin : g_parts
            logic [(PARTS-1)*PART_W-1:0] early;      // the parts before the last
            logic [PARTS*PART_W-1:0]     all;
            for (genvar q = 0; q < PARTS - 1; q++) begin : g_early
                always_ff @(posedge clk)
                    if (in_valid[l] && in_part[l] == 2'(q)) early[q*PART_W +: PART_W] <= in_chunk[l];
            end
            assign all = {in_chunk[l], early};
            assign whole = all[287:0];
        end
        delay #(.W(1 + 288), .N(l)) u_lane (.clk, .d({whole_valid, whole_valid ? whole : 288'd0}),
                                            .q({d_valid[l], d_rec[l]}));
    end
`ifndef SYNTHESIS
    // The timeline keeps the lanes apart; a collision would merge two tests.
    always_ff @(posedge clk)
        if (!$onehot0(d_valid)) $fatal(1, "isect_share: two lanes' tests in the same cycle");
`endif

    // The merged test, registered beside the pipeline; its lane number rides along as the tag.
    logic          m_valid;
    logic [LW-1:0] m_lane;
    logic [287:0]  m_rec;
    always_ff @(posedge clk) begin
        logic [LW-1:0] lane;
        logic [287:0]  rec;
        lane = '0;
        rec = '0;
        for (int l = 0; l < LANES; l++) begin
            lane = lane | (d_valid[l] ? LW'(l) : LW'(0));
            rec = rec | d_rec[l];
        end
        m_valid <= |d_valid;
        m_lane <= lane;
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

    logic          p_valid;
    logic [LW-1:0] p_lane;
    logic [1:0]    p_kind;
    logic [31:0]   p_t;
    isect_pipe #(.TAG_W(LW), .LATENCY(PIPE_LATENCY)) u_pipe (
        .clk, .in_valid(m_valid), .in_tag(m_lane), .rec(m_rec),
        .o0(r_o0), .o1(r_o1), .o2(r_o2), .kz(r_kz), .sx(r_sx), .sy(r_sy), .dz_neg(r_dz_neg),
        .dz_abs(r_dz_abs), .texp(r_texp), .ray_overflow(r_ray_overflow),
        .out_valid(p_valid), .out_tag(p_lane), .kind(p_kind), .t(p_t));

    // ---------------------------------------------------------------- results, realigned
    for (genvar l = 0; l < LANES; l++) begin : g_out
        logic mine;
        assign mine = p_valid && (LANES == 1 || p_lane == LW'(l));
        delay #(.W(1 + 2 + 32), .N(LANES - 1 - l)) u_lane (
            .clk, .d({mine, p_kind, p_t}), .q({out_valid[l], out_kind[l], out_t[l]}));
    end
endmodule
