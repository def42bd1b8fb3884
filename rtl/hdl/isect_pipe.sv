// isect_pipe: one PE's ray-triangle test, pipelined with one test every two cycles.
//
// Spec: rtl/README.md §3.3; twin: `twin::intersect`. Watertight test (Woop, Benthin, Wald,
// JCGT 2013) in Q23 fixed point: exact integer edge functions on per-vertex-rounded sheared
// coordinates, hit distance as the correctly rounded f32 of an exact rational.
//
// Inputs are one record (9 frame coordinates as i32 words, POISON = 0x80000000 where a
// coordinate did not fit) and the ray constants of the ray setup, which stay fixed while a
// ray's tests run. `kind`: 0 miss, 1 hit (`t` valid), 2 overflow. `tag` rides along.
//
// Issue interval 2: `in_valid` is never high in two consecutive cycles (the PE's issue loop
// guarantees it). Each multiplier does two of a test's 16 products, one per cycle, so a test
// needs 8 multipliers (32 MULT18X18D) and no fabric multiplier (rtl/README.md §5: the 4-PE
// design fits the ECP5-85F only so). The registers feeding a multiplier load on valid and
// hold through the following cycle, which presents the second product's operands.
module isect_pipe #(
    parameter int TAG_W = 1
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
    // Multiplier latency (mul_pipe in MULT18X18D blocks); a shared multiplier's second
    // product comes one cycle after its first, so each product pair takes MUL + 1 stages.
    // Stage numbers below follow from these localparams.
    localparam int MUL = 4;
    localparam int LAT_PAIR = MUL + 1;
    localparam int DIV_STEPS = 27;
    // K1 K2 | shear | K8 K9 | edges | K15 K16 K17 K18 K19 K20 | depth | K26 K27 K28 K29 K30 |
    // division | K58 K59 K60 (out)
    localparam int LATENCY = 2 + LAT_PAIR + 2 + LAT_PAIR + 6 + LAT_PAIR + 5 + DIV_STEPS + 3;

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

    // ================================================================ K2: permute (held)
    // Cyclic permutation moving axis kz to z: kz=0 (y,z,x), kz=1 (z,x,y), kz=2 (x,y,z).
    logic signed [34:0] k2_x [3], k2_y [3], k2_z [3];
    logic               k2_valid, k2_poison;
    always_ff @(posedge clk) begin
        k2_valid <= k1_valid;
        if (k1_valid) begin
            k2_poison <= k1_poison;
            for (int i = 0; i < 3; i++) begin
                case (kz)
                    2'd0: begin k2_x[i] <= k1_a[3*i+1]; k2_y[i] <= k1_a[3*i+2]; k2_z[i] <= k1_a[3*i]; end
                    2'd1: begin k2_x[i] <= k1_a[3*i+2]; k2_y[i] <= k1_a[3*i]; k2_z[i] <= k1_a[3*i+1]; end
                    default: begin k2_x[i] <= k1_a[3*i]; k2_y[i] <= k1_a[3*i+1]; k2_z[i] <= k1_a[3*i+2]; end
                endcase
            end
        end
    end

    // ================================================================ K3-K7: shear products
    // Multiplier i: sx * A.z in the valid cycle, sy * A.z in the next (K2 held).
    logic signed [59:0] sh_p [3], sh_p1 [3];
    logic signed [59:0] k7_px [3], k7_py [3];
    for (genvar i = 0; i < 3; i++) begin : g_shear
        mul_pipe #(.A_W(35), .B_W(25), .LATENCY(MUL)) u_m (.clk, .a(k2_z[i]), .b(k2_valid ? sx : sy), .p(sh_p[i]));
        always_ff @(posedge clk) sh_p1[i] <= sh_p[i];
        assign k7_px[i] = sh_p1[i];
        assign k7_py[i] = sh_p[i];
    end
    logic signed [34:0] k7_x [3], k7_y [3], k7_z [3];
    logic               k7_valid, k7_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_xyz
        delay #(.W(35), .N(LAT_PAIR)) u_dx (.clk, .d(k2_x[i]), .q(k7_x[i]));
        delay #(.W(35), .N(LAT_PAIR)) u_dy (.clk, .d(k2_y[i]), .q(k7_y[i]));
        delay #(.W(35), .N(LAT_PAIR)) u_dz (.clk, .d(k2_z[i]), .q(k7_z[i]));
    end
    delay #(.W(2), .N(LAT_PAIR)) u_d7 (.clk, .d({k2_valid, k2_poison}), .q({k7_valid, k7_poison}));

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
        k9_valid <= k8_valid;
        // Held through the next cycle: the edge products' second operands.
        if (k8_valid) begin
            for (int i = 0; i < 3; i++) begin
                lx = 37'(k8_x[i]) + k8_rx[i];
                ly = 37'(k8_y[i]) + k8_ry[i];
                if (out_of_range(lx) || out_of_range(ly)) bad = 1'b1;
                k9_x[i] <= lx[29:0];
                k9_y[i] <= ly[29:0];
                k9_z[i] <= k8_z[i];
            end
            k9_poison <= bad;
        end
    end

    // ================================================================ K10-K14: edge products
    // e0 = bx*cy - by*cx, e1 = cx*ay - cy*ax, e2 = ax*by - ay*bx (exact). Multiplier i makes
    // e_i's first product in the valid cycle and its second in the next (K9 held).
    logic signed [59:0] ed_p [3], ed_p1 [3];
    logic signed [29:0] ed_a [3], ed_b [3];
    always_comb begin
        // First products bx*cy, cx*ay, ax*by; second by*cx, cy*ax, ay*bx.
        for (int i = 0; i < 3; i++) begin
            ed_a[i] = k9_valid ? k9_x[(i+1)%3] : k9_y[(i+1)%3];
            ed_b[i] = k9_valid ? k9_y[(i+2)%3] : k9_x[(i+2)%3];
        end
    end
    for (genvar i = 0; i < 3; i++) begin : g_edge
        mul_pipe #(.A_W(30), .B_W(30), .LATENCY(MUL)) u_m (.clk, .a(ed_a[i]), .b(ed_b[i]), .p(ed_p[i]));
        always_ff @(posedge clk) ed_p1[i] <= ed_p[i];
    end
    logic signed [34:0] k14_z [3];
    logic               k14_valid, k14_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_z14
        delay #(.W(35), .N(LAT_PAIR)) u_dz (.clk, .d(k9_z[i]), .q(k14_z[i]));
    end
    delay #(.W(2), .N(LAT_PAIR)) u_d14 (.clk, .d({k9_valid, k9_poison}), .q({k14_valid, k14_poison}));

    // ================================================================ K15: edge functions
    logic signed [60:0] k15_e [3];
    logic signed [34:0] k15_z [3];
    logic               k15_valid, k15_poison;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) begin
            k15_e[i] <= 61'(ed_p1[i]) - 61'(ed_p[i]);
            k15_z[i] <= k14_z[i];
        end
        k15_valid <= k14_valid;
        k15_poison <= k14_poison;
    end

    // ================================================================ K16: sign test, e0 + e1
    logic signed [62:0] k16_e01;
    logic signed [60:0] k16_e [3];
    logic signed [34:0] k16_z [3];
    logic               k16_valid, k16_poison, k16_cand;
    always_ff @(posedge clk) begin
        logic any_neg, any_pos;
        any_neg = k15_e[0] < 0 || k15_e[1] < 0 || k15_e[2] < 0;
        any_pos = k15_e[0] > 0 || k15_e[1] > 0 || k15_e[2] > 0;
        k16_cand <= !(any_neg && any_pos);
        k16_e01 <= 63'(k15_e[0]) + 63'(k15_e[1]);
        k16_e <= k15_e;
        k16_z <= k15_z;
        k16_valid <= k15_valid;
        k16_poison <= k15_poison;
    end

    // ================================================================ K17: det
    logic signed [62:0] k17_det;
    logic signed [60:0] k17_e [3];
    logic signed [34:0] k17_z [3];
    logic               k17_valid, k17_poison, k17_cand;
    always_ff @(posedge clk) begin
        k17_det <= k16_e01 + 63'(k16_e[2]);
        k17_e <= k16_e;
        k17_z <= k16_z;
        k17_valid <= k16_valid;
        k17_poison <= k16_poison;
        k17_cand <= k16_cand;
    end

    // ================================================================ K18: sign-normalise
    logic [61:0]        k18_det;    // > 0 for a candidate
    logic [60:0]        k18_e [3];  // >= 0 for a candidate
    logic signed [34:0] k18_z [3];
    logic               k18_valid, k18_poison, k18_cand;
    always_ff @(posedge clk) begin
        logic neg;
        neg = k17_det < 0;
        for (int i = 0; i < 3; i++) k18_e[i] <= neg ? 61'(-k17_e[i]) : 61'(k17_e[i]);
        k18_det <= neg ? 62'(-k17_det) : 62'(k17_det);
        k18_cand <= k17_cand && k17_det != 0;
        k18_z <= k17_z;
        k18_valid <= k17_valid;
        k18_poison <= k17_poison;
    end

    // ================================================================ K19: weight shift
    // r = max(0, bitlen(det) - 34).
    logic [5:0]         det_len;
    bit_length #(.W(62)) u_det_len (.x(k18_det), .len(det_len));
    logic [4:0]         k19_r;
    logic [60:0]        k19_e [3];
    logic signed [34:0] k19_z [3];
    logic               k19_valid, k19_poison, k19_cand;
    always_ff @(posedge clk) begin
        k19_r <= (det_len > 6'd34) ? 5'(det_len - 6'd34) : 5'd0;
        k19_e <= k18_e;
        k19_z <= k18_z;
        k19_valid <= k18_valid;
        k19_poison <= k18_poison;
        k19_cand <= k18_cand;
    end

    // ================================================================ K20: weights
    logic signed [34:0] k20_w [3];  // < 2^34 for a candidate
    logic signed [34:0] k20_z [3];
    logic               k20_valid, k20_poison, k20_cand;
    always_ff @(posedge clk) begin
        k20_valid <= k19_valid;
        // Held through the next cycle: the depth products' second operands.
        if (k19_valid) begin
            for (int i = 0; i < 3; i++) k20_w[i] <= 35'(k19_e[i] >> k19_r);
            k20_z <= k19_z;
            k20_poison <= k19_poison;
            k20_cand <= k19_cand;
        end
    end

    // ================================================================ K21: weight sum
    // det' = sum of weights (< 2^34), registered for the denominator's product in K21.
    logic signed [34:0] k21_detw;
    always_ff @(posedge clk) k21_detw <= k20_w[0] + k20_w[1] + k20_w[2];

    // ================================================================ K21-K25: depth products
    // N = w0*z0 + w1*z1 + w2*z2 and D = det' * |dz|. Multiplier 0: w0*z0, then w2*z2;
    // multiplier 1: w1*z1, then det'*|dz| (K20 held; det' registered in between).
    logic signed [34:0] dp_a [2], dp_b [2];
    logic signed [69:0] dp_p [2], dp_p1 [2];
    always_comb begin
        dp_a[0] = k20_valid ? k20_w[0] : k20_w[2];
        dp_b[0] = k20_valid ? k20_z[0] : k20_z[2];
        dp_a[1] = k20_valid ? k20_w[1] : k21_detw;
        dp_b[1] = k20_valid ? k20_z[1] : 35'($signed({1'b0, dz_abs}));
    end
    for (genvar i = 0; i < 2; i++) begin : g_depth
        mul_pipe #(.A_W(35), .B_W(35), .LATENCY(MUL)) u_m (.clk, .a(dp_a[i]), .b(dp_b[i]), .p(dp_p[i]));
        always_ff @(posedge clk) dp_p1[i] <= dp_p[i];
    end
    logic k25_valid, k25_poison, k25_cand;
    delay #(.W(3), .N(LAT_PAIR)) u_d25 (.clk, .d({k20_valid, k20_poison, k20_cand}), .q({k25_valid, k25_poison, k25_cand}));

    // ================================================================ K26: n0 + n1
    logic signed [71:0] k26_n01;
    logic signed [69:0] k26_n2;
    logic [57:0]        k26_den;    // < 2^34 * 2^24
    logic               k26_valid, k26_poison, k26_cand;
    always_ff @(posedge clk) begin
        k26_n01 <= 72'(dp_p1[0]) + 72'(dp_p1[1]);
        k26_n2 <= dp_p[0];
        k26_den <= dp_p[1][57:0];
        k26_valid <= k25_valid;
        k26_poison <= k25_poison;
        k26_cand <= k25_cand;
    end

    // ================================================================ K27: depth sum
    logic signed [71:0] k27_n;
    logic [57:0]        k27_den;
    logic               k27_valid, k27_poison, k27_cand;
    always_ff @(posedge clk) begin
        k27_n <= k26_n01 + 72'(k26_n2);
        k27_den <= k26_den;
        k27_valid <= k26_valid;
        k27_poison <= k26_poison;
        k27_cand <= k26_cand;
    end

    // ================================================================ K28: front test, |N|
    // N is negated when dz < 0; a candidate needs N > 0, and then |n| is N.
    logic [69:0]  k28_n;
    logic [57:0]  k28_den;
    logic         k28_valid, k28_poison, k28_cand;
    always_ff @(posedge clk) begin
        logic front;
        front = dz_neg ? k27_n < 0 : k27_n > 0;
        k28_n <= 70'(k27_n[71] ? -k27_n : k27_n);
        k28_den <= k27_den;
        k28_valid <= k27_valid;
        k28_poison <= k27_poison;
        k28_cand <= k27_cand && front;
    end

    // ================================================================ K29: operand lengths
    logic [6:0]   n_len;
    logic [5:0]   den_len;
    bit_length #(.W(70)) u_n_len (.x(k28_n), .len(n_len));
    bit_length #(.W(58)) u_den_len (.x(k28_den), .len(den_len));
    logic [69:0]  k29_n;
    logic [57:0]  k29_den;
    logic [6:0]   k29_ln;
    logic [5:0]   k29_ld;
    logic         k29_valid, k29_poison, k29_cand;
    always_ff @(posedge clk) begin
        k29_n <= k28_n;
        k29_den <= k28_den;
        k29_ln <= n_len;
        k29_ld <= den_len;
        k29_valid <= k28_valid;
        k29_poison <= k28_poison;
        k29_cand <= k28_cand;
    end

    // ================================================================ K30: normalise operands
    logic [69:0]         k30_nn;
    logic [57:0]         k30_dn;
    logic signed [10:0]  k30_exp;
    logic                k30_valid, k30_poison, k30_cand;
    always_ff @(posedge clk) begin
        k30_nn <= k29_n << (7'd70 - k29_ln);
        k30_dn <= k29_den << (6'd58 - k29_ld);
        k30_exp <= 11'($signed({4'd0, k29_ln})) - 11'($signed({5'd0, k29_ld})) - 11'sd26 + 11'(texp);
        k30_valid <= k29_valid;
        k30_poison <= k29_poison;
        k30_cand <= k29_cand;
    end

    // ================================================================ K31-K57: division
    // q = floor(nn * 2^14 / dn) (27 bits), sticky = remainder != 0: one quotient bit per
    // stage, restoring. The dividend's bits below the initial window enter one per stage.
    logic [58:0] dv_r   [DIV_STEPS+1];
    logic [57:0] dv_d   [DIV_STEPS+1];
    logic [12:0] dv_low [DIV_STEPS+1];  // nn[12:0], consumed MSB first
    logic [26:0] dv_q   [DIV_STEPS+1];
    assign dv_r[0] = {2'b00, k30_nn[69:13]};
    assign dv_d[0] = k30_dn;
    assign dv_low[0] = k30_nn[12:0];
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
    logic signed [10:0] k57_exp;
    logic               k57_valid, k57_poison, k57_cand;
    delay #(.W(14), .N(DIV_STEPS)) u_d57 (.clk, .d({k30_exp, k30_valid, k30_poison, k30_cand}),
                                          .q({k57_exp, k57_valid, k57_poison, k57_cand}));

    // ================================================================ K58: rounding position
    // The quotient q (27 bits) has its leading one at bit 26 or 25. e = exponent of the
    // leading one; dr = bits to drop: down to 24 significant bits, or to the subnormal grid
    // 2^-149, at most 28.
    logic [27:0]        k58_q;          // quotient with a zero bit on top
    logic               k58_sticky;
    logic signed [10:0] k58_e;
    logic [4:0]         k58_dr;
    logic               k58_valid, k58_poison, k58_cand;
    always_ff @(posedge clk) begin
        logic [5:0]         p;
        logic signed [10:0] e, drop;
        p = dv_q[DIV_STEPS][26] ? 6'd27 : 6'd26;
        e = 11'(p) - 11'sd1 + k57_exp;
        drop = (e >= -11'sd126) ? 11'(p) - 11'sd24 : -11'sd149 - k57_exp;
        k58_q <= {1'b0, dv_q[DIV_STEPS]};
        k58_sticky <= dv_r[DIV_STEPS] != 0;
        k58_e <= e;
        k58_dr <= (drop > 11'sd28) ? 5'd28 : 5'(drop);
        k58_valid <= k57_valid;
        k58_poison <= k57_poison;
        k58_cand <= k57_cand;
    end

    // ================================================================ K59: mantissa, round bit
    logic [27:0]        k59_mant;
    logic               k59_up;
    logic signed [10:0] k59_e;
    logic               k59_valid, k59_poison, k59_cand;
    always_ff @(posedge clk) begin
        logic [27:0] mant;
        logic        half, rest;
        mant = k58_q >> k58_dr;
        half = k58_q[k58_dr - 5'd1];
        rest = (k58_q & ((28'd1 << (k58_dr - 5'd1)) - 28'd1)) != 0;
        k59_mant <= mant;
        k59_up <= half && (rest || k58_sticky || mant[0]);
        k59_e <= k58_e;
        k59_valid <= k58_valid;
        k59_poison <= k58_poison;
        k59_cand <= k58_cand;
    end

    // ================================================================ K60: round, pack (out)
    logic [31:0] t_bits;
    always_comb begin
        logic [27:0]        mant;
        logic signed [10:0] e;
        mant = k59_mant + 28'(k59_up);
        e = k59_e;
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
    delay_ram #(.W(TAG_W), .N(LATENCY)) u_tag (.clk, .d(in_tag), .q(tag_q));
    always_ff @(posedge clk) begin
        out_valid <= k59_valid;
        t <= t_bits;
        if (k59_poison) kind <= 2'd2;
        else if (k59_cand && t_bits != 32'd0 && t_bits != 32'h7F80_0000) kind <= 2'd1;
        else kind <= 2'd0;
    end
    assign out_tag = tag_q;
endmodule
