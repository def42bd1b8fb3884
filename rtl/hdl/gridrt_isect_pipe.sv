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
    parameter int LATENCY = 57
) (
    input  logic                clk_i,
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

    // ================================================================ K1: v - o, poison
    logic signed [34:0] k1_a [9];   // world order: vertex i axis a at 3i+a
    logic               k1_valid, k1_poison;
    always_ff @(posedge clk_i) begin
        k1_valid <= in_valid_i;
        k1_poison <= ray_overflow_i;
        for (int i = 0; i < 9; i++) begin
            logic signed [31:0] v;
            v = rec_i[32*i +: 32];
            if (v == 32'sh8000_0000) k1_poison <= 1'b1;
            case (i % 3)
                0: k1_a[i] <= 35'(v) - 35'(o0_i);
                1: k1_a[i] <= 35'(v) - 35'(o1_i);
                default: k1_a[i] <= 35'(v) - 35'(o2_i);
            endcase
        end
    end

    // ================================================================ K2: permute
    // Cyclic permutation moving axis kz to z: kz=0 (y,z,x), kz=1 (z,x,y), kz=2 (x,y,z).
    logic signed [34:0] k2_x [3], k2_y [3], k2_z [3];
    logic               k2_valid, k2_poison;
    always_ff @(posedge clk_i) begin
        k2_valid <= k1_valid;
        k2_poison <= k1_poison;
        for (int i = 0; i < 3; i++) begin
            case (kz_i)
                2'd0: begin k2_x[i] <= k1_a[3*i+1]; k2_y[i] <= k1_a[3*i+2]; k2_z[i] <= k1_a[3*i]; end
                2'd1: begin k2_x[i] <= k1_a[3*i+2]; k2_y[i] <= k1_a[3*i]; k2_z[i] <= k1_a[3*i+1]; end
                default: begin k2_x[i] <= k1_a[3*i]; k2_y[i] <= k1_a[3*i+1]; k2_z[i] <= k1_a[3*i+2]; end
            endcase
        end
    end

    // ================================================================ K3-K6: shear products
    // sx * A.z and sy * A.z for the 3 vertices (35 x 25).
    logic signed [59:0] k6_px [3], k6_py [3];
    for (genvar i = 0; i < 3; i++) begin : g_shear
        gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_SHEAR)) u_mx (.clk_i, .a_i(k2_z[i]), .b_i(sx_i), .p_o(k6_px[i]));
        gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_SHEAR)) u_my (.clk_i, .a_i(k2_z[i]), .b_i(sy_i), .p_o(k6_py[i]));
    end
    logic signed [34:0] k6_x [3], k6_y [3], k6_z [3];
    logic               k6_valid, k6_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_xyz
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dx (.clk_i, .d_i(k2_x[i]), .q_o(k6_x[i]));
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dy (.clk_i, .d_i(k2_y[i]), .q_o(k6_y[i]));
        gridrt_delay #(.W(35), .N(LAT_SHEAR)) u_dz (.clk_i, .d_i(k2_z[i]), .q_o(k6_z[i]));
    end
    gridrt_delay #(.W(2), .N(LAT_SHEAR)) u_d6 (.clk_i, .d_i({k2_valid, k2_poison}), .q_o({k6_valid, k6_poison}));

    // ================================================================ K7: shear rounding
    // round_half_up(s * A.z / 2^23) = floor((s * A.z + 2^22) / 2^23).
    logic signed [36:0] k7_rx [3], k7_ry [3];
    logic signed [34:0] k7_x [3], k7_y [3], k7_z [3];
    logic               k7_valid, k7_poison;
    always_ff @(posedge clk_i) begin
        for (int i = 0; i < 3; i++) begin
            k7_rx[i] <= 37'((k6_px[i] + 60'sd4194304) >>> 23);
            k7_ry[i] <= 37'((k6_py[i] + 60'sd4194304) >>> 23);
        end
        k7_x <= k6_x;
        k7_y <= k6_y;
        k7_z <= k6_z;
        k7_valid <= k6_valid;
        k7_poison <= k6_poison;
    end

    // ================================================================ K8: lateral coordinates
    // x = A.x + rounded shear; range |x| < 2^29 else overflow.
    logic signed [29:0] k8_x [3], k8_y [3];
    logic signed [34:0] k8_z [3];
    logic               k8_valid, k8_poison;
    // |v| >= 2^29 for a 37-bit v, as bit tests (no comparator carry chain after the adder).
    function automatic logic out_of_range(input logic signed [36:0] v);
        if (!v[36]) out_of_range = v[35:29] != 0;
        else out_of_range = v[35:29] != 7'h7F || v[28:0] == 0;
    endfunction
    always_ff @(posedge clk_i) begin
        logic signed [36:0] lx, ly;
        logic               bad;
        bad = k7_poison;
        for (int i = 0; i < 3; i++) begin
            lx = 37'(k7_x[i]) + k7_rx[i];
            ly = 37'(k7_y[i]) + k7_ry[i];
            if (out_of_range(lx) || out_of_range(ly)) bad = 1'b1;
            k8_x[i] <= lx[29:0];
            k8_y[i] <= ly[29:0];
            k8_z[i] <= k7_z[i];
        end
        k8_valid <= k7_valid;
        k8_poison <= bad;
    end

    // ================================================================ K9-K12: edge products
    // e0 = bx*cy - by*cx, e1 = cx*ay - cy*ax, e2 = ax*by - ay*bx (exact).
    logic signed [59:0] k12_p [6];
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e0 (.clk_i, .a_i(k8_x[1]), .b_i(k8_y[2]), .p_o(k12_p[0]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e1 (.clk_i, .a_i(k8_y[1]), .b_i(k8_x[2]), .p_o(k12_p[1]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e2 (.clk_i, .a_i(k8_x[2]), .b_i(k8_y[0]), .p_o(k12_p[2]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e3 (.clk_i, .a_i(k8_y[2]), .b_i(k8_x[0]), .p_o(k12_p[3]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e4 (.clk_i, .a_i(k8_x[0]), .b_i(k8_y[1]), .p_o(k12_p[4]));
    gridrt_mul_pipe #(.A_W(30), .B_W(30), .LATENCY(LAT_EDGE)) u_e5 (.clk_i, .a_i(k8_y[0]), .b_i(k8_x[1]), .p_o(k12_p[5]));
    logic signed [34:0] k12_z [3];
    logic               k12_valid, k12_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_z12
        gridrt_delay #(.W(35), .N(LAT_EDGE)) u_dz (.clk_i, .d_i(k8_z[i]), .q_o(k12_z[i]));
    end
    gridrt_delay #(.W(2), .N(LAT_EDGE)) u_d12 (.clk_i, .d_i({k8_valid, k8_poison}), .q_o({k12_valid, k12_poison}));

    // ================================================================ K13: edge functions
    logic signed [60:0] k13_e [3];
    logic signed [34:0] k13_z [3];
    logic               k13_valid, k13_poison;
    always_ff @(posedge clk_i) begin
        for (int i = 0; i < 3; i++) begin
            k13_e[i] <= 61'(k12_p[2*i]) - 61'(k12_p[2*i+1]);
            k13_z[i] <= k12_z[i];
        end
        k13_valid <= k12_valid;
        k13_poison <= k12_poison;
    end

    // ================================================================ K14: sign test, e0 + e1
    logic signed [62:0] k14_e01;
    logic signed [60:0] k14_e [3];
    logic signed [34:0] k14_z [3];
    logic               k14_valid, k14_poison, k14_cand;
    always_ff @(posedge clk_i) begin
        logic any_neg, any_pos;
        any_neg = k13_e[0] < 0 || k13_e[1] < 0 || k13_e[2] < 0;
        any_pos = k13_e[0] > 0 || k13_e[1] > 0 || k13_e[2] > 0;
        k14_cand <= !(any_neg && any_pos);
        k14_e01 <= 63'(k13_e[0]) + 63'(k13_e[1]);
        k14_e <= k13_e;
        k14_z <= k13_z;
        k14_valid <= k13_valid;
        k14_poison <= k13_poison;
    end

    // ================================================================ K15: det
    logic signed [62:0] k15_det;
    logic signed [60:0] k15_e [3];
    logic signed [34:0] k15_z [3];
    logic               k15_valid, k15_poison, k15_cand;
    always_ff @(posedge clk_i) begin
        k15_det <= k14_e01 + 63'(k14_e[2]);
        k15_e <= k14_e;
        k15_z <= k14_z;
        k15_valid <= k14_valid;
        k15_poison <= k14_poison;
        k15_cand <= k14_cand;
    end

    // ================================================================ K16: sign-normalise
    logic [61:0]        k16_det;    // > 0 for a candidate
    logic [60:0]        k16_e [3];  // >= 0 for a candidate
    logic signed [34:0] k16_z [3];
    logic               k16_valid, k16_poison, k16_cand;
    always_ff @(posedge clk_i) begin
        logic neg;
        neg = k15_det < 0;
        for (int i = 0; i < 3; i++) k16_e[i] <= neg ? 61'(-k15_e[i]) : 61'(k15_e[i]);
        k16_det <= neg ? 62'(-k15_det) : 62'(k15_det);
        k16_cand <= k15_cand && k15_det != 0;
        k16_z <= k15_z;
        k16_valid <= k15_valid;
        k16_poison <= k15_poison;
    end

    // ================================================================ K17: weight shift
    // r = max(0, bitlen(det) - 34).
    logic [5:0]         det_len;
    gridrt_bit_length #(.W(62)) u_det_len (.x_i(k16_det), .len_o(det_len));
    logic [4:0]         k17_r;
    logic [60:0]        k17_e [3];
    logic signed [34:0] k17_z [3];
    logic               k17_valid, k17_poison, k17_cand;
    always_ff @(posedge clk_i) begin
        k17_r <= (det_len > 6'd34) ? 5'(det_len - 6'd34) : 5'd0;
        k17_e <= k16_e;
        k17_z <= k16_z;
        k17_valid <= k16_valid;
        k17_poison <= k16_poison;
        k17_cand <= k16_cand;
    end

    // ================================================================ K18: weights
    logic signed [34:0] k18_w [3];  // < 2^34 for a candidate
    logic signed [34:0] k18_z [3];
    logic               k18_valid, k18_poison, k18_cand;
    always_ff @(posedge clk_i) begin
        for (int i = 0; i < 3; i++) k18_w[i] <= 35'(k17_e[i] >> k17_r);
        k18_z <= k17_z;
        k18_valid <= k17_valid;
        k18_poison <= k17_poison;
        k18_cand <= k17_cand;
    end

    // ================================================================ K19: weight sum
    // det' = sum of weights (< 2^34), registered while the depth products start.
    logic signed [34:0] k19_detw;
    always_ff @(posedge clk_i) k19_detw <= k18_w[0] + k18_w[1] + k18_w[2];

    // ================================================================ K19-K22: depth products
    logic signed [69:0] k22_n [3];
    for (genvar i = 0; i < 3; i++) begin : g_depth
        gridrt_mul_pipe #(.A_W(35), .B_W(35), .LATENCY(LAT_DEPTH)) u_n (.clk_i, .a_i(k18_w[i]), .b_i(k18_z[i]), .p_o(k22_n[i]));
    end
    // Denominator det' * |dz| (K20-K23) starts one cycle later and ends with the first depth
    // sum (K23).
    logic signed [59:0] k23_den;
    gridrt_mul_pipe #(.A_W(35), .B_W(25), .LATENCY(LAT_DEPTH)) u_den (.clk_i, .a_i(k19_detw), .b_i({1'b0, dz_abs_i}), .p_o(k23_den));
    logic k22_valid, k22_poison, k22_cand;
    gridrt_delay #(.W(3), .N(LAT_DEPTH)) u_d22 (.clk_i, .d_i({k18_valid, k18_poison, k18_cand}), .q_o({k22_valid, k22_poison, k22_cand}));

    // ================================================================ K23: n0 + n1
    logic signed [71:0] k23_n01;
    logic signed [69:0] k23_n2;
    logic               k23_valid, k23_poison, k23_cand;
    always_ff @(posedge clk_i) begin
        k23_n01 <= 72'(k22_n[0]) + 72'(k22_n[1]);
        k23_n2 <= k22_n[2];
        k23_valid <= k22_valid;
        k23_poison <= k22_poison;
        k23_cand <= k22_cand;
    end

    // ================================================================ K24: depth sum
    logic signed [71:0] k24_n;
    logic [57:0]        k24_den;
    logic               k24_valid, k24_poison, k24_cand;
    always_ff @(posedge clk_i) begin
        k24_n <= k23_n01 + 72'(k23_n2);
        k24_den <= k23_den[57:0];
        k24_valid <= k23_valid;
        k24_poison <= k23_poison;
        k24_cand <= k23_cand;
    end

    // ================================================================ K25: front test, |N|
    // N is negated when dz < 0; a candidate needs N > 0, and then |n| is N.
    logic [69:0]  k25_n;
    logic [57:0]  k25_den;
    logic         k25_valid, k25_poison, k25_cand;
    always_ff @(posedge clk_i) begin
        logic front;
        front = dz_neg_i ? k24_n < 0 : k24_n > 0;
        k25_n <= 70'(k24_n[71] ? -k24_n : k24_n);
        k25_den <= k24_den;
        k25_valid <= k24_valid;
        k25_poison <= k24_poison;
        k25_cand <= k24_cand && front;
    end

    // ================================================================ K26: operand lengths
    logic [6:0]   n_len;
    logic [5:0]   den_len;
    gridrt_bit_length #(.W(70)) u_n_len (.x_i(k25_n), .len_o(n_len));
    gridrt_bit_length #(.W(58)) u_den_len (.x_i(k25_den), .len_o(den_len));
    logic [69:0]  k26_n;
    logic [57:0]  k26_den;
    logic [6:0]   k26_ln;
    logic [5:0]   k26_ld;
    logic         k26_valid, k26_poison, k26_cand;
    always_ff @(posedge clk_i) begin
        k26_n <= k25_n;
        k26_den <= k25_den;
        k26_ln <= n_len;
        k26_ld <= den_len;
        k26_valid <= k25_valid;
        k26_poison <= k25_poison;
        k26_cand <= k25_cand;
    end

    // ================================================================ K27: normalise operands
    logic [69:0]         k27_nn;
    logic [57:0]         k27_dn;
    logic signed [10:0]  k27_exp;
    logic                k27_valid, k27_poison, k27_cand;
    always_ff @(posedge clk_i) begin
        k27_nn <= k26_n << (7'd70 - k26_ln);
        k27_dn <= k26_den << (6'd58 - k26_ld);
        k27_exp <= 11'($signed({4'd0, k26_ln})) - 11'($signed({5'd0, k26_ld})) - 11'sd26 + 11'(texp_i);
        k27_valid <= k26_valid;
        k27_poison <= k26_poison;
        k27_cand <= k26_cand;
    end

    // ================================================================ K28-K54: division
    // q = floor(nn * 2^14 / dn) (27 bits), sticky = remainder != 0: one quotient bit per
    // stage, restoring. The dividend's bits below the initial window enter one per stage.
    logic [58:0] dv_r   [DIV_STEPS+1];
    logic [57:0] dv_d   [DIV_STEPS+1];
    logic [12:0] dv_low [DIV_STEPS+1];  // nn[12:0], consumed MSB first
    logic [26:0] dv_q   [DIV_STEPS+1];
    assign dv_r[0] = {2'b00, k27_nn[69:13]};
    assign dv_d[0] = k27_dn;
    assign dv_low[0] = k27_nn[12:0];
    assign dv_q[0] = 27'd0;
    for (genvar j = 0; j < DIV_STEPS; j++) begin : g_div
        always_ff @(posedge clk_i) begin
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
    logic signed [10:0] k54_exp;
    logic               k54_valid, k54_poison, k54_cand;
    gridrt_delay #(.W(14), .N(DIV_STEPS)) u_d54 (.clk_i, .d_i({k27_exp, k27_valid, k27_poison, k27_cand}),
                                          .q_o({k54_exp, k54_valid, k54_poison, k54_cand}));

    // ================================================================ K55: rounding position
    // The quotient q (27 bits) has its leading one at bit 26 or 25. e = exponent of the
    // leading one; dr = bits to drop: down to 24 significant bits, or to the subnormal grid
    // 2^-149, at most 28.
    logic [27:0]        k55_q;          // quotient with a zero bit on top
    logic               k55_sticky;
    logic signed [10:0] k55_e;
    logic [4:0]         k55_dr;
    logic               k55_valid, k55_poison, k55_cand;
    always_ff @(posedge clk_i) begin
        logic [5:0]         p;
        logic signed [10:0] e, drop;
        p = dv_q[DIV_STEPS][26] ? 6'd27 : 6'd26;
        e = 11'(p) - 11'sd1 + k54_exp;
        drop = (e >= -11'sd126) ? 11'(p) - 11'sd24 : -11'sd149 - k54_exp;
        k55_q <= {1'b0, dv_q[DIV_STEPS]};
        k55_sticky <= dv_r[DIV_STEPS] != 0;
        k55_e <= e;
        k55_dr <= (drop > 11'sd28) ? 5'd28 : 5'(drop);
        k55_valid <= k54_valid;
        k55_poison <= k54_poison;
        k55_cand <= k54_cand;
    end

    // ================================================================ K56: mantissa, round bit
    logic [27:0]        k56_mant;
    logic               k56_up;
    logic signed [10:0] k56_e;
    logic               k56_valid, k56_poison, k56_cand;
    always_ff @(posedge clk_i) begin
        logic [27:0] mant;
        logic        half, rest;
        mant = k55_q >> k55_dr;
        half = k55_q[k55_dr - 5'd1];
        rest = (k55_q & ((28'd1 << (k55_dr - 5'd1)) - 28'd1)) != 0;
        k56_mant <= mant;
        k56_up <= half && (rest || k55_sticky || mant[0]);
        k56_e <= k55_e;
        k56_valid <= k55_valid;
        k56_poison <= k55_poison;
        k56_cand <= k55_cand;
    end

    // ================================================================ K57: round, pack (out)
    logic [31:0] t_bits;
    always_comb begin
        logic [27:0]        mant;
        logic signed [10:0] e;
        mant = k56_mant + 28'(k56_up);
        e = k56_e;
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
        sum_low_zero = k56_up ? (&k56_mant[23:0]) : (k56_mant[23:0] == 0);
        sum_bit24 = k56_mant[24] ^ (k56_up && (&k56_mant[23:0]));
        t_inf = k56_e > 11'sd127 || (k56_e == 11'sd127 && sum_bit24);
        t_zero = k56_e < -11'sd126 && sum_low_zero;
    end

    logic [TAG_W-1:0] tag_q;
    gridrt_delay #(.W(TAG_W), .N(STAGES)) u_tag (.clk_i, .d_i(in_tag_i), .q_o(tag_q));
    always_ff @(posedge clk_i) begin
        out_valid_o <= k56_valid;
        t_o <= t_bits;
        if (k56_poison) kind_o <= 2'd2;
        else if (k56_cand && !t_zero && !t_inf) kind_o <= 2'd1;
        else kind_o <= 2'd0;
    end
    assign out_tag_o = tag_q;
endmodule
