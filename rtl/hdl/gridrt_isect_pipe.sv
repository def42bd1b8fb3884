// gridrt_isect_pipe: the ray-triangle test, fully pipelined (one test per cycle), shared by
// PES_PER_PIPELINE PEs (4 by default) that issue in turn (gridrt_isect_share.sv).
//
// Spec: rtl/README.md §3.4; bit-exact twin: `intersect` of the coproc crate's
// `isect::watertight_q23` (kernel watertight, format fixed64-q23). Watertight test (Woop, Benthin, Wald,
// JCGT 2013) in Q23 fixed point: exact integer edge functions on per-vertex-rounded sheared
// coordinates, hit distance as the correctly rounded f32 of an exact rational.
//
// Inputs are one record (9 frame coordinates as i32 words, POISON = 0x80000000 where a
// coordinate did not fit) and the ray constants of the ray setup, which stay fixed while a
// ray's tests run. `kind`: 0 miss, 1 hit (`t` valid), 2 overflow. `tag` rides along.
module gridrt_isect_pipe #(
    parameter int TAG_W = 1,
    // The latency its users plan with (in_valid to out_valid); must equal STAGES below.
    parameter int LATENCY = 57,
    // 1: the data registers stop while no test is in flight (the Verilator builds: their
    // largest cost); 0: they run freely (synthesis: a clock enable on every data register
    // did not route on the ECP5). Answers and cycles are the same either way.
    parameter int STOP_WHEN_EMPTY = 0
) (
    input  logic                clk_i,
    input  logic                en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                rst_i,      // synchronous, active high: clears the valid bits
    input  logic                in_valid_i,
    input  logic [TAG_W-1:0]    in_tag_i,
    input  logic [287:0]        rec_i,        // 9 x i32, word i at bits 32i+31..32i
    // Ray constants (`watertight_q23::RaySetup`).
    input  logic signed [33:0]  o0_i, o1_i, o2_i, // origin, world axis order
    input  logic [1:0]          kz_i,
    input  logic signed [24:0]  sx_i, sy_i,
    input  logic                dz_neg_i,
    input  logic [23:0]         dz_abs_i,
    input  logic signed [9:0]   texp_i,
    input  logic                ray_overflow_i,
    output logic                out_valid_o,
    output logic [TAG_W-1:0]    out_tag_o,
    output logic [1:0]          kind_o,
    output logic [31:0]         t_o
);
    // The 16 products of a test are 16 multipliers in MULT18X18D blocks (mul_pipe, latency
    // MUL); stage numbers below follow from these localparams.
    localparam int MUL = 4;
    localparam int LAT_SHEAR = MUL;
    localparam int LAT_EDGE = MUL;
    // The denominator starts one cycle after the depth products and ends with their first sum.
    localparam int LAT_DEPTH = MUL;
    localparam int DIV_STEPS = 27;
    // K1 K2 | shear | K7 K8 | edges | K13 K14 K15 K16 K17 K18 | depth | K23 K24 K25 K26 K27 |
    // division | K55 K56 K57 (out)
    localparam int STAGES = 2 + LAT_SHEAR + 2 + LAT_EDGE + 6 + LAT_DEPTH + 5 + DIV_STEPS + 3;
    if (LATENCY != STAGES) begin : g_bad_latency
        $error("isect_pipe: LATENCY must be the pipeline's %0d stages", STAGES);
    end

    // ================================================================ stop when empty
    // With STOP_WHEN_EMPTY the data registers (not the valid bits) advance only while a test
    // is in flight: from a test's entry until STAGES cycles after the last one, so every
    // test's path is that of a free-running pipe. An idle pipe then holds its registers,
    // which saves their evaluation in Verilator (the SoC simulation's largest cost).
    if (STOP_WHEN_EMPTY != 0 && STOP_WHEN_EMPTY != 1) begin : g_bad_stop
        $error("isect_pipe: STOP_WHEN_EMPTY must be 0 or 1");
    end
    logic pipe_en, pipe_go;   // pipe_go: pipe_en while the co-processor's clock is enabled
    assign pipe_go = en_i && pipe_en;
    if (STOP_WHEN_EMPTY == 1) begin : g_stop
        logic [6:0] drain_q, drain_d;
        if (STAGES + 1 > 127) begin : g_bad_drain
            $error("isect_pipe: drain counter too narrow");
        end
        always_comb begin
            drain_d = drain_q;
            if (in_valid_i) drain_d = 7'(STAGES + 1);
            else if (drain_q != '0) drain_d = drain_q - 7'd1;
        end
        always_ff @(posedge clk_i) if (en_i) begin
            if (rst_i) drain_q <= '0;
            else drain_q <= drain_d;
        end
        assign pipe_en = in_valid_i || drain_q != '0;
    end else begin : g_free
        assign pipe_en = 1'b1;
    end

    // ================================================================ K1: v - o, poison
    logic signed [34:0] rel_a [9];   // world order: vertex i axis a at 3i+a
    logic               rel_valid, rel_poison;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        rel_poison <= ray_overflow_i;
        for (int i = 0; i < 9; i++) begin
            logic signed [31:0] v;
            v = rec_i[32*i +: 32];
            if (v == 32'sh8000_0000) rel_poison <= 1'b1;
            unique case (i % 3)
                0: rel_a[i] <= 35'(v) - 35'(o0_i);
                1: rel_a[i] <= 35'(v) - 35'(o1_i);
                default: rel_a[i] <= 35'(v) - 35'(o2_i);
            endcase
        end
    end

    // ================================================================ K2: permute
    // Cyclic permutation moving axis kz to z: kz=0 (y,z,x), kz=1 (z,x,y), kz=2 (x,y,z).
    logic signed [34:0] perm_x [3], perm_y [3], perm_z [3];
    logic               perm_valid, perm_poison;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        perm_poison <= rel_poison;
        for (int i = 0; i < 3; i++) begin
            unique case (kz_i)
                2'd0: begin perm_x[i] <= rel_a[3*i+1]; perm_y[i] <= rel_a[3*i+2]; perm_z[i] <= rel_a[3*i]; end
                2'd1: begin perm_x[i] <= rel_a[3*i+2]; perm_y[i] <= rel_a[3*i]; perm_z[i] <= rel_a[3*i+1]; end
                default: begin perm_x[i] <= rel_a[3*i]; perm_y[i] <= rel_a[3*i+1]; perm_z[i] <= rel_a[3*i+2]; end
            endcase
        end
    end

    // ================================================================ K3-K6: shear products
    // sx * A.z and sy * A.z for the 3 vertices (35 x 25).
    logic signed [59:0] shprod_px [3], shprod_py [3];
    for (genvar i = 0; i < 3; i++) begin : g_shear
        gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_SHEAR)) u_mx (.clk_i, .en_i(pipe_go), .a_i(perm_z[i]), .b_i(sx_i), .p_o(shprod_px[i]));
        gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_SHEAR)) u_my (.clk_i, .en_i(pipe_go), .a_i(perm_z[i]), .b_i(sy_i), .p_o(shprod_py[i]));
    end
    logic signed [34:0] shprod_x [3], shprod_y [3], shprod_z [3];
    logic               shprod_valid, shprod_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_xyz
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dx (.clk_i, .en_i(pipe_go), .d_i(perm_x[i]), .q_o(shprod_x[i]));
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dy (.clk_i, .en_i(pipe_go), .d_i(perm_y[i]), .q_o(shprod_y[i]));
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dz (.clk_i, .en_i(pipe_go), .d_i(perm_z[i]), .q_o(shprod_z[i]));
    end
    gridrt_delay_rst #(.W(1), .N(LAT_SHEAR)) u_shprod_valid (.clk_i, .en_i, .rst_i, .d_i(perm_valid), .q_o(shprod_valid));
    gridrt_delay #(.W(1), .N(LAT_SHEAR)) u_shprod_flags (.clk_i, .en_i(pipe_go), .d_i(perm_poison), .q_o(shprod_poison));

    // ================================================================ K7: shear rounding
    // round_half_up(s * A.z / 2^23) = floor((s * A.z + 2^22) / 2^23).
    logic signed [36:0] shrnd_rx [3], shrnd_ry [3];
    logic signed [34:0] shrnd_x [3], shrnd_y [3], shrnd_z [3];
    logic               shrnd_valid, shrnd_poison;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        for (int i = 0; i < 3; i++) begin
            shrnd_rx[i] <= 37'((shprod_px[i] + 60'sd4194304) >>> 23);
            shrnd_ry[i] <= 37'((shprod_py[i] + 60'sd4194304) >>> 23);
        end
        shrnd_x <= shprod_x;
        shrnd_y <= shprod_y;
        shrnd_z <= shprod_z;
        shrnd_poison <= shprod_poison;
    end

    // ================================================================ K8: lateral coordinates
    // x = A.x + rounded shear; range |x| < 2^29 else overflow.
    logic signed [29:0] lat_x [3], lat_y [3];
    logic signed [34:0] lat_z [3];
    logic               lat_valid, lat_poison;
    // |v| >= 2^29 for a 37-bit v, as bit tests (no comparator carry chain after the adder).
    function automatic logic out_of_range(input logic signed [36:0] v);
        if (!v[36]) out_of_range = v[35:29] != 0;
        else out_of_range = v[35:29] != 7'h7F || v[28:0] == 0;
    endfunction
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic signed [36:0] lx, ly;
        logic               bad;
        bad = shrnd_poison;
        for (int i = 0; i < 3; i++) begin
            lx = 37'(shrnd_x[i]) + shrnd_rx[i];
            ly = 37'(shrnd_y[i]) + shrnd_ry[i];
            if (out_of_range(lx) || out_of_range(ly)) bad = 1'b1;
            lat_x[i] <= lx[29:0];
            lat_y[i] <= ly[29:0];
            lat_z[i] <= shrnd_z[i];
        end
        lat_poison <= bad;
    end

    // ================================================================ K9-K12: edge products
    // e0 = bx*cy - by*cx, e1 = cx*ay - cy*ax, e2 = ax*by - ay*bx (exact).
    logic signed [59:0] edprod_p [6];
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e0 (.clk_i, .en_i(pipe_go), .a_i(lat_x[1]), .b_i(lat_y[2]), .p_o(edprod_p[0]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e1 (.clk_i, .en_i(pipe_go), .a_i(lat_y[1]), .b_i(lat_x[2]), .p_o(edprod_p[1]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e2 (.clk_i, .en_i(pipe_go), .a_i(lat_x[2]), .b_i(lat_y[0]), .p_o(edprod_p[2]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e3 (.clk_i, .en_i(pipe_go), .a_i(lat_y[2]), .b_i(lat_x[0]), .p_o(edprod_p[3]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e4 (.clk_i, .en_i(pipe_go), .a_i(lat_x[0]), .b_i(lat_y[1]), .p_o(edprod_p[4]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e5 (.clk_i, .en_i(pipe_go), .a_i(lat_y[0]), .b_i(lat_x[1]), .p_o(edprod_p[5]));
    logic signed [34:0] edprod_z [3];
    logic               edprod_valid, edprod_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_z12
        gridrt_delay #(.W(35), .N(LAT_EDGE)) u_dz (.clk_i, .en_i(pipe_go), .d_i(lat_z[i]), .q_o(edprod_z[i]));
    end
    gridrt_delay_rst #(.W(1), .N(LAT_EDGE)) u_edprod_valid (.clk_i, .en_i, .rst_i, .d_i(lat_valid), .q_o(edprod_valid));
    gridrt_delay #(.W(1), .N(LAT_EDGE)) u_edprod_flags (.clk_i, .en_i(pipe_go), .d_i(lat_poison), .q_o(edprod_poison));

    // ================================================================ K13: edge functions
    logic signed [60:0] edge_e [3];
    logic signed [34:0] edge_z [3];
    logic               edge_valid, edge_poison;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        for (int i = 0; i < 3; i++) begin
            edge_e[i] <= 61'(edprod_p[2*i]) - 61'(edprod_p[2*i+1]);
            edge_z[i] <= edprod_z[i];
        end
        edge_poison <= edprod_poison;
    end

    // ================================================================ K14: sign test, e0 + e1
    logic signed [62:0] sgn_e01;
    logic signed [60:0] sgn_e [3];
    logic signed [34:0] sgn_z [3];
    logic               sgn_valid, sgn_poison, sgn_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic any_neg, any_pos;
        any_neg = edge_e[0] < 0 || edge_e[1] < 0 || edge_e[2] < 0;
        any_pos = edge_e[0] > 0 || edge_e[1] > 0 || edge_e[2] > 0;
        sgn_cand <= !(any_neg && any_pos);
        sgn_e01 <= 63'(edge_e[0]) + 63'(edge_e[1]);
        sgn_e <= edge_e;
        sgn_z <= edge_z;
        sgn_poison <= edge_poison;
    end

    // ================================================================ K15: det
    logic signed [62:0] dsum_det;
    logic signed [60:0] dsum_e [3];
    logic signed [34:0] dsum_z [3];
    logic               dsum_valid, dsum_poison, dsum_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        dsum_det <= sgn_e01 + 63'(sgn_e[2]);
        dsum_e <= sgn_e;
        dsum_z <= sgn_z;
        dsum_poison <= sgn_poison;
        dsum_cand <= sgn_cand;
    end

    // ================================================================ K16: sign-normalise
    logic [61:0]        norm_det;    // > 0 for a candidate
    logic [60:0]        norm_e [3];  // >= 0 for a candidate
    logic signed [34:0] norm_z [3];
    logic               norm_valid, norm_poison, norm_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic neg;
        neg = dsum_det < 0;
        for (int i = 0; i < 3; i++) norm_e[i] <= neg ? 61'(-dsum_e[i]) : 61'(dsum_e[i]);
        norm_det <= neg ? 62'(-dsum_det) : 62'(dsum_det);
        norm_cand <= dsum_cand && dsum_det != 0;
        norm_z <= dsum_z;
        norm_poison <= dsum_poison;
    end

    // ================================================================ K17: weight shift
    // r = max(0, bitlen(det) - 34).
    logic [5:0]         det_len;
    gridrt_bit_length #(.W(62)) u_det_len (.x_i(norm_det), .len_o(det_len));
    logic [4:0]         wsh_r;
    logic [60:0]        wsh_e [3];
    logic signed [34:0] wsh_z [3];
    logic               wsh_valid, wsh_poison, wsh_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        wsh_r <= (det_len > 6'd34) ? 5'(det_len - 6'd34) : 5'd0;
        wsh_e <= norm_e;
        wsh_z <= norm_z;
        wsh_poison <= norm_poison;
        wsh_cand <= norm_cand;
    end

    // ================================================================ K18: weights
    logic signed [34:0] wgt_w [3];  // < 2^34 for a candidate
    logic signed [34:0] wgt_z [3];
    logic               wgt_valid, wgt_poison, wgt_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        for (int i = 0; i < 3; i++) wgt_w[i] <= 35'(wsh_e[i] >> wsh_r);
        wgt_z <= wsh_z;
        wgt_poison <= wsh_poison;
        wgt_cand <= wsh_cand;
    end

    // ================================================================ K19: weight sum
    // det' = sum of weights (< 2^34), registered while the depth products start.
    logic signed [34:0] wsum_detw;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) wsum_detw <= wgt_w[0] + wgt_w[1] + wgt_w[2];

    // ================================================================ K19-K22: depth products
    logic signed [69:0] dprod_n [3];
    for (genvar i = 0; i < 3; i++) begin : g_depth
        gridrt_mul_pipe #(.A_W(35), .B_W(35), .LATENCY(LAT_DEPTH)) u_n (.clk_i, .en_i(pipe_go), .a_i(wgt_w[i]), .b_i(wgt_z[i]), .p_o(dprod_n[i]));
    end
    // Denominator det' * |dz| (K20-K23) starts one cycle later and ends with the first depth
    // sum (K23).
    logic signed [59:0] dpart_den;
    gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_DEPTH)) u_den (.clk_i, .en_i(pipe_go), .a_i(wsum_detw), .b_i({1'b0, dz_abs_i}), .p_o(dpart_den));
    logic dprod_valid, dprod_poison, dprod_cand;
    gridrt_delay_rst #(.W(1), .N(LAT_DEPTH)) u_dprod_valid (.clk_i, .en_i, .rst_i, .d_i(wgt_valid), .q_o(dprod_valid));
    gridrt_delay #(.W(2), .N(LAT_DEPTH)) u_dprod_flags (.clk_i, .en_i(pipe_go), .d_i({wgt_poison, wgt_cand}), .q_o({dprod_poison, dprod_cand}));

    // ================================================================ K23: n0 + n1
    logic signed [71:0] dpart_n01;
    logic signed [69:0] dpart_n2;
    logic               dpart_valid, dpart_poison, dpart_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        dpart_n01 <= 72'(dprod_n[0]) + 72'(dprod_n[1]);
        dpart_n2 <= dprod_n[2];
        dpart_poison <= dprod_poison;
        dpart_cand <= dprod_cand;
    end

    // ================================================================ K24: depth sum
    logic signed [71:0] depth_n;
    logic [57:0]        depth_den;
    logic               depth_valid, depth_poison, depth_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        depth_n <= dpart_n01 + 72'(dpart_n2);
        depth_den <= dpart_den[57:0];
        depth_poison <= dpart_poison;
        depth_cand <= dpart_cand;
    end

    // ================================================================ K25: front test, |N|
    // N is negated when dz < 0; a candidate needs N > 0, and then |n| is N.
    logic [69:0]  front_n;
    logic [57:0]  front_den;
    logic         front_valid, front_poison, front_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic front;
        front = dz_neg_i ? depth_n < 0 : depth_n > 0;
        front_n <= 70'(depth_n[71] ? -depth_n : depth_n);
        front_den <= depth_den;
        front_poison <= depth_poison;
        front_cand <= depth_cand && front;
    end

    // ================================================================ K26: operand lengths
    logic [6:0]   n_len;
    logic [5:0]   den_len;
    gridrt_bit_length #(.W(70)) u_n_len (.x_i(front_n), .len_o(n_len));
    gridrt_bit_length #(.W(58)) u_den_len (.x_i(front_den), .len_o(den_len));
    logic [69:0]  len_n;
    logic [57:0]  len_den;
    logic [6:0]   len_ln;
    logic [5:0]   len_ld;
    logic         len_valid, len_poison, len_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        len_n <= front_n;
        len_den <= front_den;
        len_ln <= n_len;
        len_ld <= den_len;
        len_poison <= front_poison;
        len_cand <= front_cand;
    end

    // ================================================================ K27: normalise operands
    logic [69:0]         opnd_nn;
    logic [57:0]         opnd_dn;
    logic signed [10:0]  opnd_exp;
    logic                opnd_valid, opnd_poison, opnd_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        opnd_nn <= len_n << (7'd70 - len_ln);
        opnd_dn <= len_den << (6'd58 - len_ld);
        opnd_exp <= 11'($signed({4'd0, len_ln})) - 11'($signed({5'd0, len_ld})) - 11'sd26 + 11'(texp_i);
        opnd_poison <= len_poison;
        opnd_cand <= len_cand;
    end

    // ================================================================ K28-K54: division
    // q = floor(nn * 2^14 / dn) (27 bits), sticky = remainder != 0: one quotient bit per
    // stage, restoring. The dividend's bits below the initial window enter one per stage.
    logic [58:0] dv_r   [DIV_STEPS+1];
    logic [57:0] dv_d   [DIV_STEPS+1];
    logic [12:0] dv_low [DIV_STEPS+1];  // nn[12:0], consumed MSB first
    logic [26:0] dv_q   [DIV_STEPS+1];
    assign dv_r[0] = {2'b00, opnd_nn[69:13]};
    assign dv_d[0] = opnd_dn;
    assign dv_low[0] = opnd_nn[12:0];
    assign dv_q[0] = 27'd0;
    for (genvar j = 0; j < DIV_STEPS; j++) begin : g_div
        always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
            logic [58:0] r;
            logic [59:0] diff;
            r = {dv_r[j][57:0], dv_low[j][12]};
            // One subtractor: its borrow is the comparison.
            diff = {1'b0, r} - {2'b00, dv_d[j]};
            if (!diff[59]) begin
                dv_r[j+1] <= diff[58:0];
                dv_q[j+1] <= {dv_q[j][25:0], 1'b1};
            end else begin
                dv_r[j+1] <= r;
                dv_q[j+1] <= {dv_q[j][25:0], 1'b0};
            end
            dv_d[j+1] <= dv_d[j];
            dv_low[j+1] <= {dv_low[j][11:0], 1'b0};
        end
    end
    logic signed [10:0] quo_exp;
    logic               quo_valid, quo_poison, quo_cand;
    gridrt_delay_rst #(.W(1), .N(DIV_STEPS)) u_quo_valid (.clk_i, .en_i, .rst_i, .d_i(opnd_valid), .q_o(quo_valid));
    gridrt_delay #(.W(13), .N(DIV_STEPS)) u_quo_flags (.clk_i, .en_i(pipe_go), .d_i({opnd_exp, opnd_poison, opnd_cand}),
                                                    .q_o({quo_exp, quo_poison, quo_cand}));

    // ================================================================ K55: rounding position
    // The quotient q (27 bits) has its leading one at bit 26 or 25. e = exponent of the
    // leading one; dr = bits to drop: down to 24 significant bits, or to the subnormal grid
    // 2^-149, at most 28.
    logic [27:0]        rpos_q;          // quotient with a zero bit on top
    logic               rpos_sticky;
    logic signed [10:0] rpos_e;
    logic [4:0]         rpos_dr;
    logic               rpos_valid, rpos_poison, rpos_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic [5:0]         p;
        logic signed [10:0] e, drop;
        p = dv_q[DIV_STEPS][26] ? 6'd27 : 6'd26;
        e = 11'(p) - 11'sd1 + quo_exp;
        drop = (e >= -11'sd126) ? 11'(p) - 11'sd24 : -11'sd149 - quo_exp;
        rpos_q <= {1'b0, dv_q[DIV_STEPS]};
        rpos_sticky <= dv_r[DIV_STEPS] != 0;
        rpos_e <= e;
        rpos_dr <= (drop > 11'sd28) ? 5'd28 : 5'(drop);
        rpos_poison <= quo_poison;
        rpos_cand <= quo_cand;
    end

    // ================================================================ K56: mantissa, round bit
    logic [27:0]        rnd_mant;
    logic               rnd_up;
    logic signed [10:0] rnd_e;
    logic               rnd_valid, rnd_poison, rnd_cand;
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        logic [27:0] mant;
        logic        half, rest;
        mant = rpos_q >> rpos_dr;
        half = rpos_q[rpos_dr - 5'd1];
        rest = (rpos_q & ((28'd1 << (rpos_dr - 5'd1)) - 28'd1)) != 0;
        rnd_mant <= mant;
        rnd_up <= half && (rest || rpos_sticky || mant[0]);
        rnd_e <= rpos_e;
        rnd_poison <= rpos_poison;
        rnd_cand <= rpos_cand;
    end

    // ================================================================ K57: round, pack (out)
    logic [31:0] t_bits;
    always_comb begin
        logic [27:0]        mant;
        logic signed [10:0] e;
        mant = rnd_mant + 28'(rnd_up);
        e = rnd_e;
        if (e > 11'sd127) begin
            t_bits = 32'h7F80_0000;
        end else if (e >= -11'sd126) begin
            if (mant[24]) begin
                mant = mant >> 1;
                e = e + 11'sd1;
            end
            t_bits = (e > 11'sd127) ? 32'h7F80_0000 : {1'b0, 8'(e + 11'sd127), mant[22:0]};
        end else begin
            // Subnormal, or rounded up to the smallest normal (the same count of 2^-149).
            t_bits = {8'd0, mant[23:0]};
        end
    end

    // Whether t is 0 or infinite, from K56's values beside the rounding add rather than from
    // t_bits after it (the compares after the add were a placed 4-PE design's long path):
    // the add's low 24 bits are 0 and its bit 24 is set exactly as below.
    logic sum_low_zero, sum_bit24, t_zero, t_inf;
    always_comb begin
        sum_low_zero = rnd_up ? (&rnd_mant[23:0]) : (rnd_mant[23:0] == 0);
        sum_bit24 = rnd_mant[24] ^ (rnd_up && (&rnd_mant[23:0]));
        t_inf = rnd_e > 11'sd127 || (rnd_e == 11'sd127 && sum_bit24);
        t_zero = rnd_e < -11'sd126 && sum_low_zero;
    end

    logic [TAG_W-1:0] tag_q;
    gridrt_delay #(.W(TAG_W), .N(STAGES)) u_tag (.clk_i, .en_i(pipe_go), .d_i(in_tag_i), .q_o(tag_q));
    always_ff @(posedge clk_i) if (en_i && (pipe_en)) begin
        t_o <= t_bits;
        if (rnd_poison) kind_o <= 2'd2;
        else if (rnd_cand && !t_zero && !t_inf) kind_o <= 2'd1;
        else kind_o <= 2'd0;
    end
    assign out_tag_o = tag_q;

    // ================================================================ valid bits
    // Every stage's valid bit, cleared by the reset (the stages' data registers have none):
    // no test is in flight after a reset.
    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) begin
            rel_valid <= 1'b0;
            perm_valid <= 1'b0;
            shrnd_valid <= 1'b0;
            lat_valid <= 1'b0;
            edge_valid <= 1'b0;
            sgn_valid <= 1'b0;
            dsum_valid <= 1'b0;
            norm_valid <= 1'b0;
            wsh_valid <= 1'b0;
            wgt_valid <= 1'b0;
            dpart_valid <= 1'b0;
            depth_valid <= 1'b0;
            front_valid <= 1'b0;
            len_valid <= 1'b0;
            opnd_valid <= 1'b0;
            rpos_valid <= 1'b0;
            rnd_valid <= 1'b0;
            out_valid_o <= 1'b0;
        end else begin
            rel_valid <= in_valid_i;
            perm_valid <= rel_valid;
            shrnd_valid <= shprod_valid;
            lat_valid <= shrnd_valid;
            edge_valid <= edprod_valid;
            sgn_valid <= edge_valid;
            dsum_valid <= sgn_valid;
            norm_valid <= dsum_valid;
            wsh_valid <= norm_valid;
            wgt_valid <= wsh_valid;
            dpart_valid <= dprod_valid;
            depth_valid <= dpart_valid;
            front_valid <= depth_valid;
            len_valid <= front_valid;
            opnd_valid <= len_valid;
            rpos_valid <= quo_valid;
            rnd_valid <= rpos_valid;
            out_valid_o <= rnd_valid;
        end
    end

`ifndef SYNTHESIS
    // A stopped pipe holds no test: every valid bit is clear while the data registers hold.
    StoppedWhenEmpty: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) !pipe_en |->
        !(rel_valid || perm_valid || shprod_valid || shrnd_valid || lat_valid || edprod_valid ||
          edge_valid || sgn_valid || dsum_valid || norm_valid || wsh_valid || wgt_valid ||
          dprod_valid || dpart_valid || depth_valid || front_valid || len_valid || opnd_valid ||
          quo_valid || rpos_valid || rnd_valid || out_valid_o))
        else $fatal(1, "gridrt_isect_pipe: stopped with a test in flight");
`endif
endmodule
