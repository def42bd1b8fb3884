// pe_mem: one PE's memory, WORDS x 32 bits in 16 interleaved banks (word w in bank w mod 16).
//
// One write port (the controller: LOAD_PE's image words, records and normals) and one read
// port that serves every reader in turn: the controller while the PE is idle (voxel lookup,
// the winner's triangle), the PE while it executes (ref words and record windows in
// alternate slots, pe.sv). A read returns the window of consecutive words from the even
// address r_addr & ~1 (each bank gets its own row), the first RD_WORDS of them in window
// order, and the one word at r_addr (window word r_addr[0]), so a 10-word record at its even
// address is one read and any single word is one read too. Records sit at even addresses (the
// controller stacks them from the top of the memory down, 10 words each), which halves the
// rotation's first step. With WORD_PORT = 1 a second read port returns the word at w_addr
// (a PE with a pipeline of its own reads its ref words and its records in the same cycle).
// Both read ports have a latency of 2 cycles (block RAM, then the bank select / rotation
// register); r_word is selected after the register. Spec: rtl/README.md §4.2.
module pe_mem #(
    parameter int WORDS = 16384,
    parameter int RD_WORDS = 10,
    parameter bit WORD_PORT = 0
) (
    input  logic                      clk,
    input  logic [$clog2(WORDS)-1:0]  w_addr,
    input  logic                      w_en,
    input  logic [31:0]               w_data,
    output logic [31:0]               w_rdata,    // WORD_PORT = 1: the word at w_addr
    input  logic [$clog2(WORDS)-1:0]  r_addr,
    output logic [32*RD_WORDS-1:0]    r_window,   // window word j at bits 32j+31..32j
    output logic [31:0]               r_word
);
    localparam int AW = $clog2(WORDS);
    localparam int ROWS = WORDS / 16;
    localparam int RW = AW - 4;

    // Bank b holds window word b - start (mod 16), in the next row if b < start: every bank
    // takes one of the two rows (no adder per bank).
    logic [3:0]    start;
    logic [RW-1:0] row, row_next;
    logic [RW-1:0] r_row_b [16];
    logic [15:0]   w_en_b;
    logic [31:0]   rd_b [16], w_rd_b [16];
    always_comb begin
        start = {r_addr[3:1], 1'b0};
        row = r_addr[AW-1:4];
        row_next = row + 1'b1;
        for (int b = 0; b < 16; b++) begin
            r_row_b[b] = (4'(b) < start) ? row_next : row;
            w_en_b[b] = w_en && w_addr[3:0] == 4'(b);
        end
    end

    for (genvar b = 0; b < 16; b++) begin : g_bank
        bank_ram #(.W(32), .DEPTH(ROWS), .A_READS(WORD_PORT)) u_bank (
            .clk,
            .a_addr(w_addr[AW-1:4]), .a_we(w_en_b[b]), .a_wdata(w_data), .a_rdata(w_rd_b[b]),
            .b_addr(r_row_b[b]), .b_rdata(rd_b[b]));
    end

    // The rotation in two steps: by the even start's bit 1 over all 16 banks (a 2-way
    // select, 1 LUT4 per bit), then by its high two bits for the RD_WORDS outputs (4-way, 2
    // LUT4s per bit), instead of a 16-way select's 9 LUT4s for every output bit.
    logic [3:0]  start_q;
    logic        odd_q, odd_qq;     // r_addr[0], one and two cycles later
    logic [31:0] rot_lo [16];       // rot_lo[m] = bank (m + start[1:0]) mod 16
    always_comb begin
        for (int m = 0; m < 16; m++) rot_lo[m] = rd_b[4'(m) + {2'b00, start_q[1], 1'b0}];
    end
    always_ff @(posedge clk) begin
        start_q <= start;
        odd_q <= r_addr[0];
        odd_qq <= odd_q;
        for (int j = 0; j < RD_WORDS; j++) r_window[32*j +: 32] <= rot_lo[4'(j) + {start_q[3:2], 2'b00}];
    end
    assign r_word = odd_qq ? r_window[63:32] : r_window[31:0];

    if (WORD_PORT) begin : g_word_port
        logic [3:0] w_sel;
        always_ff @(posedge clk) begin
            w_sel <= w_addr[3:0];
            w_rdata <= w_rd_b[w_sel];
        end
    end else begin : g_no_word_port
        assign w_rdata = '0;
    end
endmodule
