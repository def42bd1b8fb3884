// tdp_ram: true dual-port RAM with synchronous reads (one DP16KD-style block per port pair;
// Yosys maps it to ECP5 block RAM). Reading and writing one address on both ports in the
// same cycle is not used by the design.
module tdp_ram #(
    parameter int W = 32,
    parameter int DEPTH = 1024
) (
    input  logic                     clk,
    input  logic [$clog2(DEPTH)-1:0] a_addr,
    input  logic                     a_we,
    input  logic [W-1:0]             a_wdata,
    output logic [W-1:0]             a_rdata,
    input  logic [$clog2(DEPTH)-1:0] b_addr,
    input  logic                     b_we,
    input  logic [W-1:0]             b_wdata,
    output logic [W-1:0]             b_rdata
);
    logic [W-1:0] mem [DEPTH];
    always_ff @(posedge clk) begin
        if (a_we) mem[a_addr] <= a_wdata;
        a_rdata <= mem[a_addr];
    end
    always_ff @(posedge clk) begin
        if (b_we) mem[b_addr] <= b_wdata;
        b_rdata <= mem[b_addr];
    end
endmodule
