// pe_mem: one PE's memory, WORDS x 32 bits in 16 interleaved banks (word w in bank w mod 16).
//
// Port A reads or writes one word (the controller: load, voxel lookup, the winner's
// triangle). Port B only reads: a window of consecutive words starting at any even address
// (each bank gets its own row), so a 10-word record is one access; its words come out in
// window order, the first RD_WORDS. Records sit at even addresses (the controller stacks them
// from the top of the memory down, 10 words each), which halves the rotation's first step.
// Both ports have a read latency of 2 cycles (block RAM, then the bank select / rotation
// register). Spec: rtl/README.md §4.2.
module pe_mem #(
    parameter int WORDS = 16384,
    parameter int RD_WORDS = 10
) (
    input  logic                      clk,
    input  logic [$clog2(WORDS)-1:0]  a_addr,
    input  logic                      a_we,
    input  logic [31:0]               a_wdata,
    output logic [31:0]               a_rdata,
    input  logic [$clog2(WORDS)-1:0]  b_addr,
    output logic [32*RD_WORDS-1:0]    b_rdata     // window word j at bits 32j+31..32j
);
    localparam int AW = $clog2(WORDS);
    localparam int ROWS = WORDS / 16;
    localparam int RW = AW - 4;

    logic [RW-1:0] a_row_b [16], b_row_b [16];
    logic [15:0]   a_we_b;
    logic [31:0]   a_rd_b [16], b_rd_b [16];

    always_comb begin
        for (int b = 0; b < 16; b++) begin
            a_row_b[b] = a_addr[AW-1:4];
            a_we_b[b] = a_we && a_addr[3:0] == 4'(b);
            // Bank b holds window word b - start (mod 16), in the next row if b < start.
            b_row_b[b] = b_addr[AW-1:4] + RW'(4'(b) < b_addr[3:0]);
        end
    end

    for (genvar b = 0; b < 16; b++) begin : g_bank
        bank_ram #(.W(32), .DEPTH(ROWS)) u_bank (
            .clk,
            .a_addr(a_row_b[b]), .a_we(a_we_b[b]), .a_wdata(a_wdata), .a_rdata(a_rd_b[b]),
            .b_addr(b_row_b[b]), .b_rdata(b_rd_b[b]));
    end

    // Port B's rotation in two steps: by the even start's bit 1 over all 16 banks (a 2-way
    // select, 1 LUT4 per bit), then by its high two bits for the RD_WORDS outputs (4-way, 2
    // LUT4s per bit), instead of a 16-way select's 9 LUT4s for every output bit.
    logic [3:0]  a_sel, b_start;
    logic [31:0] b_rot_lo [16];     // b_rot_lo[m] = bank (m + start[1:0]) mod 16
    always_comb begin
        for (int m = 0; m < 16; m++) b_rot_lo[m] = b_rd_b[4'(m) + {2'b00, b_start[1], 1'b0}];
    end
`ifndef SYNTHESIS
    always_ff @(posedge clk)
        if (b_addr[0]) $fatal(1, "pe_mem: port B window at an odd address");
`endif
    always_ff @(posedge clk) begin
        a_sel <= a_addr[3:0];
        b_start <= b_addr[3:0];
        a_rdata <= a_rd_b[a_sel];
        for (int j = 0; j < RD_WORDS; j++) b_rdata[32*j +: 32] <= b_rot_lo[4'(j) + {b_start[3:2], 2'b00}];
    end
endmodule
