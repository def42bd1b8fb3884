// pe_mem: one PE's memory, WORDS x 32 bits in 16 interleaved banks (word w in bank w mod 16).
//
// Port A reads or writes one word. Port B reads or writes a window of 16 consecutive words
// starting at any address (each bank gets its own row), so a 10-word record or an 11-word
// triangle is one access. Both ports have a read latency of 2 cycles (block RAM, then the
// bank select / rotation register). Spec: rtl/README.md §4.2.
module pe_mem #(
    parameter int WORDS = 16384
) (
    input  logic                      clk,
    input  logic [$clog2(WORDS)-1:0]  a_addr,
    input  logic                      a_we,
    input  logic [31:0]               a_wdata,
    output logic [31:0]               a_rdata,
    input  logic [$clog2(WORDS)-1:0]  b_addr,
    input  logic [15:0]               b_we,       // window word j is written when b_we[j]
    input  logic [511:0]              b_wdata,    // window word j at bits 32j+31..32j
    output logic [511:0]              b_rdata
);
    localparam int AW = $clog2(WORDS);
    localparam int ROWS = WORDS / 16;
    localparam int RW = AW - 4;

    logic [RW-1:0] a_row_b [16], b_row_b [16];
    logic [15:0]   a_we_b, b_we_b;
    logic [31:0]   b_wd_b [16];
    logic [31:0]   a_rd_b [16], b_rd_b [16];

    always_comb begin
        for (int b = 0; b < 16; b++) begin
            logic [3:0] j;
            a_row_b[b] = a_addr[AW-1:4];
            a_we_b[b] = a_we && a_addr[3:0] == 4'(b);
            // Bank b holds window word j = b - start (mod 16), in the next row if b < start.
            j = 4'(b) - b_addr[3:0];
            b_row_b[b] = b_addr[AW-1:4] + RW'(4'(b) < b_addr[3:0]);
            b_we_b[b] = b_we[j];
            b_wd_b[b] = b_wdata[32*j +: 32];
        end
    end

    for (genvar b = 0; b < 16; b++) begin : g_bank
        tdp_ram #(.W(32), .DEPTH(ROWS)) u_bank (
            .clk,
            .a_addr(a_row_b[b]), .a_we(a_we_b[b]), .a_wdata(a_wdata), .a_rdata(a_rd_b[b]),
            .b_addr(b_row_b[b]), .b_we(b_we_b[b]), .b_wdata(b_wd_b[b]), .b_rdata(b_rd_b[b]));
    end

    logic [3:0] a_sel, b_start;
    always_ff @(posedge clk) begin
        a_sel <= a_addr[3:0];
        b_start <= b_addr[3:0];
        a_rdata <= a_rd_b[a_sel];
        for (int j = 0; j < 16; j++) b_rdata[32*j +: 32] <= b_rd_b[4'(j) + b_start];
    end
endmodule
