// gridrt_pe_mem: one PE's memory, WORDS x 32 bits in BANKS interleaved banks (word w in bank
// w mod BANKS): 16 banks for a PE that reads a whole 10-word record at once, 4 for one that
// reads it in three 4-word parts (gridrt_pe.sv).
//
// One write port (the controller: LOAD_PE's image words, records and normals) and one read
// port that serves every reader in turn: the controller while the PE is idle (voxel lookup,
// the winner's triangle), the PE while it executes (ref words and records in their own
// slots, gridrt_pe.sv). A read returns a window of RD_WORDS consecutive words, each bank at its own
// row, and the one word at the address:
// - 16 banks: the window starts at the even address r_addr & ~1 (records sit at even
//   addresses, which halves the rotation's first step), the word is window word r_addr[0];
// - 4 banks: the window starts at r_addr, the word is window word 0; the rotation is one
//   4-way select of 4 words instead of 16 banks' 512 bits.
// With WORD_PORT = 1 a second read port returns the word at w_addr (a PE with a pipeline of
// its own reads its ref words and its records in the same cycle). Both read ports have a
// latency of 2 cycles (block RAM, then the rotation register); r_word is selected after the
// register. Spec: rtl/README.md §4.2.
module gridrt_pe_mem #(
    parameter int WORDS = 16384,
    parameter int BANKS = 16,
    parameter int RD_WORDS = 10,
    parameter bit WORD_PORT = 0
) (
    input  logic                      clk_i,
    input  logic                      en_i,   // the co-processor's clock enable: every register holds while low
    input  logic [$clog2(WORDS)-1:0]  w_addr_i,
    input  logic                      w_en_i,
    input  logic [31:0]               w_data_i,
    output logic [31:0]               w_rdata_o,    // WORD_PORT = 1: the word at w_addr
    input  logic [$clog2(WORDS)-1:0]  r_addr_i,
    output logic [32*RD_WORDS-1:0]    r_window_o,   // window word j at bits 32j+31..32j
    output logic [31:0]               r_word_o
);
    localparam int AW = $clog2(WORDS);
    localparam int BW = $clog2(BANKS);
    localparam int ROWS = WORDS / BANKS;
    localparam int RW = AW - BW;
    if (!(BANKS == 16 && RD_WORDS <= 16 && RD_WORDS >= 2) && !(BANKS == 4 && RD_WORDS == 4)) begin : g_bad
        $error("pe_mem: 16 banks with 2..16 window words, or 4 banks with 4");
    end

    // Bank b holds window word b - start (mod BANKS), in the next row if b < start: every
    // bank takes one of the two rows (no adder per bank).
    logic [BW-1:0] start;
    logic [RW-1:0] row, row_next;
    logic [RW-1:0] r_row_b [BANKS];
    logic [BANKS-1:0] w_en_b;
    logic [31:0]   rd_b [BANKS], w_rd_b [BANKS];
    always_comb begin
        start = (BANKS == 16) ? {r_addr_i[BW-1:1], 1'b0} : r_addr_i[BW-1:0];
        row = r_addr_i[AW-1:BW];
        row_next = row + 1'b1;
        for (int b = 0; b < BANKS; b++) begin
            r_row_b[b] = (BW'(b) < start) ? row_next : row;
            w_en_b[b] = w_en_i && w_addr_i[BW-1:0] == BW'(b);
        end
    end

    for (genvar b = 0; b < BANKS; b++) begin : g_bank
        gridrt_bank_ram #(.W(32), .DEPTH(ROWS), .A_READS(WORD_PORT)) u_bank (
            .clk_i, .en_i,
            .a_addr_i(w_addr_i[AW-1:BW]), .a_we_i(w_en_b[b]), .a_wdata_i(w_data_i), .a_rdata_o(w_rd_b[b]),
            .b_addr_i(r_row_b[b]), .b_rdata_o(rd_b[b]));
    end

    logic [BW-1:0] start_q;
    logic          odd_q, odd_qq;     // r_addr[0], one and two cycles later
    always_ff @(posedge clk_i) if (en_i) begin
        start_q <= start;
        odd_q <= r_addr_i[0];
        odd_qq <= odd_q;
    end
    if (BANKS == 16) begin : g_rotate16
        // In two steps: by the even start's bit 1 over all 16 banks (a 2-way select, 1 LUT4
        // per bit), then by its high two bits for the RD_WORDS outputs (4-way, 2 LUT4s per
        // bit), instead of a 16-way select's 9 LUT4s for every output bit.
        logic [31:0] rot_lo [16];       // rot_lo[m] = bank (m + start[1:0]) mod 16
        always_comb begin
            for (int m = 0; m < 16; m++) rot_lo[m] = rd_b[4'(m) + {2'b00, start_q[1], 1'b0}];
        end
        always_ff @(posedge clk_i) if (en_i)
            for (int j = 0; j < RD_WORDS; j++) r_window_o[32*j +: 32] <= rot_lo[4'(j) + {start_q[3:2], 2'b00}];
        assign r_word_o = odd_qq ? r_window_o[63:32] : r_window_o[31:0];
    end else begin : g_rotate4
        always_ff @(posedge clk_i) if (en_i)
            for (int j = 0; j < 4; j++) r_window_o[32*j +: 32] <= rd_b[2'(j) + start_q];
        assign r_word_o = r_window_o[31:0];
    end

    if (WORD_PORT) begin : g_word_port
        logic [BW-1:0] w_sel;
        always_ff @(posedge clk_i) if (en_i) begin
            w_sel <= w_addr_i[BW-1:0];
            w_rdata_o <= w_rd_b[w_sel];
        end
    end else begin : g_no_word_port
        assign w_rdata_o = '0;
    end
endmodule
