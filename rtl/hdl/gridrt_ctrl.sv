// gridrt_ctrl: the co-processor's protocol engine (SPEC.md §4, rtl/README.md §4.1).
//
// Receives request words, checks them in the model's order (`gridrt_coproc::coproc` module
// doc: content checks of a word before its framing check; the first violation answers with
// one ERROR word, then words are discarded up to the next control bit), and runs the packet:
// LOAD_PE streams the image into the PE's memory while validating it and converting each
// triangle (tri_loader); FRAME sets the fixed-point frame; CLEAR empties the PEs; a ray
// looks up each list entry's voxel as it arrives, then runs the ray setup, starts the PEs,
// arbitrates in list order and sends the RESULT. Replies go through a 16-word output FIFO;
// the request stream stalls (s_tready low) while a packet executes or the FIFO lacks room.
module gridrt_ctrl #(
    parameter int PES = 4,
    parameter int WORDS = 16384,
    parameter int MAX_LIST = 256
) (
    input  logic                        clk_i,
    input  logic                        en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                        rst_i,
    // Request stream (FSL: tlast = control bit).
    input  logic [31:0]                 s_tdata_i,
    input  logic                        s_tlast_i,
    input  logic                        s_tvalid_i,
    output logic                        s_tready_o,
    // Response stream.
    output logic [31:0]                 m_tdata_o,
    output logic                        m_tlast_o,
    output logic                        m_tvalid_o,
    input  logic                        m_tready_i,
    output logic                        idle_o,
    // PE memories (controller side).
    output logic [PES-1:0][$clog2(WORDS)-1:0] pe_a_addr_o,
    output logic [PES-1:0]              pe_a_we_o,
    output logic [31:0]                 pe_a_wdata_o,
    input  logic [PES-1:0][31:0]        pe_a_rdata_i,
    output logic [PES-1:0][$clog2(WORDS)-1:0] pe_ref_off_o,
    // Entry queues.
    output logic                        pe_ray_begin_o,
    output logic [PES-1:0]              pe_q_push_o,
    output logic [$clog2(MAX_LIST)-1:0] pe_q_k_o,
    output logic [$clog2(WORDS)-1:0]    pe_q_first_o,
    output logic [$clog2(WORDS)-1:0]    pe_q_count_o,
    output logic [31:0]                 pe_q_hi_o,
    // Execution.
    output logic                        pe_start_o,
    output logic                        pe_stop_o,
    output logic                        pe_any_o,
    output logic [31:0]                 pe_t_max_o,
    output logic [2:0][33:0]            pe_origin_o,
    output logic [1:0]                  pe_kz_o,
    output logic signed [24:0]          pe_sx_o, pe_sy_o,
    output logic                        pe_dz_neg_o,
    output logic [23:0]                 pe_dz_abs_o,
    output logic signed [9:0]           pe_texp_o,
    output logic                        pe_ray_overflow_o,
    input  logic [PES-1:0][31:0]        pe_issued_i,
    input  logic [PES-1:0][$clog2(MAX_LIST):0] pe_open_k_i,  // each PE's first open entry
    input  logic [PES-1:0][$clog2(MAX_LIST):0] pe_hit_k_i,   // and first hit (MAX_LIST: none)
    output logic [$clog2(MAX_LIST)-1:0] pe_res_k_o,
    input  logic [PES-1:0][31:0]        pe_res_t_i,
    input  logic [PES-1:0][$clog2(WORDS)-1:0] pe_res_tri_i
);
    localparam int AW = $clog2(WORDS);
    localparam int KW = $clog2(MAX_LIST);
    localparam int PW = (PES > 1) ? $clog2(PES) : 1;

    // Opcodes (SPEC §4.1) and error codes (§4.5).
    localparam logic [3:0] OP_LOAD = 4'h1, OP_CLOSEST = 4'h2, OP_ANY = 4'h3, OP_CLEAR = 4'h4, OP_FRAME = 4'h5;
    localparam logic [11:0] E_UNKNOWN_OPCODE = 12'd1, E_TOO_SHORT = 12'd2, E_MISSING_CONTROL = 12'd3,
        E_PE_RANGE = 12'd4, E_VOXEL_NOT_LOADED = 12'd6, E_LIST_TOO_LONG = 12'd7, E_MEM_OVERFLOW = 12'd8,
        E_MALFORMED = 12'd9, E_NOT_LOADED = 12'd10, E_NON_FINITE = 12'd11, E_BAD_FRAME = 12'd12,
        E_UNSUPPORTED = 12'd13;
    localparam logic [31:0] PE_IMAGE_TAG = 32'hFFFF_0002;

    // Registered outputs to the PEs.
    logic [PES-1:0] pe_a_we_q, pe_a_we_d;
    assign pe_a_we_o = pe_a_we_q;
    logic [31:0] pe_a_wdata_q, pe_a_wdata_d;
    assign pe_a_wdata_o = pe_a_wdata_q;
    logic [PES-1:0] pe_q_push_q, pe_q_push_d;
    assign pe_q_push_o = pe_q_push_q;
    logic [$clog2(MAX_LIST)-1:0] pe_q_k_q, pe_q_k_d;
    assign pe_q_k_o = pe_q_k_q;
    logic [$clog2(WORDS)-1:0] pe_q_first_q, pe_q_first_d;
    assign pe_q_first_o = pe_q_first_q;
    logic [$clog2(WORDS)-1:0] pe_q_count_q, pe_q_count_d;
    assign pe_q_count_o = pe_q_count_q;
    logic [31:0] pe_q_hi_q, pe_q_hi_d;
    assign pe_q_hi_o = pe_q_hi_q;
    logic  pe_ray_begin_q, pe_ray_begin_d;
    assign pe_ray_begin_o = pe_ray_begin_q;
    logic  pe_start_q, pe_start_d;
    assign pe_start_o = pe_start_q;
    logic  pe_stop_q, pe_stop_d;
    assign pe_stop_o = pe_stop_q;
    logic  pe_any_q, pe_any_d;
    assign pe_any_o = pe_any_q;
    logic [31:0] pe_t_max_q, pe_t_max_d;
    assign pe_t_max_o = pe_t_max_q;
    logic [$clog2(MAX_LIST)-1:0] pe_res_k_q, pe_res_k_d;
    assign pe_res_k_o = pe_res_k_q;

    // ================================================================ output FIFO
    // Replies wait here (gridrt_ctrl_out_fifo); the FSM pushes at most one word per cycle.
    logic        push_q;
    logic push_d;
    logic [32:0] push_word_q;
    logic [32:0] push_word_d;
    logic [4:0]  f_count;
    gridrt_ctrl_out_fifo #(.DEPTH(16)) u_out_fifo (
        .clk_i, .en_i, .rst_i, .push_i(push_q), .push_word_i(push_word_q),
        .m_tdata_o, .m_tlast_o, .m_tvalid_o, .m_tready_i, .count_o(f_count));

    // ================================================================ state
    typedef enum logic [2:0] { RX_IDLE, RX_DISCARD, RX_LOAD_COUNT, RX_LOAD_WORDS, RX_RAY, RX_FRAME } rx_t;
    typedef enum logic [3:0] {
        BZ_NONE, BZ_LOOKUP, BZ_HI, BZ_TRI, BZ_LOAD_FINISH, BZ_FRAME, BZ_SETUP, BZ_EXEC, BZ_RESULT
    } busy_t;
    rx_t   rx_q;
    rx_t rx_d;
    busy_t busy_q;
    busy_t busy_d;
    logic  word_ctl_q;        // control bit of the word that caused the busy phase
    logic word_ctl_d;
    logic [15:0] word_idx_q;  // its index in the packet
    logic [15:0] word_idx_d;

    assign s_tready_o = busy_q == BZ_NONE && f_count <= 5'd7 && !rst_i;
    assign idle_o = busy_q == BZ_NONE && f_count == 0 && !push_q;
    logic accept;
    assign accept = s_tvalid_i && s_tready_o;

    // Per-PE image layout. Per-PE values indexed by a variable PE number are unpacked
    // arrays: an index into a packed array of 14-bit elements costs a multiplier for the bit
    // offset (Yosys gave it a MULT18X18D on the path to every PE's address register).
    logic [PES-1:0]         loaded_q;
    logic [PES-1:0] loaded_d;
    logic [AW-1:0]          pe_voxels_q [PES], pe_tri_off_q [PES];
    logic [AW-1:0] pe_voxels_d [PES], pe_tri_off_d [PES];
    logic [AW-1:0]          a_addr_q [PES], ref_off_q [PES], res_tri_in [PES];
    logic [AW-1:0] a_addr_d [PES], ref_off_d [PES];
    for (genvar p = 0; p < PES; p++) begin : g_pe_ports
        assign pe_a_addr_o[p] = a_addr_q[p];
        assign pe_ref_off_o[p] = ref_off_q[p];
        assign res_tri_in[p] = pe_res_tri_i[p];
    end

    // Frame (reset: identity, s = 0, min = 0).
    logic signed [9:0]  frame_s;
    logic [2:0][54:0]   frame_qm;
    logic [2:0]         frame_huge;
    logic [5:0][31:0]   frame_box;      // FRAME's box: min xyz, max xyz

    // ================================================================ helpers
    function automatic [31:0] err_word(input [11:0] code, input [15:0] detail);
        err_word = {4'hE, code, detail};
    endfunction
    function automatic is_finite(input [31:0] f);
        is_finite = f[30:23] != 8'hFF;
    endfunction
    function automatic is_nan(input [31:0] f);
        is_nan = f[30:23] == 8'hFF && f[22:0] != 0;
    endfunction

    // ================================================================ ray request registers
    logic              ray_any_q;
    logic ray_any_d;
    logic [15:0]       ray_count_q;      // list entries n
    logic [15:0] ray_count_d;
    logic [15:0]       ray_idx_q;        // index of the next word in the packet
    logic [15:0] ray_idx_d;
    logic [2:0][31:0]  ray_org_q, ray_dir_q;
    logic [2:0][31:0] ray_org_d, ray_dir_d;
    logic [31:0]       ray_tmax_q;
    logic [31:0] ray_tmax_d;
    logic [KW-1:0]     ent_k_q;          // entry being received
    logic [KW-1:0] ent_k_d;
    logic              ent_last_q;       // ent_k is the list's last entry (registered)
    logic ent_last_d;
    logic [PW-1:0]     ent_pe_q;
    logic [PW-1:0] ent_pe_d;
    logic [23:0]       ent_voxel_q;
    logic [23:0] ent_voxel_d;
    logic [AW-1:0]     ent_first_q, ent_count_q;
    logic [AW-1:0] ent_first_d, ent_count_d;
    logic [31:0]       ent_texit_q;
    logic [31:0] ent_texit_d;

    // Lookup (binary search of the voxel table, entries at 5 + 3i: id, first, count).
    logic [AW:0]  lk_lo_q, lk_hi_q, lk_mid_q;
    logic [AW:0] lk_lo_d, lk_hi_d, lk_mid_d;
    logic [3:0]   lk_step_q;
    logic [3:0] lk_step_d;

    // t_exit slack: hi = fl32(t_exit * (1 + 2^-12)).
    logic        hi_in_q, hi_out;
    logic hi_in_d;
    logic [31:0] hi_y;
    gridrt_f32_mul u_hi (.clk_i, .en_i, .in_valid_i(hi_in_q), .a_i(ent_texit_q), .b_i(32'h3F80_0800), .out_valid_o(hi_out), .y_o(hi_y));

    // ================================================================ loader
    logic [PW-1:0]  ld_pe_q;
    logic [PW-1:0] ld_pe_d;
    logic [AW:0]    ld_n_q;           // declared image words (<= WORDS)
    logic [AW:0] ld_n_d;
    logic [AW:0]    ld_i_q;           // image index of the next word
    logic [AW:0] ld_i_d;
    logic [31:0]    ld_t_q, ld_v_q, ld_r_q, ld_p_q;
    logic [31:0] ld_t_d, ld_v_d, ld_r_d, ld_p_d;
    logic [37:0]    ld_vox_end_q, ld_ref_end_q, ld_tri_end_q, ld_need_q;
    logic [37:0] ld_vox_end_d, ld_ref_end_d, ld_tri_end_d, ld_need_d;
    logic           ld_tag_ok_q, ld_bad_q, ld_have_prev_q;
    logic ld_tag_ok_d, ld_bad_d, ld_have_prev_d;
    logic [31:0]    ld_prev_id_q, ld_first_q;
    logic [31:0] ld_prev_id_d, ld_first_d;
    logic [1:0]     ld_sub3_q;
    logic [1:0] ld_sub3_d;
    logic [3:0]     ld_sub11_q, ld_sub16_q;
    logic [3:0] ld_sub11_d, ld_sub16_d;
    logic [AW:0]    ld_tri_base_q;    // image index of the current triangle
    logic [AW:0] ld_tri_base_d;
    logic signed [AW+1:0] ld_rec_addr_q;  // the next record's address: WORDS - 10 (triangles seen + 1)
    logic signed [AW+1:0] ld_rec_addr_d;
    logic [8:0][31:0] ld_v9_q;
    logic [8:0][31:0] ld_v9_d;
    logic [31:0]    ld_prim_q;
    logic [31:0] ld_prim_d;
    logic           ld_last_q;        // the triangle being processed ended the image
    logic ld_last_d;
    logic           tl_start_q, tl_done;
    logic tl_start_d;
    logic [8:0][31:0] tl_coord;
    logic [2:0][31:0] tl_normal;
    logic [3:0]     tl_wr_q;          // record and normal words written so far (tri_step)
    logic [3:0] tl_wr_d;
    gridrt_tri_loader u_tri (.clk_i, .en_i, .start_i(tl_start_q), .v_i(ld_v9_q), .frame_s_i(frame_s), .frame_qm_i(frame_qm), .frame_huge_i(frame_huge),
                      .done_o(tl_done), .coord_o(tl_coord), .normal_o(tl_normal));

    // ================================================================ frame computation
    // The FRAME packet's box goes to gridrt_ctrl_frame word by word; at its last word the box
    // is checked (frame_bad: 0, or ERROR 12's detail) and, if it is good and the packet ends
    // there, the computation starts (the FRAME phase; frame_done at its last step).
    logic        frame_box_we, frame_start, frame_done;
    logic [15:0] frame_bad;
    always_comb begin
        logic [191:0] box;
        frame_box_we = accept && rx_q == RX_FRAME;
        box = {s_tdata_i, frame_box[4], frame_box[3], frame_box[2], frame_box[1], frame_box[0]};
        frame_bad = 16'd0;
        for (int i = 5; i >= 0; i--) if (!is_finite(box[32*i +: 32])) frame_bad = 16'(i + 1);
        if (frame_bad == 0) begin
            for (int a = 2; a >= 0; a--)
                if (f32_lt(box[32*(3 + a) +: 32], box[32*a +: 32])) frame_bad = 16'(4 + a);
        end
        frame_start = frame_box_we && ray_idx_q == 16'd6 && frame_bad == 0 && s_tlast_i;
    end
    gridrt_ctrl_frame u_frame (
        .clk_i, .en_i, .rst_i, .box_we_i(frame_box_we), .box_idx_i(3'(ray_idx_q - 16'd1)), .box_word_i(s_tdata_i),
        .box_o(frame_box), .start_i(frame_start), .run_i(busy_q == BZ_FRAME), .done_o(frame_done),
        .frame_s_o(frame_s), .frame_qm_o(frame_qm), .frame_huge_o(frame_huge));

    // ================================================================ ray setup
    logic rs_start_q, rs_done, rs_overflow;
    logic rs_start_d;
    logic [2:0][33:0] rs_o;
    gridrt_ray_setup u_setup (.clk_i, .en_i, .start_i(rs_start_q), .org_i(ray_org_q), .dir_i(ray_dir_q), .frame_s_i(frame_s), .frame_qm_i(frame_qm), .frame_huge_i(frame_huge),
                       .done_o(rs_done), .o_o(rs_o), .kz_o(pe_kz_o), .sx_o(pe_sx_o), .sy_o(pe_sy_o), .dz_neg_o(pe_dz_neg_o),
                       .dz_abs_o(pe_dz_abs_o), .texp_o(pe_texp_o), .overflow_o(rs_overflow));
    assign pe_origin_o = rs_o;
    assign pe_ray_overflow_o = rs_overflow;

    // ================================================================ arbiter
    logic [31:0]         ray_cnt_q;
    logic [31:0] ray_cnt_d;
    logic [2:0]          ex_step_q;      // exec sub-steps before arbitration
    logic [2:0] ex_step_d;
    logic [KW-1:0]       win_k_q;
    logic [KW-1:0] win_k_d;
    logic [PW-1:0]       win_pe_q;
    logic [PW-1:0] win_pe_d;
    logic                win_hit_q;
    logic win_hit_d;
    logic [15:0]         win_tests_q;
    logic [15:0] win_tests_d;
    logic [3:0]          res_step_q;
    logic [3:0] res_step_d;
    logic [AW-1:0]       res_base_q;     // the winner's triangle (image address)
    logic [AW-1:0] res_base_d;
    logic [AW-1:0]       win_tri_q, win_tri_off_q;  // its local index, its PE's triangle table
    logic [AW-1:0] win_tri_d, win_tri_off_d;
    logic [31:0]         win_t_q;
    logic [31:0] win_t_d;
    logic [PW-1:0]       ent_pe_of [MAX_LIST];  // each entry's PE, written as entries arrive
    logic                ent_pe_of_we;

    // The first open entry and the first hit over all PEs, two cycles late, and the tests
    // issued, three cycles late (gridrt_ctrl_arbiter).
    logic [KW:0] first_hit, first_open;
    logic [34:0] issued_prev2;
    gridrt_ctrl_arbiter #(.PES(PES), .MAX_LIST(MAX_LIST)) u_arbiter (
        .clk_i, .en_i, .pe_open_k_i, .pe_hit_k_i, .pe_issued_i,
        .first_open_o(first_open), .first_hit_o(first_hit), .issued_o(issued_prev2));

    // ================================================================ next state
    // Next state of every register below (the tasks write *_d, read *_q).
    always_comb begin
        logic [3:0]  op;
        logic        ctl;
        logic [31:0] w;
        w = s_tdata_i;
        ctl = s_tlast_i;
        op = w[31:28];
        push_word_d = push_word_q;
        rx_d = rx_q;
        busy_d = busy_q;
        word_ctl_d = word_ctl_q;
        word_idx_d = word_idx_q;
        loaded_d = loaded_q;
        pe_voxels_d = pe_voxels_q;
        pe_tri_off_d = pe_tri_off_q;
        ray_any_d = ray_any_q;
        ray_count_d = ray_count_q;
        ray_idx_d = ray_idx_q;
        ray_org_d = ray_org_q;
        ray_dir_d = ray_dir_q;
        ray_tmax_d = ray_tmax_q;
        ent_k_d = ent_k_q;
        ent_last_d = ent_last_q;
        ent_pe_d = ent_pe_q;
        ent_voxel_d = ent_voxel_q;
        ent_first_d = ent_first_q;
        ent_count_d = ent_count_q;
        ent_texit_d = ent_texit_q;
        lk_lo_d = lk_lo_q;
        lk_hi_d = lk_hi_q;
        lk_mid_d = lk_mid_q;
        lk_step_d = lk_step_q;
        ld_pe_d = ld_pe_q;
        ld_n_d = ld_n_q;
        ld_i_d = ld_i_q;
        ld_t_d = ld_t_q;
        ld_v_d = ld_v_q;
        ld_r_d = ld_r_q;
        ld_p_d = ld_p_q;
        ld_vox_end_d = ld_vox_end_q;
        ld_ref_end_d = ld_ref_end_q;
        ld_tri_end_d = ld_tri_end_q;
        ld_need_d = ld_need_q;
        ld_tag_ok_d = ld_tag_ok_q;
        ld_bad_d = ld_bad_q;
        ld_have_prev_d = ld_have_prev_q;
        ld_prev_id_d = ld_prev_id_q;
        ld_first_d = ld_first_q;
        ld_sub3_d = ld_sub3_q;
        ld_sub11_d = ld_sub11_q;
        ld_sub16_d = ld_sub16_q;
        ld_tri_base_d = ld_tri_base_q;
        ld_rec_addr_d = ld_rec_addr_q;
        ld_v9_d = ld_v9_q;
        ld_prim_d = ld_prim_q;
        ld_last_d = ld_last_q;
        tl_wr_d = tl_wr_q;
        ray_cnt_d = ray_cnt_q;
        ex_step_d = ex_step_q;
        win_k_d = win_k_q;
        win_pe_d = win_pe_q;
        win_hit_d = win_hit_q;
        win_tests_d = win_tests_q;
        res_step_d = res_step_q;
        res_base_d = res_base_q;
        win_tri_d = win_tri_q;
        win_tri_off_d = win_tri_off_q;
        win_t_d = win_t_q;
        a_addr_d = a_addr_q;
        ref_off_d = ref_off_q;
        pe_a_wdata_d = pe_a_wdata_q;
        pe_q_k_d = pe_q_k_q;
        pe_q_first_d = pe_q_first_q;
        pe_q_count_d = pe_q_count_q;
        pe_q_hi_d = pe_q_hi_q;
        pe_any_d = pe_any_q;
        pe_t_max_d = pe_t_max_q;
        pe_res_k_d = pe_res_k_q;
        ent_pe_of_we = 1'b0;
        push_d = 1'b0;
        pe_a_we_d = '0;
        pe_q_push_d = '0;
        pe_ray_begin_d = 1'b0;
        pe_start_d = 1'b0;
        pe_stop_d = 1'b0;
        hi_in_d = 1'b0;
        tl_start_d = 1'b0;
        rs_start_d = 1'b0;
        ray_cnt_d = ray_cnt_q + 1;
        // Registered every cycle, from values that are stable long before they are used
        // (they were the 2-PE design's critical path as enables of begin_exec's registers).
        ent_last_d = 17'(ent_k_q) + 17'd1 == 17'(ray_count_q);
        pe_any_d = ray_any_q;
        pe_t_max_d = ray_tmax_q;
        if (rst_i) begin
            rx_d = RX_IDLE;
            busy_d = BZ_NONE;
            tl_wr_d = 4'd0;
            loaded_d = '0;
        end else if (accept) begin
            // ------------------------------------------------ one request word
            w = s_tdata_i;
            ctl = s_tlast_i;
            op = w[31:28];
            unique case (rx_q)
                RX_IDLE: begin
                    unique case (op)
                        OP_LOAD: begin
                            if (w[7:0] >= 8'(PES)) begin
                                fail(E_PE_RANGE, 16'(w[7:0]), ctl);
                            end else begin
                                ld_pe_d = PW'(w[7:0]);
                                loaded_d[PW'(w[7:0])] = 1'b0;
                                if (ctl) fail(E_TOO_SHORT, 16'd0, 1'b1);
                                else rx_d = RX_LOAD_COUNT;
                            end
                        end
                        OP_CLEAR: begin
                            if (!ctl) begin
                                fail(E_MISSING_CONTROL, 16'd0, 1'b0);
                            end else begin
                                loaded_d = '0;
                                reply({4'h9, OP_CLEAR, 24'd0});
                            end
                        end
                        OP_CLOSEST, OP_ANY: begin
                            if (loaded_q == 0) fail(E_NOT_LOADED, 16'd0, ctl);
                            else if (w[15:0] > 16'(MAX_LIST)) fail(E_LIST_TOO_LONG, 16'(MAX_LIST), ctl);
                            else if (ctl) fail(E_TOO_SHORT, 16'd0, 1'b1);
                            else begin
                                ray_any_d = op == OP_ANY;
                                ray_count_d = w[15:0];
                                ray_idx_d = 16'd1;
                                ent_k_d = '0;
                                pe_ray_begin_d = 1'b1;
                                rx_d = RX_RAY;
                            end
                        end
                        OP_FRAME: begin
                            if (ctl) fail(E_TOO_SHORT, 16'd0, 1'b1);
                            else begin
                                ray_idx_d = 16'd1;
                                rx_d = RX_FRAME;
                            end
                        end
                        default: fail(E_UNKNOWN_OPCODE, 16'(op), ctl);
                    endcase
                end
                RX_DISCARD: if (ctl) rx_d = RX_IDLE;
                RX_LOAD_COUNT: begin
                    if (w > 32'(WORDS)) begin
                        fail(E_MEM_OVERFLOW, 16'(ld_pe_q), ctl);
                    end else if (w == 0) begin
                        if (!ctl) fail(E_MISSING_CONTROL, 16'd1, 1'b0);
                        else begin
                            // An empty image: loaded_q, no voxels.
                            loaded_d[ld_pe_q] = 1'b1;
                            pe_voxels_d[ld_pe_q] = '0;
                            reply({4'h9, OP_LOAD, 16'd0, 8'(ld_pe_q)});
                            rx_d = RX_IDLE;
                        end
                    end else if (ctl) begin
                        fail(E_TOO_SHORT, 16'd1, 1'b1);
                    end else begin
                        ld_n_d = (AW+1)'(w);
                        ld_i_d = '0;
                        ld_tag_ok_d = 1'b0;
                        ld_bad_d = 1'b0;
                        ld_have_prev_d = 1'b0;
                        ld_rec_addr_d = (AW+2)'(WORDS - 10);
                        rx_d = RX_LOAD_WORDS;
                    end
                end
                RX_LOAD_WORDS: load_word(w, ctl);
                RX_RAY: ray_word(w, ctl);
                RX_FRAME: begin
                    // The word goes into gridrt_ctrl_frame's box (frame_box_we).
                    if (ray_idx_q == 16'd6) begin
                        if (frame_bad != 0) fail(E_BAD_FRAME, frame_bad, ctl);
                        else if (!ctl) fail(E_MISSING_CONTROL, 16'd6, 1'b0);
                        else begin
                            // frame_start: gridrt_ctrl_frame begins.
                            busy_d = BZ_FRAME;
                            rx_d = RX_IDLE;
                        end
                    end else if (ctl) begin
                        fail(E_TOO_SHORT, ray_idx_q, 1'b1);
                    end else begin
                        ray_idx_d = ray_idx_q + 16'd1;
                    end
                end
                default: rx_d = RX_IDLE;
            endcase
        end else begin
            // ------------------------------------------------ busy_q phases
            unique case (busy_q)
                BZ_LOOKUP: lookup_step();
                BZ_HI: begin
                    if (hi_out) begin
                        pe_q_push_d[ent_pe_q] = 1'b1;
                        pe_q_k_d = ent_k_q;
                        pe_q_first_d = ent_first_q;
                        pe_q_count_d = ent_count_q;
                        pe_q_hi_d = hi_y;
                        ent_pe_of_we = 1'b1;  // ent_pe_of[ent_k_q] <= ent_pe_q, below
                        ent_k_d = ent_k_q + 1'b1;
                        busy_d = BZ_NONE;
                        if (ent_last_q) begin
                            if (!word_ctl_q) fail(E_MISSING_CONTROL, word_idx_q, 1'b0);
                            else begin_exec();
                        end else if (word_ctl_q) begin
                            fail(E_TOO_SHORT, word_idx_q, 1'b1);
                        end else begin
                            ray_idx_d = ray_idx_q + 16'd1;
                        end
                    end
                end
                BZ_TRI: tri_step();
                BZ_LOAD_FINISH: load_finish();
                BZ_FRAME: begin
                    if (frame_done) begin
                        loaded_d = '0;
                        reply({4'h9, OP_FRAME, 24'd0});
                        busy_d = BZ_NONE;
                    end
                end
                BZ_SETUP: begin
                    if (rs_done) begin
                        pe_start_d = 1'b1;
                        ex_step_d = 3'd0;
                        busy_d = BZ_EXEC;
                    end
                end
                BZ_EXEC: begin
                    // pe_start is seen by the PEs in the cycle after it is set (exec cycle
                    // -1); exec cycle 0 is their first setup; arbitration looks at the state
                    // from cycle 1 on, through the PEs' registered first open and hit
                    // entries and their registered minimum (two cycles late).
                    if (ex_step_q < 3'd3) begin
                        ex_step_d = ex_step_q + 3'd1;
                    end else if ((first_hit < first_open) || (first_open == (KW+1)'(MAX_LIST))) begin
                        win_hit_d = first_hit != (KW+1)'(MAX_LIST) && first_hit < first_open;
                        win_k_d = KW'(first_hit);
                        win_pe_d = ent_pe_of[KW'(first_hit)];
                        win_tests_d = (issued_prev2 > 35'd65535) ? 16'hFFFF : 16'(issued_prev2);
                        pe_stop_d = 1'b1;
                        res_step_d = 4'd0;
                        busy_d = BZ_RESULT;
                    end
                end
                BZ_RESULT: result_step();
                default: ;
            endcase
        end
    end

    // ================================================================ registers
    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) begin
            rx_q <= RX_IDLE;
            busy_q <= BZ_NONE;
            tl_wr_q <= 4'd0;
            loaded_q <= '0;
        end else begin
            rx_q <= rx_d;
            busy_q <= busy_d;
            tl_wr_q <= tl_wr_d;
            loaded_q <= loaded_d;
        end
        push_q <= push_d;
        push_word_q <= push_word_d;
        word_ctl_q <= word_ctl_d;
        word_idx_q <= word_idx_d;
        pe_voxels_q <= pe_voxels_d;
        pe_tri_off_q <= pe_tri_off_d;
        ray_any_q <= ray_any_d;
        ray_count_q <= ray_count_d;
        ray_idx_q <= ray_idx_d;
        ray_org_q <= ray_org_d;
        ray_dir_q <= ray_dir_d;
        ray_tmax_q <= ray_tmax_d;
        ent_k_q <= ent_k_d;
        ent_last_q <= ent_last_d;
        ent_pe_q <= ent_pe_d;
        ent_voxel_q <= ent_voxel_d;
        ent_first_q <= ent_first_d;
        ent_count_q <= ent_count_d;
        ent_texit_q <= ent_texit_d;
        lk_lo_q <= lk_lo_d;
        lk_hi_q <= lk_hi_d;
        lk_mid_q <= lk_mid_d;
        lk_step_q <= lk_step_d;
        hi_in_q <= hi_in_d;
        ld_pe_q <= ld_pe_d;
        ld_n_q <= ld_n_d;
        ld_i_q <= ld_i_d;
        ld_t_q <= ld_t_d;
        ld_v_q <= ld_v_d;
        ld_r_q <= ld_r_d;
        ld_p_q <= ld_p_d;
        ld_vox_end_q <= ld_vox_end_d;
        ld_ref_end_q <= ld_ref_end_d;
        ld_tri_end_q <= ld_tri_end_d;
        ld_need_q <= ld_need_d;
        ld_tag_ok_q <= ld_tag_ok_d;
        ld_bad_q <= ld_bad_d;
        ld_have_prev_q <= ld_have_prev_d;
        ld_prev_id_q <= ld_prev_id_d;
        ld_first_q <= ld_first_d;
        ld_sub3_q <= ld_sub3_d;
        ld_sub11_q <= ld_sub11_d;
        ld_sub16_q <= ld_sub16_d;
        ld_tri_base_q <= ld_tri_base_d;
        ld_rec_addr_q <= ld_rec_addr_d;
        ld_v9_q <= ld_v9_d;
        ld_prim_q <= ld_prim_d;
        ld_last_q <= ld_last_d;
        tl_start_q <= tl_start_d;
        rs_start_q <= rs_start_d;
        ray_cnt_q <= ray_cnt_d;
        ex_step_q <= ex_step_d;
        win_k_q <= win_k_d;
        win_pe_q <= win_pe_d;
        win_hit_q <= win_hit_d;
        win_tests_q <= win_tests_d;
        res_step_q <= res_step_d;
        res_base_q <= res_base_d;
        win_tri_q <= win_tri_d;
        win_tri_off_q <= win_tri_off_d;
        win_t_q <= win_t_d;
        a_addr_q <= a_addr_d;
        ref_off_q <= ref_off_d;
        pe_a_we_q <= pe_a_we_d;
        pe_a_wdata_q <= pe_a_wdata_d;
        pe_q_push_q <= pe_q_push_d;
        pe_q_k_q <= pe_q_k_d;
        pe_q_first_q <= pe_q_first_d;
        pe_q_count_q <= pe_q_count_d;
        pe_q_hi_q <= pe_q_hi_d;
        pe_ray_begin_q <= pe_ray_begin_d;
        pe_start_q <= pe_start_d;
        pe_stop_q <= pe_stop_d;
        pe_any_q <= pe_any_d;
        pe_t_max_q <= pe_t_max_d;
        pe_res_k_q <= pe_res_k_d;
    end

    always_ff @(posedge clk_i) if (en_i && (ent_pe_of_we)) ent_pe_of[ent_k_q] <= ent_pe_q;

    // ================================================================ tasks
    task automatic reply(input [31:0] word);
        push_d = 1'b1;
        push_word_d = {1'b1, word};
    endtask

    // One ERROR word, then the packet is over (control bit seen) or discarded to the next one.
    task automatic fail(input [11:0] code, input [15:0] detail, input ctl);
        reply(err_word(code, detail));
        rx_d = ctl ? RX_IDLE : RX_DISCARD;
        busy_d = BZ_NONE;
    endtask

    function automatic f32_lt(input [31:0] a, input [31:0] b);
        // a < b for non-NaN values (±0 equal).
        if (a[30:0] == 0 && b[30:0] == 0) f32_lt = 1'b0;
        else if (a[31] != b[31]) f32_lt = a[31];
        else if (!a[31]) f32_lt = a[30:0] < b[30:0];
        else f32_lt = a[30:0] > b[30:0];
    endfunction

    // ---------------------------------------------------------------- LOAD_PE image words
    task automatic load_word(input [31:0] w, input ctl);
        logic [AW:0]  i;
        logic [15:0]  index;
        logic [37:0]  i38;
        logic         tri_end_word;
        i = ld_i_q;
        i38 = 38'(i);
        index = 16'(i) + 16'd2;
        tri_end_word = 1'b0;
        a_addr_d[ld_pe_q] = AW'(i);
        pe_a_we_d[ld_pe_q] = 1'b1;
        pe_a_wdata_d = w;
        ld_i_d = i + 1'b1;
        // Header.
        if (i == 0) ld_tag_ok_d = w == PE_IMAGE_TAG;
        if (i == 1) ld_t_d = w;
        if (i == 2) ld_v_d = w;
        if (i == 3) ld_r_d = w;
        if (i == 4) begin
            logic [37:0] ve, re, te;
            ld_p_d = w;
            // Constant multiples as shifts and adds: Yosys would give each `*` DSP blocks.
            ve = 38'd5 + (38'(ld_v_q) << 1) + 38'(ld_v_q);
            re = ve + 38'(ld_r_q);
            te = re + (38'(ld_t_q) << 3) + (38'(ld_t_q) << 1) + 38'(ld_t_q);
            ld_vox_end_d = ve;
            ld_ref_end_d = re;
            ld_tri_end_d = te;
            ld_need_d = te + (38'(w) << 4);
            ld_sub3_d = '0;
            ld_sub11_d = '0;
            ld_sub16_d = '0;
        end
        if (i >= 5) begin
            if (i38 < ld_vox_end_q) begin
                // Voxel table: ids strictly increasing, first + count <= R.
                unique case (ld_sub3_q)
                    2'd0: begin
                        if (ld_have_prev_q && w <= ld_prev_id_q) ld_bad_d = 1'b1;
                        ld_prev_id_d = w;
                        ld_have_prev_d = 1'b1;
                    end
                    2'd1: ld_first_d = w;
                    default: if (33'(ld_first_q) + 33'(w) > 33'(ld_r_q)) ld_bad_d = 1'b1;
                endcase
                ld_sub3_d = (ld_sub3_q == 2'd2) ? 2'd0 : ld_sub3_q + 2'd1;
            end else if (i38 < ld_ref_end_q) begin
                if (33'(w) >= 33'(ld_t_q) + 33'(ld_p_q)) ld_bad_d = 1'b1;
            end else if (i38 < ld_tri_end_q) begin
                // Triangle: 9 finite vertex words, prim, material <= 65535.
                if (ld_sub11_q == 4'd0) ld_tri_base_d = i;
                if (ld_sub11_q <= 4'd8) begin
                    if (!is_finite(w)) ld_bad_d = 1'b1;
                    ld_v9_d[ld_sub11_q] = w;
                end
                if (ld_sub11_q == 4'd9) ld_prim_d = w;
                if (ld_sub11_q == 4'd10) begin
                    if (w > 32'd65535) ld_bad_d = 1'b1;
                    tri_end_word = 1'b1;
                end
                ld_sub11_d = (ld_sub11_q == 4'd10) ? 4'd0 : ld_sub11_q + 4'd1;
            end else if (i38 < ld_need_q) begin
                // Analytic primitive: kind 1..5, material <= 65535, transform finite.
                unique case (ld_sub16_q)
                    4'd0: if (w == 0 || w > 32'd5) ld_bad_d = 1'b1;
                    4'd1: ;
                    4'd2: if (w > 32'd65535) ld_bad_d = 1'b1;
                    4'd15: ;
                    default: if (!is_finite(w)) ld_bad_d = 1'b1;
                endcase
                ld_sub16_d = ld_sub16_q + 4'd1;
            end
        end
        // Framing.
        if (i + 1'b1 == ld_n_q) begin
            if (!ctl) begin
                fail(E_MISSING_CONTROL, index, 1'b0);
            end else begin
                rx_d = RX_IDLE;
                ld_last_d = 1'b1;
                if (tri_end_word) begin
                    tl_start_d = 1'b1;
                    busy_d = BZ_TRI;
                end else begin
                    busy_d = BZ_LOAD_FINISH;
                end
            end
        end else if (ctl) begin
            fail(E_TOO_SHORT, index, 1'b1);
        end else if (tri_end_word) begin
            ld_last_d = 1'b0;
            tl_start_d = 1'b1;
            busy_d = BZ_TRI;
        end
    endtask

    // ---------------------------------------------------------------- triangle records
    // After tri_loader, 13 port-A writes, one per cycle: the record (9 coordinates + prim)
    // of triangle t at WORDS - 10 (t + 1), then the normal over vertex a's three words. One
    // word per cycle keeps the controller's write bus 32 bits wide for all PEs (a record in
    // one port-B write took a 512-bit bus to every PE memory). Records stack from the top
    // down so that each starts at an even address (pe_mem's rotation); they meet the image
    // exactly when n + 10 T > WORDS, which load_finish answers with MEM_OVERFLOW, as the
    // model does for its records after the image.
    task automatic tri_step();
        if (tl_done || tl_wr_q != 0) begin
            logic [3:0]    j;
            logic [AW-1:0] rec_addr;
            logic [31:0]   word;
            j = tl_done ? 4'd0 : tl_wr_q;
            rec_addr = AW'(ld_rec_addr_q) + AW'(j);
            unique case (j)
                4'd9: word = ld_prim_q;
                4'd10: word = tl_normal[0];
                4'd11: word = tl_normal[1];
                4'd12: word = tl_normal[2];
                default: word = tl_coord[j];
            endcase
            if (j < 4'd10) begin
                // Below address 0 a record is not written (MEM_OVERFLOW follows).
                a_addr_d[ld_pe_q] = rec_addr;
                pe_a_we_d[ld_pe_q] = ld_rec_addr_q >= 0;
            end else begin
                a_addr_d[ld_pe_q] = AW'(ld_tri_base_q) + AW'(2'(j - 4'd10));
                pe_a_we_d[ld_pe_q] = 1'b1;
            end
            pe_a_wdata_d = word;
            if (j == 4'd12) begin
                tl_wr_d = 4'd0;
                ld_rec_addr_d = ld_rec_addr_q - (AW+2)'(10);
                busy_d = ld_last_q ? BZ_LOAD_FINISH : BZ_NONE;
            end else begin
                tl_wr_d = j + 4'd1;
            end
        end
    endtask

    // ---------------------------------------------------------------- LOAD_PE end
    task automatic load_finish();
        logic [37:0] n38;
        n38 = 38'(ld_n_q);
        busy_d = BZ_NONE;
        if (ld_n_q < 5 || !ld_tag_ok_q || ld_need_q != n38 || ld_bad_q) begin
            reply(err_word(E_MALFORMED, 16'(ld_pe_q)));
        end else if (ld_p_q != 0) begin
            reply(err_word(E_UNSUPPORTED, 16'(ld_pe_q)));
        end else if (n38 + (38'(ld_t_q) << 3) + (38'(ld_t_q) << 1) > 38'(WORDS)) begin
            reply(err_word(E_MEM_OVERFLOW, 16'(ld_pe_q)));
        end else begin
            loaded_d[ld_pe_q] = 1'b1;
            pe_voxels_d[ld_pe_q] = AW'(ld_v_q);
            ref_off_d[ld_pe_q] = AW'(ld_vox_end_q);
            pe_tri_off_d[ld_pe_q] = AW'(ld_ref_end_q);
            reply({4'h9, OP_LOAD, 16'd0, 8'(ld_pe_q)});
        end
    endtask

    // ---------------------------------------------------------------- ray words
    task automatic ray_word(input [31:0] w, input ctl);
        logic [15:0] idx;
        idx = ray_idx_q;
        if (idx <= 16'd7) begin
            if (idx >= 16'd1 && idx <= 16'd3) ray_org_d[idx - 16'd1] = w;
            if (idx >= 16'd4 && idx <= 16'd6) ray_dir_d[idx - 16'd4] = w;
            if (idx == 16'd7) begin
                logic [15:0]  bad;
                logic [191:0] c;
                c = {ray_dir_q, ray_org_q};
                bad = 16'd0;
                for (int i = 5; i >= 0; i--) if (!is_finite(c[32*i +: 32])) bad = 16'(i + 1);
                if (bad == 0 && ray_dir_q[0][30:0] == 0 && ray_dir_q[1][30:0] == 0 && ray_dir_q[2][30:0] == 0) bad = 16'd4;
                if (bad == 0 && is_nan(w)) bad = 16'd7;
                ray_tmax_d = w;
                if (bad != 0) fail(E_NON_FINITE, bad, ctl);
                else if (ray_count_q == 0) begin
                    if (!ctl) fail(E_MISSING_CONTROL, 16'd7, 1'b0);
                    else begin_exec();
                end else if (ctl) fail(E_TOO_SHORT, 16'd7, 1'b1);
                else ray_idx_d = idx + 16'd1;
            end else if (ctl) begin
                fail(E_TOO_SHORT, idx, 1'b1);
            end else begin
                ray_idx_d = idx + 16'd1;
            end
        end else if (!idx[0]) begin
            // Entry word 0: PE range, then the voxel lookup (then framing, after it).
            if (w[31:24] >= 8'(PES)) begin
                fail(E_PE_RANGE, 16'(w[31:24]), ctl);
            end else begin
                ent_pe_d = PW'(w[31:24]);
                ent_voxel_d = w[23:0];
                word_ctl_d = ctl;
                word_idx_d = idx;
                lk_lo_d = '0;
                lk_hi_d = (AW+1)'(pe_voxels_q[PW'(w[31:24])]);
                lk_step_d = loaded_q[PW'(w[31:24])] ? 4'd1 : 4'd15;
                busy_d = BZ_LOOKUP;
            end
        end else begin
            // Entry word 1: t_exit must not be NaN; hi = fl32(t_exit (1 + 2^-12)).
            if (is_nan(w)) begin
                fail(E_NON_FINITE, idx, ctl);
            end else begin
                ent_texit_d = w;
                hi_in_d = 1'b1;
                word_ctl_d = ctl;
                word_idx_d = idx;
                busy_d = BZ_HI;
            end
        end
    endtask

    // Binary search, one probe per 4 cycles: address, two cycles of read latency, compare.
    task automatic lookup_step();
        logic [AW:0] mid;
        mid = lk_lo_q + ((lk_hi_q - lk_lo_q) >> 1);
        unique case (lk_step_q)
            4'd1: begin
                if (lk_lo_q >= lk_hi_q) begin
                    lk_step_d = 4'd15;
                end else begin
                    lk_mid_d = mid;
                    a_addr_d[ent_pe_q] = AW'(5) + AW'(mid) + (AW'(mid) << 1);
                    lk_step_d = 4'd2;
                end
            end
            4'd2: lk_step_d = 4'd3;
            4'd3: lk_step_d = 4'd4;
            4'd4: begin
                if (pe_a_rdata_i[ent_pe_q] < 32'(ent_voxel_q)) begin
                    lk_lo_d = lk_mid_q + 1'b1;
                    lk_step_d = 4'd1;
                end else if (pe_a_rdata_i[ent_pe_q] > 32'(ent_voxel_q)) begin
                    lk_hi_d = lk_mid_q;
                    lk_step_d = 4'd1;
                end else begin
                    a_addr_d[ent_pe_q] = AW'(6) + AW'(lk_mid_q) + (AW'(lk_mid_q) << 1);
                    lk_step_d = 4'd5;
                end
            end
            4'd5: begin
                a_addr_d[ent_pe_q] = AW'(7) + AW'(lk_mid_q) + (AW'(lk_mid_q) << 1);
                lk_step_d = 4'd6;
            end
            4'd6: lk_step_d = 4'd7;
            4'd7: begin
                ent_first_d = AW'(pe_a_rdata_i[ent_pe_q]);
                lk_step_d = 4'd8;
            end
            4'd8: begin
                ent_count_d = AW'(pe_a_rdata_i[ent_pe_q]);
                busy_d = BZ_NONE;
                if (word_ctl_q) fail(E_TOO_SHORT, word_idx_q, 1'b1);
                else ray_idx_d = ray_idx_q + 16'd1;
            end
            default: fail(E_VOXEL_NOT_LOADED, 16'(ent_k_q), word_ctl_q);
        endcase
    endtask

    // The request is complete: ray setup, then the PEs.
    task automatic begin_exec();
        rx_d = RX_IDLE;
        rs_start_d = 1'b1;
        ray_cnt_d = 32'd0;
        busy_d = BZ_SETUP;
    endtask

    // The result: the winner's t and triangle (PE result memory, registered in step 2), its
    // triangle's address (step 3), then its prim, material and normal (five port-A reads of
    // the triangle's words 9, 10, 0, 1, 2, one per cycle, each used three cycles after its
    // address), then 8 words.
    task automatic result_step();
        res_step_d = res_step_q + 4'd1;
        unique case (res_step_q)
            4'd0: pe_res_k_d = win_k_q;
            4'd2: begin
                // The PE's result memory answers in this step (block RAM outputs): registered
                // here, used from the next step on.
                win_tri_d = res_tri_in[win_pe_q];
                win_tri_off_d = pe_tri_off_q[win_pe_q];
                win_t_d = pe_res_t_i[win_pe_q];
            end
            4'd3: res_base_d = win_tri_off_q + win_tri_q + (win_tri_q << 1) + (win_tri_q << 3);
            4'd4: a_addr_d[win_pe_q] = res_base_q + AW'(9);
            4'd5: a_addr_d[win_pe_q] = res_base_q + AW'(10);
            4'd6: a_addr_d[win_pe_q] = res_base_q;
            4'd7: a_addr_d[win_pe_q] = res_base_q + AW'(1);
            4'd8: a_addr_d[win_pe_q] = res_base_q + AW'(2);
            default: ;
        endcase
        if (res_step_q >= 4'd5 && res_step_q <= 4'd12) begin
            logic [31:0] rd, word;
            rd = pe_a_rdata_i[win_pe_q];
            unique case (res_step_q)
                4'd5: word = {4'h8, win_hit_q ? 12'(win_k_q) : 12'd0, win_hit_q ? 8'(win_pe_q) : 8'd0, 7'd0, win_hit_q};
                4'd6: word = win_hit_q ? win_t_q : 32'h7F80_0000;
                4'd7: word = win_hit_q ? rd : 32'd0;
                4'd8: word = {win_tests_q, win_hit_q ? rd[15:0] : 16'd0};
                4'd9, 4'd10, 4'd11: word = win_hit_q ? rd : 32'd0;
                default: begin
                    // cycles = request words + busy_q cycles + result words (one per cycle).
                    logic [35:0] c;
                    c = 36'd16 + (36'(ray_count_q) << 1) + 36'(ray_cnt_q) - 36'd7;
                    word = (c > 36'hFFFF_FFFF) ? 32'hFFFF_FFFF : 32'(c);
                end
            endcase
            push_d = 1'b1;
            push_word_d = {res_step_q == 4'd12, word};
            if (res_step_q == 4'd12) busy_d = BZ_NONE;
        end
    endtask
endmodule
