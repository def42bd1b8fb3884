// gridrt_pe: one processing element: its memory, its queue of list entries, the test issue loop
// and the per-entry result (rtl/README.md §4.3). Its tests go out on the t_* ports to the
// intersection pipeline it shares with ISSUE_INTERVAL - 1 other PEs (gridrt_isect_share.sv) and come
// back on r_*.
//
// Timeline of a ray (the model's `PeTimeline` with issue interval I = ISSUE_INTERVAL and
// voxel_setup_cycles V = max(2, I)): `start` in cycle -1; in cycles 0 .. V-1 the PE sets up
// its first entry. An entry whose setup starts in cycle c issues its n tests in cycles c+V,
// c+V+I, .., c+V+(n-1)I and the next entry's setup starts in cycle c+V+nI, so every issue
// falls on a multiple of I: the pipeline takes the other lanes' tests in the cycles between.
// An entry with no tests is done in cycle c+V (event in cycle c+V-1); an entry with tests is
// done a fixed number of cycles after its last issue (the model's test latency: reads, the
// record's parts, the shared pipeline, the result stage), or, for RAY_ANY, after the issue
// of its first accepted test. `issued` counts the issues of the current ray.
module gridrt_pe #(
    parameter int WORDS = 16384,
    parameter int MAX_LIST = 256,
    // Cycles between two issues: the PEs sharing this PE's intersection pipeline (1, 2, 4).
    parameter int ISSUE_INTERVAL = 2,
    // A test's record goes to the pipeline in PARTS parts of PART_W bits (the last may be
    // partly unused), t_part numbering them: 3 parts of 4 words (128 bits) read one by one
    // from a 4-bank memory when ISSUE_INTERVAL is 4, else ISSUE_INTERVAL parts of 288 /
    // ISSUE_INTERVAL bits of a record read at once, in consecutive cycles.
    parameter int PARTS = 2,
    parameter int PART_W = 144,
    // Cycles from a test's last part on t_* to its result on r_* (isect_share).
    parameter int RESULT_LATENCY = 60,
    // 1: the memory is a cache of the PE's image in an external memory (gridrt_pe_cache,
    // ISSUE_INTERVAL 4 only) of CACHE_LINES 8-word lines; 0: block RAM (gridrt_pe_mem).
    parameter int PE_CACHE = 0,
    parameter int CACHE_LINES = 512
) (
    input  logic                         clk_i,
    input  logic                         en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                         rst_i,
    // Port A of the memory for the controller (load, voxel lookup, the winner's triangle);
    // ignored while the PE executes a ray. Port B is the PE's own (record windows).
    input  logic [$clog2(WORDS)-1:0]     c_a_addr_i,
    input  logic                         c_a_we_i,
    input  logic [31:0]                  c_a_wdata_i,
    output logic [31:0]                  a_rdata_o,
    // PE_CACHE: the freeze controller's phase, this PE's requests to it, its external memory
    // (gridrt_pe_cache); unused with block RAM.
    input  logic [1:0]                   pc_phase_i,
    output logic                         pc_hold_o,
    output logic                         pc_ready_o,
    output logic                         m_req_o,
    output logic                         m_we_o,
    output logic [$clog2(WORDS)-1:0]     m_addr_o,
    output logic [31:0]                  m_wdata_o,
    input  logic                         m_ack_i,
    input  logic [31:0]                  m_rdata_i,
    // Image layout (valid while loaded).
    input  logic [$clog2(WORDS)-1:0]     ref_off_i,
    // Entry queue, filled while the request streams in.
    input  logic                         ray_begin_i,  // empties the queue
    input  logic                         q_push_i,
    input  logic [$clog2(MAX_LIST)-1:0]  q_k_i,
    input  logic [$clog2(WORDS)-1:0]     q_first_i,
    input  logic [$clog2(WORDS)-1:0]     q_count_i,
    input  logic [31:0]                  q_hi_i,
    // Execution.
    input  logic                         start_i,
    input  logic                         stop_i,
    input  logic                         any_i,        // RAY_ANY
    input  logic [31:0]                  t_max_i,
    output logic [31:0]                  issued_o,
    // Tests to the shared intersection pipeline: the record's parts, t_valid with each;
    // their results, in issue order, RESULT_LATENCY cycles after the last part (the test's
    // entry, triangle and prim id wait here).
    output logic                         t_valid_o,
    output logic [1:0]                   t_part_o,
    output logic [PART_W-1:0]            t_chunk_o,
    input  logic                         r_valid_i,
    input  logic [1:0]                   r_kind_i,
    input  logic [31:0]                  r_t_i,
    // For the arbiter: the first of this PE's list entries that is not done, and the first
    // that hit (MAX_LIST: none), with this cycle's events, registered.
    output logic [$clog2(MAX_LIST):0]    open_k_o,
    output logic [$clog2(MAX_LIST):0]    hit_k_o,
    // Result of entry k (hit distance, local triangle), read after the ray.
    input  logic [$clog2(MAX_LIST)-1:0]  res_k_i,
    output logic [31:0]                  res_t_o,
    output logic [$clog2(WORDS)-1:0]     res_tri_o
);
    localparam int AW = $clog2(WORDS);
    localparam int KW = $clog2(MAX_LIST);

    // ---------------------------------------------------------------- memory and ports
    // The controller writes and reads the memory while the PE is idle; while it executes a
    // ray the PE reads its ref words and records. A PE that shares its pipeline issues in
    // cycles c that are multiples of ISSUE_INTERVAL and reads a test's ref word in c+1, so
    // one read port serves all reads: its record in c+4 (interval 2: 16 banks, the whole
    // record), or its three parts in c+4, c+6 and c+7 (interval 4: 4 banks). A PE with a
    // pipeline of its own reads both in every cycle, the ref word on the memory's word port.
    localparam bit WORD_PORT = ISSUE_INTERVAL == 1;
    localparam bit PARTED = ISSUE_INTERVAL == 4;
    localparam int RD_WORDS = PARTED ? 4 : 10;
    if (PARTED ? (PARTS != 3 || PART_W != 128) : (PARTS != ISSUE_INTERVAL || PART_W * PARTS != 288)) begin : g_bad_parts
        $error("pe: PARTS and PART_W do not match ISSUE_INTERVAL");
    end
    logic          active_q, active_d;     // executing a ray: the issue loop reads the memory
    logic [AW-1:0] x_a_addr_q, x_a_addr_d, x_b_addr, x_b_addr4, x_b_addr8;
    logic          iss_valid_q, iss_valid_d;  // an issue in the last cycle: its ref word is read now
    logic          rd_part0, rd_part1, rd_part2;   // PARTED: the record's three reads now
    logic [31:0]   w_rdata, r_word, ref_word;
    logic [32*RD_WORDS-1:0] r_window;      // a record (9 coordinates, prim) or a part of one
    logic [AW-1:0] r_addr;
    always_comb begin
        if (!active_q) r_addr = c_a_addr_i;
        else if (!WORD_PORT && iss_valid_q) r_addr = x_a_addr_q;
        else if (PARTED && rd_part1) r_addr = x_b_addr4;
        else if (PARTED && rd_part2) r_addr = x_b_addr8;
        else r_addr = x_b_addr;
    end
    // The controller's writes are registered here first, so its data bus fans out to four
    // registers instead of every block RAM of every PE (nothing reads a word in the cycles
    // after the controller writes it: writes are LOAD_PE's). The word port's address is not
    // delayed: it reads.
    logic [AW-1:0] w_addr_q;
    logic          w_en_q;
    logic [31:0]   w_data_q;
    always_ff @(posedge clk_i) if (en_i) begin
        w_addr_q <= c_a_addr_i;
        w_en_q <= !active_q && c_a_we_i && !rst_i;
        w_data_q <= c_a_wdata_i;
    end
    if (PE_CACHE != 0) begin : g_cache
        if (!PARTED) begin : g_bad_cache
            $error("pe: PE_CACHE needs ISSUE_INTERVAL 4");
        end
        // The reads the PE uses: the controller's while idle (any cycle it does not write),
        // the ref word and the record's three parts while it executes.
        logic r_valid;
        assign r_valid = active_q ? (iss_valid_q || rd_part0 || rd_part1 || rd_part2) : !c_a_we_i;
        gridrt_pe_cache #(.WORDS(WORDS), .LINES(CACHE_LINES)) u_cache (
            .clk_i, .rst_i, .en_i, .phase_i(pc_phase_i),
            .w_addr_i(w_addr_q), .w_en_i(w_en_q), .w_data_i(w_data_q),
            .r_addr_i(r_addr), .r_valid_i(r_valid), .r_window_o(r_window), .r_word_o(r_word),
            .hold_o(pc_hold_o), .ready_o(pc_ready_o),
            .m_req_o, .m_we_o, .m_addr_o, .m_wdata_o, .m_ack_i, .m_rdata_i);
        assign w_rdata = '0;
    end else begin : g_bram
        gridrt_pe_mem #(.WORDS(WORDS), .BANKS(PARTED ? 4 : 16), .RD_WORDS(RD_WORDS), .WORD_PORT(WORD_PORT)) u_mem (
            .clk_i, .en_i,
            .w_addr_i(WORD_PORT ? (active_q ? x_a_addr_q : c_a_addr_i) : w_addr_q),
            .w_en_i(WORD_PORT ? !active_q && c_a_we_i : w_en_q), .w_data_i(WORD_PORT ? c_a_wdata_i : w_data_q),
            .w_rdata_o(w_rdata), .r_addr_i(r_addr), .r_window_o(r_window), .r_word_o(r_word));
        assign pc_hold_o = 1'b0;
        assign pc_ready_o = 1'b1;
        assign m_req_o = 1'b0;
        assign m_we_o = 1'b0;
        assign m_addr_o = '0;
        assign m_wdata_o = '0;
    end
    // The single-word read: the controller's reads and the PE's ref words (the same port).
    assign ref_word = WORD_PORT ? w_rdata : r_word;
    assign a_rdata_o = ref_word;

    // ---------------------------------------------------------------- entry queue
    logic [KW+2*AW-1:0] q_mem [MAX_LIST];
    logic [KW+2*AW-1:0] q_rdata;
    logic [KW:0]        q_n_q, q_raddr_q, q_n_d, q_raddr_d;
    logic [31:0]        hi_mem [MAX_LIST];
    always_ff @(posedge clk_i) if (en_i) begin
        if (q_push_i) begin
            q_mem[q_n_q[KW-1:0]] <= {q_k_i, q_first_i, q_count_i};
            hi_mem[q_k_i] <= q_hi_i;
        end
        q_rdata <= q_mem[q_raddr_q[KW-1:0]];
    end

    // ---------------------------------------------------------------- issue loop
    // An entry's setup is S_SETUP (SETUP - 1 cycles) then S_TAKE; S_GAP follows every issue
    // for the rest of the issue interval. `phase_q` counts the cycles spent in a state.
    localparam int SETUP = (ISSUE_INTERVAL > 2) ? ISSUE_INTERVAL : 2;
    typedef enum logic [2:0] { S_IDLE, S_SETUP, S_TAKE, S_ISSUE, S_GAP } state_t;
    state_t        state_q, state_d;
    logic [1:0]    phase_q, phase_d;
    logic [KW-1:0] cur_k_q, cur_k_d;
    logic [AW-1:0] cur_first_q, cur_count_q, cur_i_q, cur_first_d, cur_count_d, cur_i_d;
    logic          epoch_q, epoch_d;
    logic [31:0]   issued_q, issued_d;
    assign issued_o = issued_q;
    logic          iss_more_q, iss_more_d;   // the current entry has tests left to issue
    logic          iss_last_q, iss_last_d;
    logic [KW-1:0] iss_k_q, iss_k_d;
    always_comb begin
        logic more;
        state_d = state_q;
        active_d = active_q;
        q_n_d = q_n_q;
        q_raddr_d = q_raddr_q;
        epoch_d = epoch_q;
        issued_d = issued_q;
        cur_k_d = cur_k_q;
        cur_first_d = cur_first_q;
        cur_count_d = cur_count_q;
        cur_i_d = cur_i_q;
        iss_last_d = iss_last_q;
        iss_k_d = iss_k_q;
        x_a_addr_d = x_a_addr_q;
        iss_more_d = iss_more_q;
        iss_valid_d = 1'b0;
        phase_d = phase_q + 2'd1;
        more = cur_i_q != cur_count_q - 1'b1;
        if (rst_i) begin
            state_d = S_IDLE;
            active_d = 1'b0;
            q_n_d = '0;
            q_raddr_d = '0;
            epoch_d = 1'b0;
            issued_d = 32'd0;
        end else begin
            if (ray_begin_i) begin
                q_n_d = '0;
                q_raddr_d = '0;
            end else if (q_push_i) begin
                q_n_d = q_n_q + 1'b1;
            end
            if (start_i) begin
                state_d = S_SETUP;
                phase_d = '0;
                active_d = 1'b1;
                epoch_d = !epoch_q;
                issued_d = 32'd0;
            end else if (stop_i) begin
                state_d = S_IDLE;
                active_d = 1'b0;
                q_raddr_d = '0;
            end else begin
                unique case (state_q)
                    S_SETUP: if (phase_q == 2'(SETUP - 2)) state_d = S_TAKE;
                    S_TAKE: begin
                        phase_d = '0;
                        if (q_raddr_q == q_n_q) begin
                            state_d = S_IDLE;
                        end else begin
                            {cur_k_d, cur_first_d, cur_count_d} = q_rdata;
                            cur_i_d = '0;
                            q_raddr_d = q_raddr_q + 1'b1;
                            if (q_rdata[AW-1:0] == 0) begin
                                state_d = S_SETUP;   // done (pend, below)
                            end else begin
                                state_d = S_ISSUE;
                            end
                        end
                    end
                    S_ISSUE: begin
                        iss_valid_d = 1'b1;
                        iss_last_d = !more;
                        iss_k_d = cur_k_q;
                        x_a_addr_d = ref_off_i + cur_first_q + cur_i_q;
                        issued_d = issued_q + 1;
                        cur_i_d = cur_i_q + 1'b1;
                        iss_more_d = more;
                        phase_d = '0;
                        if (ISSUE_INTERVAL > 1) state_d = S_GAP;
                        else if (!more) state_d = S_SETUP;
                    end
                    S_GAP: begin
                        if (phase_q == 2'(ISSUE_INTERVAL - 2)) begin
                            state_d = iss_more_q ? S_ISSUE : S_SETUP;
                            phase_d = '0;
                        end
                    end
                    default: ;
                endcase
            end
        end
    end

    always_ff @(posedge clk_i) if (en_i) begin
        state_q <= state_d;
        phase_q <= phase_d;
        active_q <= active_d;
        q_n_q <= q_n_d;
        q_raddr_q <= q_raddr_d;
        epoch_q <= epoch_d;
        issued_q <= issued_d;
        cur_k_q <= cur_k_d;
        cur_first_q <= cur_first_d;
        cur_count_q <= cur_count_d;
        cur_i_q <= cur_i_d;
        iss_valid_q <= iss_valid_d;
        iss_last_q <= iss_last_d;
        iss_k_q <= iss_k_d;
        x_a_addr_q <= x_a_addr_d;
        iss_more_q <= iss_more_d;
    end
    // A test issued in cycle c presents its ref address (x_a_addr_q) and its tag in cycle c+1;
    // the ref word arrives in c+3, the record's address is read in c+4 (and c+6, c+7) and its
    // window arrives two cycles after each read (pe_mem).
    logic [KW+1:0] tag_p2;
    logic          v_p2;
    gridrt_delay #(.W(KW+3), .N(2)) u_dp2 (.clk_i, .en_i(en_i), .d_i({iss_valid_q, epoch_q, iss_last_q, iss_k_q}), .q_o({v_p2, tag_p2}));
    logic [AW-1:0] ref_tri;
    assign ref_tri = ref_word[AW-1:0];
    // Record t at WORDS - 10 (t + 1) (the controller stacks them from the top down).
    always_ff @(posedge clk_i) if (en_i) begin
        if (v_p2) begin
            x_b_addr <= AW'(WORDS - 10) - (AW'(ref_tri) << 3) - (AW'(ref_tri) << 1);
            x_b_addr4 <= AW'(WORDS - 6) - (AW'(ref_tri) << 3) - (AW'(ref_tri) << 1);
            x_b_addr8 <= AW'(WORDS - 2) - (AW'(ref_tri) << 3) - (AW'(ref_tri) << 1);
        end
    end

    // The test's tag (epoch, last of entry, entry k, triangle, prim id) waits here for its
    // result: it enters the delay line in the cycle the last part is registered for t_*.
    localparam int TAG_W = 2 + KW + AW + 32;
    logic             tag_in_valid;
    logic [TAG_W-1:0] tag_in;
    if (PARTED) begin : g_parts_read
        // Reads in c+4, c+6, c+7; the parts arrive in c+6, c+8, c+9 and go out a cycle later
        // (v_pN: valid in cycle c+N+1).
        logic          v_p3, v_p5, v_p6, v_p7, v_p8;
        logic [KW+1:0] tag_p8;
        logic [AW-1:0] tri_p8;
        gridrt_delay #(.W(1), .N(1)) u_d3 (.clk_i, .en_i(en_i), .d_i(v_p2), .q_o(v_p3));
        gridrt_delay #(.W(1), .N(2)) u_d5 (.clk_i, .en_i(en_i), .d_i(v_p3), .q_o(v_p5));
        gridrt_delay #(.W(1), .N(1)) u_d6 (.clk_i, .en_i(en_i), .d_i(v_p5), .q_o(v_p6));
        gridrt_delay #(.W(1), .N(2)) u_d7 (.clk_i, .en_i(en_i), .d_i(v_p5), .q_o(v_p7));
        gridrt_delay #(.W(1), .N(2)) u_d8 (.clk_i, .en_i(en_i), .d_i(v_p6), .q_o(v_p8));
        gridrt_delay #(.W(KW+2+AW), .N(6)) u_dtag (.clk_i, .en_i(en_i), .d_i({tag_p2, ref_tri}), .q_o({tag_p8, tri_p8}));
        assign rd_part0 = v_p3;
        assign rd_part1 = v_p5;
        assign rd_part2 = v_p6;
        always_ff @(posedge clk_i) if (en_i) begin
            t_valid_o <= v_p5 || v_p7 || v_p8;
            t_part_o <= v_p5 ? 2'd0 : (v_p7 ? 2'd1 : 2'd2);
            t_chunk_o <= r_window;
        end
        // Part 2 is the record's words 8 and 9: the last coordinate and the prim id.
        assign tag_in_valid = v_p8;
        assign tag_in = {tag_p8, tri_p8, r_window[63:32]};
    end else begin : g_record_read
        // Read in c+4, the window in c+6; its parts go out in c+7 .. c+6+PARTS (the window
        // holds for one cycle: the parts after the first wait in rec_rest, and the last goes
        // out before the next test's window arrives, PARTS <= ISSUE_INTERVAL).
        logic [KW+1:0] tag_p5;
        logic [AW-1:0] tri_p5;
        logic          v_p5;
        logic [287:0]  rec_rest;
        logic [1:0]    part_next;
        gridrt_delay #(.W(KW+3+AW), .N(3)) u_dp5 (.clk_i, .en_i(en_i), .d_i({v_p2, tag_p2, ref_tri}), .q_o({v_p5, tag_p5, tri_p5}));
        assign rd_part0 = 1'b0;
        assign rd_part1 = 1'b0;
        assign rd_part2 = 1'b0;
        always_ff @(posedge clk_i) if (en_i) begin
            t_valid_o <= v_p5 || part_next != 0;
            if (v_p5) begin
                t_part_o <= 2'd0;
                t_chunk_o <= r_window[PART_W-1:0];
                rec_rest <= r_window[287:0] >> PART_W;
                part_next <= (PARTS > 1) ? 2'd1 : 2'd0;
            end else if (part_next != 0) begin
                t_part_o <= part_next;
                t_chunk_o <= rec_rest[PART_W-1:0];
                rec_rest <= rec_rest >> PART_W;
                part_next <= (part_next == 2'(PARTS - 1)) ? 2'd0 : part_next + 2'd1;
            end
            if (rst_i) part_next <= '0;
        end
        assign tag_in_valid = v_p5;
        assign tag_in = {tag_p5, tri_p5, r_window[32*9 +: 32]};
    end
    logic [TAG_W-1:0] r_tag;
    localparam int TAG_DELAY = RESULT_LATENCY + (PARTED ? 1 : PARTS);
    gridrt_delay_ram #(.W(TAG_W), .N(TAG_DELAY)) u_tag (.clk_i, .en_i, .d_i(tag_in), .q_o(r_tag));
`ifndef SYNTHESIS
    // Every result comes TAG_DELAY cycles after its test's tag entered u_tag, when the tag
    // comes out (checked from TAG_DELAY cycles after a reset on: a reset may drop the tests
    // in flight).
    logic r_expected;
    int   settled_q;
    gridrt_delay #(.W(1), .N(TAG_DELAY)) u_expected (.clk_i, .en_i(en_i), .d_i(tag_in_valid), .q_o(r_expected));
    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) settled_q <= 0;
        else if (settled_q <= TAG_DELAY) settled_q <= settled_q + 1;
    end
    ResultLatency: assert property (@(posedge clk_i) disable iff (!en_i || rst_i || settled_q <= TAG_DELAY)
        r_valid_i == r_expected)
        else $fatal(1, "gridrt_pe: a result not RESULT_LATENCY cycles after its test");
`endif

    // ---------------------------------------------------------------- result stage
    // R0: register, read the entry's hi bound.
    logic          r0_valid, r0_hit, r0_last;
    logic [KW-1:0] r0_k;
    logic [AW-1:0] r0_tri;
    logic [31:0]   r0_t, r0_prim, r0_hi;
    always_ff @(posedge clk_i) if (en_i) begin
        r0_valid <= r_valid_i && active_q && r_tag[TAG_W-1] == epoch_q;
        r0_hit <= r_kind_i == 2'd1;
        {r0_last, r0_k} <= r_tag[TAG_W-2 -: KW+1];
        r0_tri <= r_tag[32 +: AW];
        r0_prim <= r_tag[31:0];
        r0_t <= r_t_i;
        r0_hi <= hi_mem[r_tag[TAG_W-3 -: KW]];
    end

    // R1: the acceptance rule 0 < t < t_max and t <= hi (t is positive and finite).
    logic          r1_valid, r1_acc, r1_last;
    logic [KW-1:0] r1_k;
    logic [AW-1:0] r1_tri;
    logic [31:0]   r1_t, r1_prim;
    always_ff @(posedge clk_i) if (en_i) begin
        r1_valid <= r0_valid && active_q;
        r1_acc <= r0_hit && !t_max_i[31] && r0_t[30:0] < t_max_i[30:0] && !r0_hi[31] && r0_t[30:0] <= r0_hi[30:0];
        r1_last <= r0_last;
        r1_k <= r0_k;
        r1_tri <= r0_tri;
        r1_t <= r0_t;
        r1_prim <= r0_prim;
    end

    // R2: the entry's winner. Closest: smallest t, ties to the lowest prim id, reported
    // after the entry's last test. Any: the first accepted test, reported at once.
    logic          best_valid, resolved;
    logic [31:0]   best_t, best_prim;
    logic [AW-1:0] best_tri;
    logic [31:0]   res_t_mem [MAX_LIST];
    logic [AW-1:0] res_tri_mem [MAX_LIST];
    logic          ev1_valid, ev1_hit;   // an entry done (its k: ev1_k)
    logic [KW-1:0] ev1_k;
    always_ff @(posedge clk_i) if (en_i) begin
        logic          take, emit, hit;
        logic [31:0]   t_out;
        logic [AW-1:0] tri_out;
        ev1_valid <= 1'b0;
        take = 1'b0;
        emit = 1'b0;
        hit = 1'b0;
        t_out = best_t;
        tri_out = best_tri;
        if (start_i) begin
            best_valid <= 1'b0;
            resolved <= 1'b0;
        end else if (r1_valid && active_q) begin
            if (any_i) begin
                if (r1_acc && !resolved) begin
                    emit = 1'b1;
                    hit = 1'b1;
                    t_out = r1_t;
                    tri_out = r1_tri;
                end else if (r1_last && !resolved) begin
                    emit = 1'b1;
                end
                resolved <= r1_last ? 1'b0 : (resolved || r1_acc);
            end else begin
                take = r1_acc && (!best_valid || r1_t < best_t || (r1_t == best_t && r1_prim < best_prim));
                if (r1_last) begin
                    emit = 1'b1;
                    hit = best_valid || take;
                    t_out = take ? r1_t : best_t;
                    tri_out = take ? r1_tri : best_tri;
                    best_valid <= 1'b0;
                end else if (take) begin
                    best_valid <= 1'b1;
                    best_t <= r1_t;
                    best_prim <= r1_prim;
                    best_tri <= r1_tri;
                end
            end
        end
        if (emit) begin
            ev1_valid <= 1'b1;
            ev1_k <= r1_k;
            ev1_hit <= hit;
            res_t_mem[r1_k] <= t_out;
            res_tri_mem[r1_k] <= tri_out;
        end
        res_t_o <= res_t_mem[res_k_i];
        res_tri_o <= res_tri_mem[res_k_i];
    end

    // ---------------------------------------------------------------- open and hit entries
    // The arbiter needs the first list entry that is not done and the first that hit; each
    // PE reports its own, and the controller takes the minimum over the PEs. A PE's entries
    // are in list order: the untaken ones follow the taken ones; an entry without tests is
    // done when it is taken, the others in order (`pend`, the taken entries with tests not
    // done yet), at their result stage's event, and so are their hits. So the PE's first
    // open entry is the oldest in `pend`, else the untaken one at q_raddr_q, and its first hit
    // is the first event with a hit. Both count this cycle's events (the entry of an event
    // in ev1 is done now), like the map bits the arbiter used to keep per entry.
    // More than the entries in flight: a test's latency (≈ 70 cycles) over the 3 cycles an
    // entry with tests takes at least (voxel setup 2, one issue).
    localparam int PEND = 32;
    logic [KW-1:0]       qk_mem [MAX_LIST];     // entry k of queue index i
    logic [KW-1:0]       head_k, next_k;        // k at q_raddr_q and q_raddr_q + 1, a cycle late
    logic                took;                  // q_raddr_q moved on last cycle
    logic [KW-1:0]       pend_mem [PEND];
    logic [$clog2(PEND)-1:0] pend_rd, pend_wr;
    logic [$clog2(PEND):0]   pend_n;
    always_ff @(posedge clk_i) if (en_i) begin
        if (q_push_i) qk_mem[q_n_q[KW-1:0]] <= q_k_i;
        head_k <= qk_mem[q_raddr_q[KW-1:0]];
        next_k <= qk_mem[KW'(q_raddr_q[KW-1:0] + 1'b1)];
        took <= state_q == S_TAKE && q_raddr_q != q_n_q && !start_i && !stop_i;
    end
    logic pend_push, pend_pop;
    always_comb begin
        pend_push = state_q == S_TAKE && q_raddr_q != q_n_q && q_rdata[AW-1:0] != 0 && !start_i && !stop_i;
        pend_pop = ev1_valid && pend_n != 0;
    end
    always_ff @(posedge clk_i) if (en_i) begin
        if (pend_push) pend_mem[pend_wr] <= q_rdata[KW+2*AW-1 -: KW];
        if (rst_i || start_i) begin
            pend_rd <= '0;
            pend_wr <= '0;
            pend_n <= '0;
        end else begin
            pend_wr <= pend_wr + $clog2(PEND)'(pend_push);
            pend_rd <= pend_rd + $clog2(PEND)'(pend_pop);
            pend_n <= pend_n + ($clog2(PEND)+1)'(pend_push) - ($clog2(PEND)+1)'(pend_pop);
        end
    end
`ifndef SYNTHESIS
    // Bounds of pend: never full (sized above the entries in flight), no pop when empty.
    PendNeverFull: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) pend_n != ($clog2(PEND)+1)'(PEND))
        else $fatal(1, "gridrt_pe: more entries in flight than pend holds");
    PendPopNotEmpty: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) pend_pop |-> pend_n != 0)
        else $fatal(1, "gridrt_pe: pop from an empty pend");
`endif
    always_ff @(posedge clk_i) if (en_i) begin
        logic [KW:0] open_now;
        if (ev1_valid ? pend_n > 1 : pend_n != 0)
            open_now = {1'b0, pend_mem[ev1_valid ? pend_rd + 1'b1 : pend_rd]};
        else if (q_raddr_q != q_n_q)
            open_now = {1'b0, took ? next_k : head_k};
        else
            open_now = (KW+1)'(MAX_LIST);
        open_k_o <= open_now;
        if (start_i) hit_k_o <= (KW+1)'(MAX_LIST);
        else if (ev1_valid && ev1_hit && hit_k_o == (KW+1)'(MAX_LIST)) hit_k_o <= {1'b0, ev1_k};
    end
endmodule
