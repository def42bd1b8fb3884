// isect_pipe: one PE's ray-triangle test, fully pipelined (one test per cycle).
//
// Spec: rtl/README.md §3.3; twin: `twin::intersect`. Watertight test (Woop, Benthin, Wald,
// JCGT 2013) in Q23 fixed point: exact integer edge functions on per-vertex-rounded sheared
// coordinates, hit distance as the correctly rounded f32 of an exact rational.
//
// Inputs are one record (9 frame coordinates as i32 words, POISON = 0x80000000 where a
// coordinate did not fit) and the ray constants of the ray setup, which stay fixed while a
// ray's tests run. `kind`: 0 miss, 1 hit (`t` valid), 2 overflow. `tag` rides along.
module isect_pipe #(
    parameter int TAG_W = 1,
    parameter bit DSP_SHEAR = 0,    // shear products (6 x 25x35) in DSP blocks
    parameter bit DSP_EDGE = 1,     // edge products (6 x 30x30)
    parameter bit DSP_DEPTH = 1,    // depth products (3 x 35x35)
    parameter bit DSP_DEN = 0       // denominator (1 x 35x25)
) (
    input  logic                clk,
    input  logic                in_valid,
    input  logic [TAG_W-1:0]    in_tag,
    input  logic [287:0]        rec,        // 9 x i32, word i at bits 32i+31..32i
    // Ray constants (twin::RaySetup).
    input  logic signed [33:0]  o0, o1, o2, // origin, world axis order
    input  logic [1:0]          kz,
    input  logic signed [24:0]  sx, sy,
    input  logic                dz_neg,
    input  logic [23:0]         dz_abs,
    input  logic signed [9:0]   texp,
    input  logic                ray_overflow,
    output logic                out_valid,
    output logic [TAG_W-1:0]    out_tag,
    output logic [1:0]          kind,
    output logic [31:0]         t
);
    // Multiplier latencies (mul_pipe): 4 in DSP blocks; 5 in fabric for the 35 x 25 products
    // (13 radix-4 rows: 4 groups, 2 tree levels). Stage numbers below are for the default
    // parameters; every latency follows from these localparams.
    localparam int MUL_DSP = 4;
    localparam int MUL_FABRIC = 5;
    localparam int LAT_SHEAR = DSP_SHEAR ? MUL_DSP : MUL_FABRIC;
    localparam int LAT_EDGE = DSP_EDGE ? MUL_DSP : MUL_FABRIC;
    localparam int LAT_DEN = DSP_DEN ? MUL_DSP : MUL_FABRIC;
    // The depth products end with the denominator, which starts one cycle later.
    localparam int LAT_DEPTH = (DSP_DEPTH ? MUL_DSP : MUL_FABRIC) > LAT_DEN ? (DSP_DEPTH ? MUL_DSP : MUL_FABRIC) : LAT_DEN;
    localparam int DIV_STEPS = 27;
    // K1 K2 | shear | K8 K9 | edges | K14 K15 K16 K17 K18 K19 | depth | K25 K26 K27 K28 K29 |
    // division | K57 K58 K59 (out)
    localparam int LATENCY = 2 + LAT_SHEAR + 2 + LAT_EDGE + 6 + LAT_DEPTH + 5 + DIV_STEPS + 3;

    // ================================================================ K1: v - o, poison
    logic signed [34:0] k1_a [9];   // world order: vertex i axis a at 3i+a
    logic               k1_valid, k1_poison;
    always_ff @(posedge clk) begin
        k1_valid <= in_valid;
        k1_poison <= ray_overflow;
        for (int i = 0; i < 9; i++) begin
            logic signed [31:0] v;
            v = rec[32*i +: 32];
            if (v == 32'sh8000_0000) k1_poison <= 1'b1;
            case (i % 3)
                0: k1_a[i] <= 35'(v) - 35'(o0);
                1: k1_a[i] <= 35'(v) - 35'(o1);
                default: k1_a[i] <= 35'(v) - 35'(o2);
            endcase
        end
    end

    // ================================================================ K2: permute
    // Cyclic permutation moving axis kz to z: kz=0 (y,z,x), kz=1 (z,x,y), kz=2 (x,y,z).
    logic signed [34:0] k2_x [3], k2_y [3], k2_z [3];
    logic               k2_valid, k2_poison;
    always_ff @(posedge clk) begin
        k2_valid <= k1_valid;
        k2_poison <= k1_poison;
        for (int i = 0; i < 3; i++) begin
            case (kz)
                2'd0: begin k2_x[i] <= k1_a[3*i+1]; k2_y[i] <= k1_a[3*i+2]; k2_z[i] <= k1_a[3*i]; end
                2'd1: begin k2_x[i] <= k1_a[3*i+2]; k2_y[i] <= k1_a[3*i]; k2_z[i] <= k1_a[3*i+1]; end
                default: begin k2_x[i] <= k1_a[3*i]; k2_y[i] <= k1_a[3*i+1]; k2_z[i] <= k1_a[3*i+2]; end
            endcase
        end
    end

    // ================================================================ K3-K7: shear products
    // The 35-bit coordinate is the multiplicand: 13 rows of |s| (25 bits) instead of 18.
    logic signed [59:0] k7_px [3], k7_py [3];
    for (genvar i = 0; i < 3; i++) begin : g_shear
        mul_pipe #(.A_W(35), .B_W(25), .USE_DSP(DSP_SHEAR), .LATENCY(LAT_SHEAR)) u_mx (.clk, .a(k2_z[i]), .b(sx), .p(k7_px[i]));
        mul_pipe #(.A_W(35), .B_W(25), .USE_DSP(DSP_SHEAR), .LATENCY(LAT_SHEAR)) u_my (.clk, .a(k2_z[i]), .b(sy), .p(k7_py[i]));
    end
    logic signed [34:0] k7_x [3], k7_y [3], k7_z [3];
    logic               k7_valid, k7_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_xyz
        delay #(.W(35), .N(LAT_SHEAR)) u_dx (.clk, .d(k2_x[i]), .q(k7_x[i]));
        delay #(.W(35), .N(LAT_SHEAR)) u_dy (.clk, .d(k2_y[i]), .q(k7_y[i]));
        delay #(.W(35), .N(LAT_SHEAR)) u_dz (.clk, .d(k2_z[i]), .q(k7_z[i]));
    end
    delay #(.W(2), .N(LAT_SHEAR)) u_d7 (.clk, .d({k2_valid, k2_poison}), .q({k7_valid, k7_poison}));

    // ================================================================ K8: shear rounding
    // round_half_up(s * A.z / 2^23) = floor((s * A.z + 2^22) / 2^23).
    logic signed [36:0] k8_rx [3], k8_ry [3];
    logic signed [34:0] k8_x [3], k8_y [3], k8_z [3];
    logic               k8_valid, k8_poison;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) begin
            k8_rx[i] <= 37'((k7_px[i] + 60'sd4194304) >>> 23);
            k8_ry[i] <= 37'((k7_py[i] + 60'sd4194304) >>> 23);
        end
        k8_x <= k7_x;
        k8_y <= k7_y;
        k8_z <= k7_z;
        k8_valid <= k7_valid;
        k8_poison <= k7_poison;
    end

    // ================================================================ K9: lateral coordinates
    // x = A.x + rounded shear; range |x| < 2^29 else overflow.
    logic signed [29:0] k9_x [3], k9_y [3];
    logic signed [34:0] k9_z [3];
    logic               k9_valid, k9_poison;
    // |v| >= 2^29 for a 37-bit v, as bit tests (no comparator carry chain after the adder).
    function automatic logic out_of_range(input logic signed [36:0] v);
        if (!v[36]) out_of_range = v[35:29] != 0;
        else out_of_range = v[35:29] != 7'h7F || v[28:0] == 0;
    endfunction
    always_ff @(posedge clk) begin
        logic signed [36:0] lx, ly;
        logic               bad;
        bad = k8_poison;
        for (int i = 0; i < 3; i++) begin
            lx = 37'(k8_x[i]) + k8_rx[i];
            ly = 37'(k8_y[i]) + k8_ry[i];
            if (out_of_range(lx) || out_of_range(ly)) bad = 1'b1;
            k9_x[i] <= lx[29:0];
            k9_y[i] <= ly[29:0];
            k9_z[i] <= k8_z[i];
        end
        k9_valid <= k8_valid;
        k9_poison <= bad;
    end

    // ================================================================ K10-K13: edge products
    // e0 = bx*cy - by*cx, e1 = cx*ay - cy*ax, e2 = ax*by - ay*bx (exact).
    logic signed [59:0] k13_p [6];
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e0 (.clk, .a(k9_x[1]), .b(k9_y[2]), .p(k13_p[0]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e1 (.clk, .a(k9_y[1]), .b(k9_x[2]), .p(k13_p[1]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e2 (.clk, .a(k9_x[2]), .b(k9_y[0]), .p(k13_p[2]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e3 (.clk, .a(k9_y[2]), .b(k9_x[0]), .p(k13_p[3]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e4 (.clk, .a(k9_x[0]), .b(k9_y[1]), .p(k13_p[4]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE), .LATENCY(LAT_EDGE)) u_e5 (.clk, .a(k9_y[0]), .b(k9_x[1]), .p(k13_p[5]));
    logic signed [34:0] k13_z [3];
    logic               k13_valid, k13_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_z13
        delay #(.W(35), .N(LAT_EDGE)) u_dz (.clk, .d(k9_z[i]), .q(k13_z[i]));
    end
    delay #(.W(2), .N(LAT_EDGE)) u_d13 (.clk, .d({k9_valid, k9_poison}), .q({k13_valid, k13_poison}));

    // ================================================================ K14: edge functions
    logic signed [60:0] k14_e [3];
    logic signed [34:0] k14_z [3];
    logic               k14_valid, k14_poison;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) begin
            k14_e[i] <= 61'(k13_p[2*i]) - 61'(k13_p[2*i+1]);
            k14_z[i] <= k13_z[i];
        end
        k14_valid <= k13_valid;
        k14_poison <= k13_poison;
    end

    // ================================================================ K15: sign test, e0 + e1
    logic signed [62:0] k15_e01;
    logic signed [60:0] k15_e [3];
    logic signed [34:0] k15_z [3];
    logic               k15_valid, k15_poison, k15_cand;
    always_ff @(posedge clk) begin
        logic any_neg, any_pos;
        any_neg = k14_e[0] < 0 || k14_e[1] < 0 || k14_e[2] < 0;
        any_pos = k14_e[0] > 0 || k14_e[1] > 0 || k14_e[2] > 0;
        k15_cand <= !(any_neg && any_pos);
        k15_e01 <= 63'(k14_e[0]) + 63'(k14_e[1]);
        k15_e <= k14_e;
        k15_z <= k14_z;
        k15_valid <= k14_valid;
        k15_poison <= k14_poison;
    end

    // ================================================================ K16: det
    logic signed [62:0] k16_det;
    logic signed [60:0] k16_e [3];
    logic signed [34:0] k16_z [3];
    logic               k16_valid, k16_poison, k16_cand;
    always_ff @(posedge clk) begin
        k16_det <= k15_e01 + 63'(k15_e[2]);
        k16_e <= k15_e;
        k16_z <= k15_z;
        k16_valid <= k15_valid;
        k16_poison <= k15_poison;
        k16_cand <= k15_cand;
    end

    // ================================================================ K17: sign-normalise
    logic [61:0]        k17_det;    // > 0 for a candidate
    logic [60:0]        k17_e [3];  // >= 0 for a candidate
    logic signed [34:0] k17_z [3];
    logic               k17_valid, k17_poison, k17_cand;
    always_ff @(posedge clk) begin
        logic neg;
        neg = k16_det < 0;
        for (int i = 0; i < 3; i++) k17_e[i] <= neg ? 61'(-k16_e[i]) : 61'(k16_e[i]);
        k17_det <= neg ? 62'(-k16_det) : 62'(k16_det);
        k17_cand <= k16_cand && k16_det != 0;
        k17_z <= k16_z;
        k17_valid <= k16_valid;
        k17_poison <= k16_poison;
    end

    // ================================================================ K18: weight shift
    // r = max(0, bitlen(det) - 34).
    logic [5:0]         det_len;
    bit_length #(.W(62)) u_det_len (.x(k17_det), .len(det_len));
    logic [4:0]         k18_r;
    logic [60:0]        k18_e [3];
    logic signed [34:0] k18_z [3];
    logic               k18_valid, k18_poison, k18_cand;
    always_ff @(posedge clk) begin
        k18_r <= (det_len > 6'd34) ? 5'(det_len - 6'd34) : 5'd0;
        k18_e <= k17_e;
        k18_z <= k17_z;
        k18_valid <= k17_valid;
        k18_poison <= k17_poison;
        k18_cand <= k17_cand;
    end

    // ================================================================ K19: weights
    logic signed [34:0] k19_w [3];  // < 2^34 for a candidate
    logic signed [34:0] k19_z [3];
    logic               k19_valid, k19_poison, k19_cand;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) k19_w[i] <= 35'(k18_e[i] >> k18_r);
        k19_z <= k18_z;
        k19_valid <= k18_valid;
        k19_poison <= k18_poison;
        k19_cand <= k18_cand;
    end

    // ================================================================ K20: weight sum
    // det' = sum of weights (< 2^34), registered while the depth products start.
    logic signed [34:0] k20_detw;
    always_ff @(posedge clk) k20_detw <= k19_w[0] + k19_w[1] + k19_w[2];

    // ================================================================ K20-K24: depth products
    logic signed [69:0] k24_n [3];
    for (genvar i = 0; i < 3; i++) begin : g_depth
        mul_pipe #(.A_W(35), .B_W(35), .USE_DSP(DSP_DEPTH), .LATENCY(LAT_DEPTH)) u_n (.clk, .a(k19_w[i]), .b(k19_z[i]), .p(k24_n[i]));
    end
    // Denominator det' * |dz| starts one cycle later and ends with the first depth sum (K25).
    logic signed [59:0] k25_den;
    mul_pipe #(.A_W(35), .B_W(25), .USE_DSP(DSP_DEN), .LATENCY(LAT_DEPTH)) u_den (.clk, .a(k20_detw), .b({1'b0, dz_abs}), .p(k25_den));
    logic k24_valid, k24_poison, k24_cand;
    delay #(.W(3), .N(LAT_DEPTH)) u_d24 (.clk, .d({k19_valid, k19_poison, k19_cand}), .q({k24_valid, k24_poison, k24_cand}));

    // ================================================================ K25: n0 + n1
    logic signed [71:0] k25_n01;
    logic signed [69:0] k25_n2;
    logic               k25_valid, k25_poison, k25_cand;
    always_ff @(posedge clk) begin
        k25_n01 <= 72'(k24_n[0]) + 72'(k24_n[1]);
        k25_n2 <= k24_n[2];
        k25_valid <= k24_valid;
        k25_poison <= k24_poison;
        k25_cand <= k24_cand;
    end

    // ================================================================ K26: depth sum
    logic signed [71:0] k26_n;
    logic [57:0]        k26_den;
    logic               k26_valid, k26_poison, k26_cand;
    always_ff @(posedge clk) begin
        k26_n <= k25_n01 + 72'(k25_n2);
        k26_den <= k25_den[57:0];
        k26_valid <= k25_valid;
        k26_poison <= k25_poison;
        k26_cand <= k25_cand;
    end

    // ================================================================ K27: front test, |N|
    // N is negated when dz < 0; a candidate needs N > 0, and then |n| is N.
    logic [69:0]  k27_n;
    logic [57:0]  k27_den;
    logic         k27_valid, k27_poison, k27_cand;
    always_ff @(posedge clk) begin
        logic front;
        front = dz_neg ? k26_n < 0 : k26_n > 0;
        k27_n <= 70'(k26_n[71] ? -k26_n : k26_n);
        k27_den <= k26_den;
        k27_valid <= k26_valid;
        k27_poison <= k26_poison;
        k27_cand <= k26_cand && front;
    end

    // ================================================================ K28: operand lengths
    logic [6:0]   n_len;
    logic [5:0]   den_len;
    bit_length #(.W(70)) u_n_len (.x(k27_n), .len(n_len));
    bit_length #(.W(58)) u_den_len (.x(k27_den), .len(den_len));
    logic [69:0]  k28_n;
    logic [57:0]  k28_den;
    logic [6:0]   k28_ln;
    logic [5:0]   k28_ld;
    logic         k28_valid, k28_poison, k28_cand;
    always_ff @(posedge clk) begin
        k28_n <= k27_n;
        k28_den <= k27_den;
        k28_ln <= n_len;
        k28_ld <= den_len;
        k28_valid <= k27_valid;
        k28_poison <= k27_poison;
        k28_cand <= k27_cand;
    end

    // ================================================================ K29: normalise operands
    logic [69:0]         k29_nn;
    logic [57:0]         k29_dn;
    logic signed [10:0]  k29_exp;
    logic                k29_valid, k29_poison, k29_cand;
    always_ff @(posedge clk) begin
        k29_nn <= k28_n << (7'd70 - k28_ln);
        k29_dn <= k28_den << (6'd58 - k28_ld);
        k29_exp <= 11'($signed({4'd0, k28_ln})) - 11'($signed({5'd0, k28_ld})) - 11'sd26 + 11'(texp);
        k29_valid <= k28_valid;
        k29_poison <= k28_poison;
        k29_cand <= k28_cand;
    end

    // ================================================================ K30-K56: division
    // q = floor(nn * 2^14 / dn) (27 bits), sticky = remainder != 0: one quotient bit per
    // stage, restoring. The dividend's bits below the initial window enter one per stage.
    logic [58:0] dv_r   [DIV_STEPS+1];
    logic [57:0] dv_d   [DIV_STEPS+1];
    logic [12:0] dv_low [DIV_STEPS+1];  // nn[12:0], consumed MSB first
    logic [26:0] dv_q   [DIV_STEPS+1];
    assign dv_r[0] = {2'b00, k29_nn[69:13]};
    assign dv_d[0] = k29_dn;
    assign dv_low[0] = k29_nn[12:0];
    assign dv_q[0] = 27'd0;
    for (genvar j = 0; j < DIV_STEPS; j++) begin : g_div
        always_ff @(posedge clk) begin
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
    logic signed [10:0] k56_exp;
    logic               k56_valid, k56_poison, k56_cand;
    delay #(.W(14), .N(DIV_STEPS)) u_d56 (.clk, .d({k29_exp, k29_valid, k29_poison, k29_cand}),
                                          .q({k56_exp, k56_valid, k56_poison, k56_cand}));

    // ================================================================ K57: rounding position
    // The quotient q (27 bits) has its leading one at bit 26 or 25. e = exponent of the
    // leading one; dr = bits to drop: down to 24 significant bits, or to the subnormal grid
    // 2^-149, at most 28.
    logic [27:0]        k57_q;          // quotient with a zero bit on top
    logic               k57_sticky;
    logic signed [10:0] k57_e;
    logic [4:0]         k57_dr;
    logic               k57_valid, k57_poison, k57_cand;
    always_ff @(posedge clk) begin
        logic [5:0]         p;
        logic signed [10:0] e, drop;
        p = dv_q[DIV_STEPS][26] ? 6'd27 : 6'd26;
        e = 11'(p) - 11'sd1 + k56_exp;
        drop = (e >= -11'sd126) ? 11'(p) - 11'sd24 : -11'sd149 - k56_exp;
        k57_q <= {1'b0, dv_q[DIV_STEPS]};
        k57_sticky <= dv_r[DIV_STEPS] != 0;
        k57_e <= e;
        k57_dr <= (drop > 11'sd28) ? 5'd28 : 5'(drop);
        k57_valid <= k56_valid;
        k57_poison <= k56_poison;
        k57_cand <= k56_cand;
    end

    // ================================================================ K58: mantissa, round bit
    logic [27:0]        k58_mant;
    logic               k58_up;
    logic signed [10:0] k58_e;
    logic               k58_valid, k58_poison, k58_cand;
    always_ff @(posedge clk) begin
        logic [27:0] mant;
        logic        half, rest;
        mant = k57_q >> k57_dr;
        half = k57_q[k57_dr - 5'd1];
        rest = (k57_q & ((28'd1 << (k57_dr - 5'd1)) - 28'd1)) != 0;
        k58_mant <= mant;
        k58_up <= half && (rest || k57_sticky || mant[0]);
        k58_e <= k57_e;
        k58_valid <= k57_valid;
        k58_poison <= k57_poison;
        k58_cand <= k57_cand;
    end

    // ================================================================ K59: round, pack (out)
    logic [31:0] t_bits;
    always_comb begin
        logic [27:0]        mant;
        logic signed [10:0] e;
        mant = k58_mant + 28'(k58_up);
        e = k58_e;
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

    logic [TAG_W-1:0] tag_q;
    delay #(.W(TAG_W), .N(LATENCY)) u_tag (.clk, .d(in_tag), .q(tag_q));
    always_ff @(posedge clk) begin
        out_valid <= k58_valid;
        t <= t_bits;
        if (k58_poison) kind <= 2'd2;
        else if (k58_cand && t_bits != 32'd0 && t_bits != 32'h7F80_0000) kind <= 2'd1;
        else kind <= 2'd0;
    end
    assign out_tag = tag_q;
endmodule
