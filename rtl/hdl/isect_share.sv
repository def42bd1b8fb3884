// isect_share: one intersection pipeline (isect_pipe, one test per cycle) shared by two PEs
// (rtl/README.md §4.3).
//
// Both PEs issue on even cycles of a ray only (pe.sv's timeline), so PE A's tests enter the
// pipeline as they come and PE B's one cycle later, in the odd cycles. A's results are held
// one cycle on the way out, so each PE sees the same latency, LATENCY + 1 from its t_valid
// to its r_valid. With HAS_B = 0 (an odd PE count's last PE) the B side is unused.
module isect_share #(
    parameter int TAG_W = 1,
    parameter bit HAS_B = 1
) (
    input  logic                clk,
    // Tests of PE A and PE B.
    input  logic                a_valid, b_valid,
    input  logic [TAG_W-1:0]    a_tag, b_tag,
    input  logic [287:0]        a_rec, b_rec,
    // Ray constants (isect_pipe).
    input  logic signed [33:0]  o0, o1, o2,
    input  logic [1:0]          kz,
    input  logic signed [24:0]  sx, sy,
    input  logic                dz_neg,
    input  logic [23:0]         dz_abs,
    input  logic signed [9:0]   texp,
    input  logic                ray_overflow,
    // Results to PE A and PE B.
    output logic                a_out_valid, b_out_valid,
    output logic [TAG_W-1:0]    a_out_tag, b_out_tag,
    output logic [1:0]          a_kind, b_kind,
    output logic [31:0]         a_t, b_t
);
    // PE B's test, one cycle later.
    logic               b1_valid;
    logic [TAG_W-1:0]   b1_tag;
    logic [287:0]       b1_rec;
    always_ff @(posedge clk) begin
        b1_valid <= HAS_B && b_valid;
        b1_tag <= b_tag;
        b1_rec <= b_rec;
    end
`ifndef SYNTHESIS
    // The timeline keeps the two apart; a collision would lose a test.
    always_ff @(posedge clk)
        if (a_valid && b1_valid) $fatal(1, "isect_share: PE A and PE B tests in the same cycle");
`endif

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

    // The pipeline's tag: the source (1 = B) above the PE's tag.
    logic               p_valid;
    logic [TAG_W:0]     p_tag;
    logic [1:0]         p_kind;
    logic [31:0]        p_t;
    isect_pipe #(.TAG_W(TAG_W + 1)) u_pipe (
        .clk, .in_valid(a_valid || b1_valid),
        .in_tag(a_valid ? {1'b0, a_tag} : {1'b1, b1_tag}), .rec(a_valid ? a_rec : b1_rec),
        .o0(r_o0), .o1(r_o1), .o2(r_o2), .kz(r_kz), .sx(r_sx), .sy(r_sy), .dz_neg(r_dz_neg),
        .dz_abs(r_dz_abs), .texp(r_texp), .ray_overflow(r_ray_overflow),
        .out_valid(p_valid), .out_tag(p_tag), .kind(p_kind), .t(p_t));

    always_ff @(posedge clk) begin
        a_out_valid <= p_valid && !p_tag[TAG_W];
        a_out_tag <= p_tag[TAG_W-1:0];
        a_kind <= p_kind;
        a_t <= p_t;
    end
    assign b_out_valid = p_valid && p_tag[TAG_W];
    assign b_out_tag = p_tag[TAG_W-1:0];
    assign b_kind = p_kind;
    assign b_t = p_t;
endmodule
