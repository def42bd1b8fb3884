// bank_ram: one bank of a PE memory (pe_mem): port A writes (and with A_READS = 1 reads the
// address it is given), port B only reads, both with synchronous reads. Yosys maps it to
// ECP5 DP16KD block RAM (1024 x 32 = two DP16KD in 1024 x 18 mode). The design never reads an
// address in the cycle port A writes it, so the collision behaviour is left undefined
// (`no_rw_check`): without it Yosys must keep read-old-data across the two ports, which
// DP16KD cannot do, and builds the memory from flip-flops instead.
module bank_ram #(
    parameter int W = 32,
    parameter int DEPTH = 1024,
    parameter bit A_READS = 1
) (
    input  logic                     clk,
    input  logic [$clog2(DEPTH)-1:0] a_addr,
    input  logic                     a_we,
    input  logic [W-1:0]             a_wdata,
    output logic [W-1:0]             a_rdata,
    input  logic [$clog2(DEPTH)-1:0] b_addr,
    output logic [W-1:0]             b_rdata
);
    (* no_rw_check *)
    logic [W-1:0] mem [DEPTH];
    always_ff @(posedge clk) begin
        if (a_we) mem[a_addr] <= a_wdata;
    end
    if (A_READS) begin : g_a_reads
        always_ff @(posedge clk) a_rdata <= mem[a_addr];
    end else begin : g_a_writes_only
        assign a_rdata = '0;
    end
    always_ff @(posedge clk) b_rdata <= mem[b_addr];
endmodule
