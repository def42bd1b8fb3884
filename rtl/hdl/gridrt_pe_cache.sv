// gridrt_pe_cache: one PE's memory as a direct-mapped cache of its image in an external
// memory (SDRAM on the board), in place of gridrt_pe_mem's block RAM when the co-processor is
// built with PE_CACHE = 1 (rtl/README.md §4.6). The PE side is gridrt_pe_mem's with 4 banks:
// a read of the 4-word window at r_addr_i has a latency of 2 cycles; writes (LOAD_PE's) go
// through to the external memory.
//
// Misses stop the whole co-processor instead of the reader (rtl/README.md §4.6): a read whose
// line is absent is found in the cycle after its address (the tag RAM's output), and the
// cache raises hold_o; the freeze controller (gridrt_coproc) then clears the co-processor's
// clock enable from the next cycle on and steps every cache through FILL (lines fetched,
// writes drained), REPLAY_R (the missed read presented again) and REPLAY_R2 (the read after
// it). The co-processor resumes with both reads where they were when it stopped, so its
// timeline, its answers and its cycle counts are those of block RAM.
//
// Geometry: LINES lines of LINE_WORDS = 8 words; word w in bank w mod 4 at row
// w[IW+2:2]; line l at index l mod LINES, tag l / LINES. The tags sit in two RAMs, even and
// odd indices, so a window that spans two lines looks both up in one cycle.
module gridrt_pe_cache #(
    parameter int WORDS = 1 << 20,
    parameter int LINES = 512,
    parameter int WB_DEPTH = 4
) (
    input  logic                      clk_i,
    input  logic                      rst_i,
    input  logic                      en_i,        // the co-processor's clock enable
    input  logic [1:0]                phase_i,     // PHASE_* of the freeze controller
    // The PE side (gridrt_pe_mem's, 4 banks): writes are taken in cycles with en_i.
    input  logic [$clog2(WORDS)-1:0]  w_addr_i,
    input  logic                      w_en_i,
    input  logic [31:0]               w_data_i,
    input  logic [$clog2(WORDS)-1:0]  r_addr_i,
    input  logic                      r_valid_i,   // a read the PE uses (only those can miss)
    output logic [127:0]              r_window_o,
    output logic [31:0]               r_word_o,
    // To the freeze controller.
    output logic                      hold_o,      // stop the co-processor from the next cycle
    output logic                      ready_o,     // FILL: nothing left to fetch or write
    // The external memory, one word per request (request held until ack; a read's word
    // comes with its ack). Addresses are this PE's word addresses.
    output logic                      m_req_o,
    output logic                      m_we_o,
    output logic [$clog2(WORDS)-1:0]  m_addr_o,
    output logic [31:0]               m_wdata_o,
    input  logic                      m_ack_i,
    input  logic [31:0]               m_rdata_i
);
    localparam logic [1:0] PHASE_RUN = 2'd0, PHASE_FILL = 2'd1, PHASE_REPLAY_R = 2'd2, PHASE_REPLAY_R2 = 2'd3;
    localparam int AW = $clog2(WORDS);
    localparam int IW = $clog2(LINES);
    localparam int LW = AW - 3;               // line number bits
    localparam int TW = LW - IW;              // tag bits
    localparam int ROWS = LINES * 2;          // rows per bank: 8-word lines in 4 banks
    localparam int RW = IW + 1;
    if (TW < 1 || LINES < 2 || (1 << IW) != LINES) begin : g_bad_geometry
        $error("pe_cache: LINES must be a power of two, smaller than WORDS / 8");
    end

    // ---------------------------------------------------------------- the read address
    // The address the data and tag RAMs read this cycle: the PE's, or a saved one in replay.
    logic [AW-1:0] sav_r_q, sav_r2_q;         // the missed read and the one after it
    logic          sav_r_v_q, sav_r2_v_q;
    logic [AW-1:0] a;
    logic          a_v;
    always_comb begin
        case (phase_i)
            PHASE_REPLAY_R:  begin a = sav_r_q;  a_v = sav_r_v_q; end
            PHASE_REPLAY_R2: begin a = sav_r2_q; a_v = sav_r2_v_q; end
            default:         begin a = r_addr_i; a_v = r_valid_i && phase_i == PHASE_RUN; end
        endcase
    end

    // ---------------------------------------------------------------- data: 4 banks
    logic [1:0]    start;
    logic [RW-1:0] row, row_next;
    logic [RW-1:0] r_row_b [4];
    logic [31:0]   rd_b [4];
    logic [3:0]    f_we_b;                    // a fill word into bank b
    logic [AW-1:0] f_addr;                    // the word being filled
    logic [31:0]   f_data;
    always_comb begin
        start = a[1:0];
        row = a[IW+2:2];
        row_next = row + 1'b1;
        for (int b = 0; b < 4; b++) r_row_b[b] = (2'(b) < start) ? row_next : row;
    end
    for (genvar b = 0; b < 4; b++) begin : g_bank
        logic [31:0] unused_a;   // port A only writes (A_READS = 0)
        gridrt_bank_ram #(.W(32), .DEPTH(ROWS), .A_READS(0)) u_bank (
            .clk_i, .en_i(1'b1),
            .a_addr_i(f_addr[IW+2:2]), .a_we_i(f_we_b[b]), .a_wdata_i(f_data), .a_rdata_o(unused_a),
            .b_addr_i(r_row_b[b]), .b_rdata_o(rd_b[b]));
    end
    logic [1:0] start_q;
    always_ff @(posedge clk_i) start_q <= start;
    always_ff @(posedge clk_i)
        for (int j = 0; j < 4; j++) r_window_o[32*j +: 32] <= rd_b[2'(j) + start_q];
    assign r_word_o = r_window_o[31:0];

    // ---------------------------------------------------------------- tags: even and odd lines
    // A window's lines: l0 = a / 8 and l1 = (a + 3) / 8 (the same unless a mod 8 > 4). The
    // even one is looked up in tag_e, the odd one in tag_o; an entry is {valid, tag}.
    logic [LW-1:0] l0, l1, le, lo;
    logic          need_e, need_o;
    always_comb begin
        l0 = a[AW-1:3];
        l1 = LW'((a + AW'(3)) >> 3);
        le = l0[0] ? l1 : l0;
        lo = l0[0] ? l0 : l1;
        need_e = !l0[0] || (l1 != l0 && !l1[0]);
        need_o = l0[0] || (l1 != l0 && l1[0]);
    end
    logic [TW:0]   tag_e [LINES/2];
    logic [TW:0]   tag_o [LINES/2];
    logic [TW:0]   te_q, to_q;                // the entries read for the address of last cycle
    logic [LW-1:0] le_q, lo_q;
    logic          need_e_q, need_o_q, look_v_q;
    logic [AW-1:0] look_a_q;
    // Tag writes: a filled line becomes valid, a written word's line invalid.
    logic          tw_e, tw_o;
    logic [IW-2:0] tw_idx;
    logic [TW:0]   tw_val;
    always_ff @(posedge clk_i) begin
        if (tw_e) tag_e[tw_idx] <= tw_val;
        if (tw_o) tag_o[tw_idx] <= tw_val;
        te_q <= tag_e[le[IW-1:1]];
        to_q <= tag_o[lo[IW-1:1]];
        le_q <= le;
        lo_q <= lo;
        need_e_q <= need_e;
        need_o_q <= need_o;
        look_v_q <= a_v;
        look_a_q <= a;
    end
    logic miss_e, miss_o, miss, look_lines;
    always_comb begin
        miss_e = need_e_q && !(te_q[TW] && te_q[TW-1:0] == le_q[LW-1 -: TW]);
        miss_o = need_o_q && !(to_q[TW] && to_q[TW-1:0] == lo_q[LW-1 -: TW]);
        miss = look_v_q && (miss_e || miss_o);
        look_lines = miss && (phase_i == PHASE_RUN || phase_i == PHASE_REPLAY_R2);
    end

    // ---------------------------------------------------------------- write buffer
    logic [AW+31:0]              wb_mem [WB_DEPTH];
    logic [$clog2(WB_DEPTH)-1:0] wb_rd_q, wb_wr_q;
    logic [$clog2(WB_DEPTH):0]   wb_n_q;
    logic                        wb_push, wb_pop;
    assign wb_push = w_en_i && en_i;
    always_ff @(posedge clk_i) begin
        if (wb_push) wb_mem[wb_wr_q] <= {w_addr_i, w_data_i};
        if (rst_i) begin
            wb_rd_q <= '0;
            wb_wr_q <= '0;
            wb_n_q <= '0;
        end else begin
            if (wb_push) wb_wr_q <= wb_wr_q + 1'b1;
            if (wb_pop) wb_rd_q <= wb_rd_q + 1'b1;
            wb_n_q <= wb_n_q + ($clog2(WB_DEPTH)+1)'(wb_push) - ($clog2(WB_DEPTH)+1)'(wb_pop);
        end
    end

    // ---------------------------------------------------------------- the memory side
    // CLEAR (after a reset: every tag invalid), IDLE, WRITE (the buffer's head), FILL_E /
    // FILL_O (a missed line, word by word; the next word's request goes out with the ack of
    // the last). Fills wait for an empty write buffer, so a line read back holds what LOAD_PE
    // wrote.
    typedef enum logic [2:0] { M_CLEAR, M_IDLE, M_WRITE, M_FILL_E, M_FILL_O } mstate_t;
    mstate_t       ms_q, ms_d;
    logic [IW-1:0] clr_q, clr_d;
    logic          pend_e_q, pend_e_d, pend_o_q, pend_o_d;   // lines still to fill
    logic [LW-1:0] pl_e_q, pl_o_q;                            // and their numbers
    logic [2:0]    fw_q, fw_d;                                // the word of the line
    logic          req_q, req_d;
    always_comb begin
        ms_d = ms_q;
        clr_d = clr_q;
        pend_e_d = pend_e_q;
        pend_o_d = pend_o_q;
        fw_d = fw_q;
        req_d = req_q;
        wb_pop = 1'b0;
        tw_e = 1'b0;
        tw_o = 1'b0;
        tw_idx = '0;
        tw_val = '0;
        f_we_b = '0;
        f_addr = '0;
        f_data = m_rdata_i;
        // A miss in RUN (or of a replayed read, if a line went away): its lines, filled in FILL.
        if (look_lines) begin
            pend_e_d = miss_e;
            pend_o_d = miss_o;
        end
        // A write makes its line invalid (it never allocates).
        if (wb_push) begin
            tw_e = !w_addr_i[3];
            tw_o = w_addr_i[3];
            tw_idx = w_addr_i[IW+2:4];
            tw_val = '0;
        end
        case (ms_q)
            M_CLEAR: begin
                tw_e = 1'b1;
                tw_o = 1'b1;
                tw_idx = clr_q[IW-2:0];
                tw_val = '0;
                clr_d = clr_q + 1'b1;
                if (clr_q == IW'(LINES / 2 - 1)) ms_d = M_IDLE;
            end
            M_IDLE: begin
                if (wb_n_q != 0) begin
                    ms_d = M_WRITE;
                    req_d = 1'b1;
                end else if (phase_i == PHASE_FILL && (pend_e_q || pend_o_q)) begin
                    ms_d = pend_e_q ? M_FILL_E : M_FILL_O;
                    fw_d = '0;
                    req_d = 1'b1;
                end
            end
            M_WRITE: begin
                if (m_ack_i) begin
                    wb_pop = 1'b1;
                    req_d = 1'b0;
                    ms_d = M_IDLE;
                end
            end
            default: begin   // M_FILL_E, M_FILL_O
                f_addr = {ms_q == M_FILL_E ? pl_e_q : pl_o_q, fw_q};
                if (m_ack_i) begin
                    f_we_b[f_addr[1:0]] = 1'b1;
                    fw_d = fw_q + 1'b1;
                    if (fw_q == 3'd7) begin
                        tw_e = ms_q == M_FILL_E;
                        tw_o = ms_q == M_FILL_O;
                        tw_idx = f_addr[IW+2:4];
                        tw_val = {1'b1, f_addr[AW-1 -: TW]};
                        if (ms_q == M_FILL_E) pend_e_d = 1'b0;
                        else pend_o_d = 1'b0;
                        if (ms_q == M_FILL_E && pend_o_q) begin
                            ms_d = M_FILL_O;
                        end else begin
                            ms_d = M_IDLE;
                            req_d = 1'b0;
                        end
                    end
                end
            end
        endcase
    end
    always_ff @(posedge clk_i) begin
        if (rst_i) begin
            ms_q <= M_CLEAR;
            clr_q <= '0;
            pend_e_q <= 1'b0;
            pend_o_q <= 1'b0;
            fw_q <= '0;
            req_q <= 1'b0;
        end else begin
            ms_q <= ms_d;
            clr_q <= clr_d;
            pend_e_q <= pend_e_d;
            pend_o_q <= pend_o_d;
            fw_q <= fw_d;
            req_q <= req_d;
        end
        if (phase_i == PHASE_RUN) begin
            // The lookup of this cycle and the address behind it: what REPLAY presents again
            // if this cycle's lookup stops the co-processor.
            sav_r_q <= look_a_q;
            sav_r_v_q <= look_v_q;
            sav_r2_q <= a;
            sav_r2_v_q <= a_v;
        end
        if (look_lines) begin
            pl_e_q <= le_q;
            pl_o_q <= lo_q;
        end
    end
    assign m_req_o = req_q;
    assign m_we_o = ms_q == M_WRITE;
    assign m_addr_o = ms_q == M_WRITE ? wb_mem[wb_rd_q][AW+31:32] : {ms_q == M_FILL_E ? pl_e_q : pl_o_q, fw_q};
    assign m_wdata_o = wb_mem[wb_rd_q][31:0];

    // Stop when a read missed (in RUN, or replayed in REPLAY_R2), when the write buffer could overflow with the writes of the
    // next cycle, and while the tags are cleared after a reset.
    assign hold_o = !rst_i && (ms_q == M_CLEAR || miss || wb_n_q >= ($clog2(WB_DEPTH)+1)'(WB_DEPTH - 1));
    assign ready_o = ms_q == M_IDLE && wb_n_q == 0 && !pend_e_q && !pend_o_q;

`ifndef SYNTHESIS
    // The memory is asked only for what the co-processor waits for: fills only in FILL.
    FillOnlyWhenStopped: assert property (@(posedge clk_i) disable iff (rst_i)
        (ms_q == M_FILL_E || ms_q == M_FILL_O) |-> phase_i == PHASE_FILL)
        else $fatal(1, "gridrt_pe_cache: a line fill outside FILL");
    WriteBufferNeverFull: assert property (@(posedge clk_i) disable iff (rst_i)
        !(wb_push && wb_n_q == ($clog2(WB_DEPTH)+1)'(WB_DEPTH) && !wb_pop))
        else $fatal(1, "gridrt_pe_cache: write buffer overflow");
`endif
endmodule
