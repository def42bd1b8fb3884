// gridrt_bank_ram: one bank of a PE memory (pe_mem): port A writes (and with A_READS = 1 reads the
// address it is given), port B only reads, both with synchronous reads. Yosys maps it to
// ECP5 DP16KD block RAM (1024 x 32 = two DP16KD in 1024 x 18 mode). The design never reads an
// address in the cycle port A writes it, so the collision behaviour is left undefined
// (`no_rw_check`): without it Yosys must keep read-old-data across the two ports, which
// DP16KD cannot do, and builds the memory from flip-flops instead.
module gridrt_bank_ram #(
    parameter int W = 32,
    parameter int DEPTH = 1024,
    parameter bit A_READS = 1
) (
    input  logic                     clk_i,
    input  logic                     en_i,   // the co-processor's clock enable: every register holds while low
    input  logic [$clog2(DEPTH)-1:0] a_addr_i,
    input  logic                     a_we_i,
    input  logic [W-1:0]             a_wdata_i,
    output logic [W-1:0]             a_rdata_o,
    input  logic [$clog2(DEPTH)-1:0] b_addr_i,
    output logic [W-1:0]             b_rdata_o
);
    (* no_rw_check *)
    logic [W-1:0] mem [DEPTH];
    always_ff @(posedge clk_i) if (en_i) begin
        if (a_we_i) mem[a_addr_i] <= a_wdata_i;
    end
    if (A_READS) begin : g_a_reads
        always_ff @(posedge clk_i) if (en_i) a_rdata_o <= mem[a_addr_i];
    end else begin : g_a_writes_only
        assign a_rdata_o = '0;
    end
    always_ff @(posedge clk_i) if (en_i) b_rdata_o <= mem[b_addr_i];
endmodule
