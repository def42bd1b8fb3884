// mul_pipe: signed A_W x B_W -> A_W+B_W product with a fixed latency of 3 cycles.
//
// USE_DSP = 1 infers `*` (Yosys maps it to MULT18X18D blocks); USE_DSP = 0 builds the same
// product from shift-and-add rows in fabric, so the top level can keep the DSP count within
// the device (rtl/README.md §5). Both give the exact product.
module mul_pipe #(
    parameter int A_W = 18,
    parameter int B_W = 18,
    parameter bit USE_DSP = 1
) (
    input  logic                        clk,
    input  logic signed [A_W-1:0]       a,
    input  logic signed [B_W-1:0]       b,
    output logic signed [A_W+B_W-1:0]   p
);
    localparam int P_W = A_W + B_W;
    logic signed [A_W-1:0] a1;
    logic signed [B_W-1:0] b1;
    always_ff @(posedge clk) begin
        a1 <= a;
        b1 <= b;
    end
    if (USE_DSP) begin : g_dsp
        logic signed [P_W-1:0] p2;
        always_ff @(posedge clk) begin
            p2 <= a1 * b1;
            p <= p2;
        end
    end else begin : g_fabric
        // |a| * |b| in radix 4: one row per two bits of |b|, each row a choice of
        // {0, |a|, 2|a|, 3|a|} (3|a| formed in the input stage), accumulated A_W+2 bits at a
        // time with two settled product bits shifted out per row, so every adder is as narrow
        // as the row. Rows are split into two halves summed in parallel, then added and signed.
        localparam int R = (B_W + 1) / 2;   // rows
        localparam int RL = R / 2;          // rows of the low half
        localparam int RH = R - RL;
        localparam int RW = A_W + 2;        // row width: 3|a| < 2^(A_W+1)
        logic [A_W-1:0]   ma;
        logic [A_W+1:0]   ma3;
        logic [B_W-1:0]   mb0;
        logic [2*R-1:0]   mb;
        always_comb begin
            ma = a1[A_W-1] ? A_W'(-a1) : A_W'(a1);
            mb0 = b1[B_W-1] ? B_W'(-b1) : B_W'(b1);
            mb = (2*R)'(mb0);
        end
        // Row k's multiple of |a| for digit d.
        function automatic logic [RW-1:0] pick(input logic [1:0] d, input logic [A_W-1:0] x,
                                                input logic [A_W+1:0] x3);
            case (d)
                2'd0: pick = '0;
                2'd1: pick = RW'(x);
                2'd2: pick = RW'({x, 1'b0});
                default: pick = RW'(x3);
            endcase
        endfunction
        // Sum of rows first..first+n-1 (value / 4^first), RW + 2n bits.
        function automatic logic [RW+2*R-1:0] rows(input int first, input int n, input logic [2*R-1:0] m,
                                                     input logic [A_W-1:0] x, input logic [A_W+1:0] x3);
            logic [RW:0]          acc;
            logic [RW+2*R-1:0]    out;
            out = '0;
            acc = {1'b0, pick(m[2*first +: 2], x, x3)};
            for (int k = 1; k < n; k++) begin
                out[2*(k-1) +: 2] = acc[1:0];
                acc = {2'b00, acc[RW:2]} + {1'b0, pick(m[2*(first+k) +: 2], x, x3)};
            end
            out[2*(n-1) +: RW+1] = acc;
            rows = out;
        endfunction
        logic [RW+2*R-1:0] lo2, hi2;
        logic              neg2;
        always_ff @(posedge clk) begin
            lo2 <= rows(0, RL, mb, ma, ma3);
            hi2 <= rows(RL, RH, mb, ma, ma3);
            neg2 <= a1[A_W-1] ^ b1[B_W-1];
        end
        assign ma3 = (A_W+2)'(ma) + (A_W+2)'({ma, 1'b0});
        logic [P_W-1:0] sum2;
        assign sum2 = P_W'(lo2) + P_W'({hi2, (2*RL)'(0)});
        always_ff @(posedge clk) p <= neg2 ? -$signed(sum2) : $signed(sum2);
    end
endmodule
