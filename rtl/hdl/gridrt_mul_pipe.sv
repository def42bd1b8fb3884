// gridrt_mul_pipe: signed A_W x B_W -> A_W+B_W product in four MULT18X18D blocks, pipelined, with a
// latency of LATENCY cycles (the caller's choice, at least the structure's 4), counted in
// cycles with en_i high (every register holds while it is low).
//
// Each operand (18 < width <= 35) is split into a signed high and an unsigned 17-bit low
// part, so each of the four partial products is one 18x18 MULT18X18D; two registered adder
// levels sum them. The product is exact; longer latencies are padded with registers at the
// output. (A fabric variant of radix-4 rows, for the shear products when those stayed out of
// the DSP blocks, was removed at the issue-interval-2 redesign: rtl/README.md §5.)
module gridrt_mul_pipe #(
    parameter int A_W = 35,
    parameter int B_W = 35,
    parameter int LATENCY = 4
) (
    input  logic                        clk_i,
    input  logic                        en_i,   // advance; tie high for a free-running pipe
    input  logic signed [A_W-1:0]       a_i,
    input  logic signed [B_W-1:0]       b_i,
    output logic signed [A_W+B_W-1:0]   p_o
);
    localparam int P_W = A_W + B_W;

    // Stages: input registers | partial products | two adder levels.
    localparam int STRUCT_LATENCY = 4;

    logic signed [P_W-1:0] prod;    // the product after STRUCT_LATENCY cycles

    if (A_W <= 18 || A_W > 35 || B_W <= 18 || B_W > 35) begin : g_bad
        $error("mul_pipe: needs 18 < A_W, B_W <= 35");
    end
    localparam int L = 17;              // low part width (unsigned)
    logic signed [A_W-1:0] a1;
    logic signed [B_W-1:0] b1;
    logic signed [35:0]    pll, plh, phl, phh;
    logic signed [P_W-1:0] hl3;         // {phh, pll}: the low part is < 2^34, no overlap
    logic signed [P_W-L-1:0] mid3;      // plh + phl
    always_ff @(posedge clk_i) if (en_i) begin
        a1 <= a_i;
        b1 <= b_i;
        // Each product is 18x18 signed: one MULT18X18D.
        pll <= $signed({1'b0, a1[L-1:0]}) * $signed({1'b0, b1[L-1:0]});
        plh <= $signed({1'b0, a1[L-1:0]}) * 18'($signed(b1[B_W-1:L]));
        phl <= 18'($signed(a1[A_W-1:L])) * $signed({1'b0, b1[L-1:0]});
        phh <= 18'($signed(a1[A_W-1:L])) * 18'($signed(b1[B_W-1:L]));
        hl3 <= $signed({(P_W-2*L)'(phh), pll[2*L-1:0]});
        mid3 <= (P_W-L)'(plh) + (P_W-L)'(phl);
        prod <= hl3 + $signed({mid3, (L)'(0)});
    end

    if (LATENCY < STRUCT_LATENCY) begin : g_short
        $error("mul_pipe: LATENCY below the structure's");
    end
    gridrt_delay #(.W(P_W), .N(LATENCY - STRUCT_LATENCY)) u_pad (.clk_i, .en_i, .d_i(prod), .q_o(p_o));
endmodule
