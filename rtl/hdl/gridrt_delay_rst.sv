// gridrt_delay_rst: W bits delayed by N cycles (N >= 0; N = 0 is a wire), cleared by the
// synchronous reset: gridrt_delay for valid bits, so that nothing is in flight after a reset.
module gridrt_delay_rst #(
    parameter int W = 1,
    parameter int N = 1
) (
    input  logic         clk_i,
    input  logic         en_i,   // the co-processor's clock enable: every register holds while low
    input  logic         rst_i,  // synchronous, active high
    input  logic [W-1:0] d_i,
    output logic [W-1:0] q_o
);
    if (N == 0) begin : g_wire
        assign q_o = d_i;
    end else begin : g_regs
        logic [W-1:0] r_q [N];
        always_ff @(posedge clk_i) if (en_i) begin
            if (rst_i) begin
                for (int i = 0; i < N; i++) r_q[i] <= '0;
            end else begin
                r_q[0] <= d_i;
                for (int i = 1; i < N; i++) r_q[i] <= r_q[i-1];
            end
        end
        assign q_o = r_q[N-1];
    end
endmodule
