// gridrt_delay_ram: W bits delayed by N cycles (N >= 2) through a block RAM ring instead of N
// registers: one write and one read per cycle, for wide payloads that only ride along a
// long pipeline (a PE's test tag: 56 bits over 60 stages would be 3 360 flip-flops).
// The ring has the smallest power-of-two depth above N - 1; entry p is written in cycle t and
// read back in cycle t + N - 1, its output register adding the last cycle.
module gridrt_delay_ram #(
    parameter int W = 1,
    parameter int N = 2
) (
    input  logic         clk_i,
    input  logic         en_i,   // the co-processor's clock enable: every register holds while low
    input  logic [W-1:0] d_i,
    output logic [W-1:0] q_o
);
    localparam int AW = $clog2(N);  // 2^AW >= N > N - 1: the read never meets the write
    if (N < 2) begin : g_bad
        $error("delay_ram: N must be at least 2");
    end
    (* ram_style = "block" *)
    logic [W-1:0]  ring [2**AW];
    logic [AW-1:0] wp;
    always_ff @(posedge clk_i) if (en_i) begin
        ring[wp] <= d_i;
        q_o <= ring[wp - AW'(N - 1)];
        wp <= wp + 1'b1;
    end
endmodule
