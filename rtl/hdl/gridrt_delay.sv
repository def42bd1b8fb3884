// gridrt_delay: W bits delayed by N cycles (N >= 0; N = 0 is a wire) while en_i is high (a
// pipeline that stops when empty holds its payloads). Keeps pipeline payloads in step with the
// arithmetic stages.
module gridrt_delay #(
    parameter int W = 1,
    parameter int N = 1
) (
    input  logic         clk_i,
    input  logic         en_i,   // shift; tie high for a plain delay line
    input  logic [W-1:0] d_i,
    output logic [W-1:0] q_o
);
    if (N == 0) begin : g_wire
        assign q_o = d_i;
    end else begin : g_regs
        logic [W-1:0] r [N];
        always_ff @(posedge clk_i) if (en_i) begin
            r[0] <= d_i;
            for (int i = 1; i < N; i++) r[i] <= r[i-1];
        end
        assign q_o = r[N-1];
    end
endmodule
