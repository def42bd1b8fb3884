// mul_pipe: signed A_W x B_W -> A_W+B_W product, pipelined, with a latency of LATENCY
// cycles (the caller's choice, at least the structure's: DSP_LATENCY or fabric_latency()).
//
// USE_DSP = 1 splits each operand (18 < width <= 35) into a signed high and an unsigned
// 17-bit low part, so each of the four partial products is one 18x18 MULT18X18D, and sums
// them in two registered adder levels. USE_DSP = 0 builds the product in fabric (no DSP
// blocks, rtl/README.md §5): radix-4 rows of the signed multiplicand, ROWS_PER_STAGE rows
// summed per group, then a registered binary tree of adders. Both give the exact product;
// short latencies are padded with registers at the output.
module mul_pipe #(
    parameter int A_W = 35,
    parameter int B_W = 35,
    parameter bit USE_DSP = 1,
    parameter int LATENCY = 4
) (
    input  logic                        clk,
    input  logic signed [A_W-1:0]       a,
    input  logic signed [B_W-1:0]       b,
    output logic signed [A_W+B_W-1:0]   p
);
    localparam int P_W = A_W + B_W;

    // Fabric structure: R radix-4 rows (one per two bits of |b|) in NG groups of at most
    // ROWS_PER_STAGE, summed by a TREE-level binary tree.
    localparam int ROWS_PER_STAGE = 4;
    localparam int R = (B_W + 1) / 2;
    localparam int NG = (R + ROWS_PER_STAGE - 1) / ROWS_PER_STAGE;
    localparam int TREE = (NG > 1) ? $clog2(NG) : 0;
    // Stages: DSP input | partial products | two adder levels; fabric: sign and |b| | 3x |
    // groups | tree levels.
    localparam int DSP_LATENCY = 4;
    localparam int FABRIC_LATENCY = 3 + TREE;
    localparam int STRUCT_LATENCY = USE_DSP ? DSP_LATENCY : FABRIC_LATENCY;

    logic signed [P_W-1:0] prod;    // the product after STRUCT_LATENCY cycles

    if (USE_DSP) begin : g_dsp
        if (A_W <= 18 || A_W > 35 || B_W <= 18 || B_W > 35) begin : g_bad
            $error("mul_pipe: USE_DSP needs 18 < A_W, B_W <= 35");
        end
        localparam int L = 17;              // low part width (unsigned)
        logic signed [A_W-1:0] a1;
        logic signed [B_W-1:0] b1;
        logic signed [35:0]    pll, plh, phl, phh;
        logic signed [P_W-1:0] hl3;         // {phh, pll}: the low part is < 2^34, no overlap
        logic signed [P_W-L-1:0] mid3;      // plh + phl
        always_ff @(posedge clk) begin
            a1 <= a;
            b1 <= b;
            // Each product is 18x18 signed: one MULT18X18D.
            pll <= $signed({1'b0, a1[L-1:0]}) * $signed({1'b0, b1[L-1:0]});
            plh <= $signed({1'b0, a1[L-1:0]}) * 18'($signed(b1[B_W-1:L]));
            phl <= 18'($signed(a1[A_W-1:L])) * $signed({1'b0, b1[L-1:0]});
            phh <= 18'($signed(a1[A_W-1:L])) * 18'($signed(b1[B_W-1:L]));
            hl3 <= $signed({(P_W-2*L)'(phh), pll[2*L-1:0]});
            mid3 <= (P_W-L)'(plh) + (P_W-L)'(phl);
            prod <= hl3 + $signed({mid3, (L)'(0)});
        end
    end else begin : g_fabric
        localparam int RW = A_W + 2;        // row width: |3s| < 2^(A_W+1), signed
        logic signed [A_W:0]   s1;          // a * sign(b)
        logic [B_W-1:0]        mb0;
        logic [2*R-1:0]        mb1;         // |b|
        logic signed [A_W:0]   s2;
        logic signed [RW-1:0]  s3x2;        // 3 s
        logic [2*R-1:0]        mb2;
        assign mb0 = b[B_W-1] ? B_W'(-b) : B_W'(b);
        always_ff @(posedge clk) begin
            s1 <= b[B_W-1] ? -((A_W+1)'(a)) : (A_W+1)'(a);
            mb1 <= (2*R)'(mb0);
            s2 <= s1;
            s3x2 <= RW'(s1) + RW'({s1, 1'b0});
            mb2 <= mb1;
        end
        // Row multiple of s for digit d.
        function automatic logic signed [RW-1:0] pick(input logic [1:0] d, input logic signed [A_W:0] x,
                                                       input logic signed [RW-1:0] x3);
            case (d)
                2'd0: pick = '0;
                2'd1: pick = RW'(x);
                2'd2: pick = RW'({x, 1'b0});
                default: pick = x3;
            endcase
        endfunction
        // Sum of rows first..first+n-1 times 4^first, as P_W bits. The accumulator is as wide
        // as a row: two settled product bits leave it per row.
        function automatic logic signed [P_W-1:0] rows(input int first, input int n, input logic [2*R-1:0] m,
                                                        input logic signed [A_W:0] x, input logic signed [RW-1:0] x3);
            logic signed [RW:0]      acc;
            logic [P_W+2*R-1:0]      out;
            out = '0;
            acc = (RW+1)'(pick(m[2*first +: 2], x, x3));
            for (int k = 1; k < n; k++) begin
                out[2*(first+k-1) +: 2] = acc[1:0];
                acc = (acc >>> 2) + (RW+1)'(pick(m[2*(first+k) +: 2], x, x3));
            end
            out[2*(first+n-1) +: P_W] = P_W'(acc);
            rows = P_W'(out);
        endfunction
        logic signed [P_W-1:0] tr [TREE+1][NG];
        always_ff @(posedge clk) begin
            for (int g = 0; g < NG; g++)
                tr[0][g] <= rows(g * ROWS_PER_STAGE, (R - g * ROWS_PER_STAGE < ROWS_PER_STAGE)
                                 ? R - g * ROWS_PER_STAGE : ROWS_PER_STAGE, mb2, s2, s3x2);
        end
        for (genvar l = 1; l <= TREE; l++) begin : g_tree
            always_ff @(posedge clk) begin
                for (int i = 0; i < NG; i++)
                    tr[l][i] <= ((2*i < NG) ? tr[l-1][2*i] : P_W'(0)) + ((2*i+1 < NG) ? tr[l-1][2*i+1] : P_W'(0));
            end
        end
        assign prod = tr[TREE][0];
    end

    if (LATENCY < STRUCT_LATENCY) begin : g_short
        $error("mul_pipe: LATENCY below the structure's");
    end
    delay #(.W(P_W), .N(LATENCY - STRUCT_LATENCY)) u_pad (.clk, .d(prod), .q(p));
endmodule
