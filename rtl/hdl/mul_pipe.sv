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
        // |a| * |b| as two half-products of shifted rows, then the sign.
        localparam int H = B_W / 2;
        logic [A_W-1:0] ma;
        logic [B_W-1:0] mb;
        logic           neg;
        logic [P_W-1:0] lo_sum, hi_sum;
        always_comb begin
            ma = a1[A_W-1] ? A_W'(-a1) : A_W'(a1);
            mb = b1[B_W-1] ? B_W'(-b1) : B_W'(b1);
            lo_sum = '0;
            hi_sum = '0;
            for (int i = 0; i < H; i++) if (mb[i]) lo_sum = lo_sum + (P_W'(ma) << i);
            for (int i = H; i < B_W; i++) if (mb[i]) hi_sum = hi_sum + (P_W'(ma) << i);
        end
        logic [P_W-1:0] lo2, hi2;
        logic           neg2;
        always_ff @(posedge clk) begin
            lo2 <= lo_sum;
            hi2 <= hi_sum;
            neg2 <= a1[A_W-1] ^ b1[B_W-1];
        end
        always_ff @(posedge clk) p <= neg2 ? -$signed(lo2 + hi2) : $signed(lo2 + hi2);
    end
endmodule
