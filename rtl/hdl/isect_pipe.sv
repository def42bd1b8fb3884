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
    // K1 K2 K3-5 K6 K7-9 K10 K11 K12 K13 K14 K15-17 K18 K19 K20 K21-47 out
    localparam int LATENCY = 1 + 1 + 3 + 1 + 3 + 1 + 1 + 1 + 1 + 1 + 3 + 1 + 1 + 1 + 27 + 1;

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

    // ================================================================ K3-K5: shear products
    logic signed [59:0] k5_px [3], k5_py [3];
    for (genvar i = 0; i < 3; i++) begin : g_shear
        mul_pipe #(.A_W(25), .B_W(35), .USE_DSP(DSP_SHEAR)) u_mx (.clk, .a(sx), .b(k2_z[i]), .p(k5_px[i]));
        mul_pipe #(.A_W(25), .B_W(35), .USE_DSP(DSP_SHEAR)) u_my (.clk, .a(sy), .b(k2_z[i]), .p(k5_py[i]));
    end
    logic signed [34:0] k5_x [3], k5_y [3], k5_z [3];
    logic               k5_valid, k5_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_xyz
        delay #(.W(35), .N(3)) u_dx (.clk, .d(k2_x[i]), .q(k5_x[i]));
        delay #(.W(35), .N(3)) u_dy (.clk, .d(k2_y[i]), .q(k5_y[i]));
        delay #(.W(35), .N(3)) u_dz (.clk, .d(k2_z[i]), .q(k5_z[i]));
    end
    delay #(.W(2), .N(3)) u_d5 (.clk, .d({k2_valid, k2_poison}), .q({k5_valid, k5_poison}));

    // ================================================================ K6: lateral coordinates
    // x = A.x + round_half_up(sx * A.z / 2^23); range |x| < 2^29 else overflow.
    logic signed [29:0] k6_x [3], k6_y [3];
    logic signed [34:0] k6_z [3];
    logic               k6_valid, k6_poison;
    always_ff @(posedge clk) begin
        logic signed [36:0] lx, ly;
        logic               bad;
        bad = k5_poison;
        for (int i = 0; i < 3; i++) begin
            lx = 37'(k5_x[i]) + 37'((k5_px[i] + 60'sd4194304) >>> 23);
            ly = 37'(k5_y[i]) + 37'((k5_py[i] + 60'sd4194304) >>> 23);
            if (lx >= 37'sd536870912 || lx <= -37'sd536870912) bad = 1'b1;
            if (ly >= 37'sd536870912 || ly <= -37'sd536870912) bad = 1'b1;
            k6_x[i] <= lx[29:0];
            k6_y[i] <= ly[29:0];
            k6_z[i] <= k5_z[i];
        end
        k6_valid <= k5_valid;
        k6_poison <= bad;
    end

    // ================================================================ K7-K9: edge products
    // e0 = bx*cy - by*cx, e1 = cx*ay - cy*ax, e2 = ax*by - ay*bx (exact).
    logic signed [59:0] k9_p [6];
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e0 (.clk, .a(k6_x[1]), .b(k6_y[2]), .p(k9_p[0]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e1 (.clk, .a(k6_y[1]), .b(k6_x[2]), .p(k9_p[1]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e2 (.clk, .a(k6_x[2]), .b(k6_y[0]), .p(k9_p[2]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e3 (.clk, .a(k6_y[2]), .b(k6_x[0]), .p(k9_p[3]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e4 (.clk, .a(k6_x[0]), .b(k6_y[1]), .p(k9_p[4]));
    mul_pipe #(.A_W(30), .B_W(30), .USE_DSP(DSP_EDGE)) u_e5 (.clk, .a(k6_y[0]), .b(k6_x[1]), .p(k9_p[5]));
    logic signed [34:0] k9_z [3];
    logic               k9_valid, k9_poison;
    for (genvar i = 0; i < 3; i++) begin : g_carry_z9
        delay #(.W(35), .N(3)) u_dz (.clk, .d(k6_z[i]), .q(k9_z[i]));
    end
    delay #(.W(2), .N(3)) u_d9 (.clk, .d({k6_valid, k6_poison}), .q({k9_valid, k9_poison}));

    // ================================================================ K10: edge functions
    logic signed [60:0] k10_e [3];
    logic signed [34:0] k10_z [3];
    logic               k10_valid, k10_poison;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) begin
            k10_e[i] <= 61'(k9_p[2*i]) - 61'(k9_p[2*i+1]);
            k10_z[i] <= k9_z[i];
        end
        k10_valid <= k9_valid;
        k10_poison <= k9_poison;
    end

    // ================================================================ K11: sign test, det
    logic signed [62:0] k11_det;
    logic signed [60:0] k11_e [3];
    logic signed [34:0] k11_z [3];
    logic               k11_valid, k11_poison, k11_cand;
    always_ff @(posedge clk) begin
        logic any_neg, any_pos;
        any_neg = k10_e[0] < 0 || k10_e[1] < 0 || k10_e[2] < 0;
        any_pos = k10_e[0] > 0 || k10_e[1] > 0 || k10_e[2] > 0;
        k11_cand <= !(any_neg && any_pos);
        k11_det <= 63'(k10_e[0]) + 63'(k10_e[1]) + 63'(k10_e[2]);
        k11_e <= k10_e;
        k11_z <= k10_z;
        k11_valid <= k10_valid;
        k11_poison <= k10_poison;
    end

    // ================================================================ K12: sign-normalise
    logic [61:0]        k12_det;    // > 0 for a candidate
    logic [60:0]        k12_e [3];  // >= 0 for a candidate
    logic signed [34:0] k12_z [3];
    logic               k12_valid, k12_poison, k12_cand;
    always_ff @(posedge clk) begin
        logic neg;
        neg = k11_det < 0;
        for (int i = 0; i < 3; i++) k12_e[i] <= neg ? 61'(-k11_e[i]) : 61'(k11_e[i]);
        k12_det <= neg ? 62'(-k11_det) : 62'(k11_det);
        k12_cand <= k11_cand && k11_det != 0;
        k12_z <= k11_z;
        k12_valid <= k11_valid;
        k12_poison <= k11_poison;
    end

    // ================================================================ K13: weight shift
    // r = max(0, bitlen(det) - 34).
    logic [4:0]         k13_r;
    logic [60:0]        k13_e [3];
    logic signed [34:0] k13_z [3];
    logic               k13_valid, k13_poison, k13_cand;
    always_ff @(posedge clk) begin
        logic [5:0] len;
        len = 6'd0;
        for (int i = 0; i < 62; i++) if (k12_det[i]) len = 6'(i + 1);
        k13_r <= (len > 6'd34) ? 5'(len - 6'd34) : 5'd0;
        k13_e <= k12_e;
        k13_z <= k12_z;
        k13_valid <= k12_valid;
        k13_poison <= k12_poison;
        k13_cand <= k12_cand;
    end

    // ================================================================ K14: weights
    logic signed [34:0] k14_w [3];  // < 2^34 for a candidate
    logic signed [34:0] k14_z [3];
    logic               k14_valid, k14_poison, k14_cand;
    always_ff @(posedge clk) begin
        for (int i = 0; i < 3; i++) k14_w[i] <= 35'(k13_e[i] >> k13_r);
        k14_z <= k13_z;
        k14_valid <= k13_valid;
        k14_poison <= k13_poison;
        k14_cand <= k13_cand;
    end

    // ================================================================ K15: weight sum
    // det' = sum of weights (< 2^34), registered while the depth products start.
    logic signed [34:0] k15_detw;
    always_ff @(posedge clk) k15_detw <= k14_w[0] + k14_w[1] + k14_w[2];

    // ================================================================ K15-K17: depth products
    logic signed [69:0] k17_n [3];
    for (genvar i = 0; i < 3; i++) begin : g_depth
        mul_pipe #(.A_W(35), .B_W(35), .USE_DSP(DSP_DEPTH)) u_n (.clk, .a(k14_w[i]), .b(k14_z[i]), .p(k17_n[i]));
    end
    // Denominator det' * |dz| starts one cycle later and ends with the depth sum (K18).
    logic signed [59:0] k18_den;
    mul_pipe #(.A_W(35), .B_W(25), .USE_DSP(DSP_DEN)) u_den (.clk, .a(k15_detw), .b({1'b0, dz_abs}), .p(k18_den));
    logic k17_valid, k17_poison, k17_cand;
    delay #(.W(3), .N(3)) u_d17 (.clk, .d({k14_valid, k14_poison, k14_cand}), .q({k17_valid, k17_poison, k17_cand}));

    // ================================================================ K18: depth sum, sign
    logic signed [71:0] k18_n;
    logic               k18_valid, k18_poison, k18_cand;
    always_ff @(posedge clk) begin
        logic signed [71:0] n;
        n = 72'(k17_n[0]) + 72'(k17_n[1]) + 72'(k17_n[2]);
        k18_n <= dz_neg ? -n : n;
        k18_valid <= k17_valid;
        k18_poison <= k17_poison;
        k18_cand <= k17_cand;
    end

    // ================================================================ K19: front test, lengths
    logic [69:0]  k19_n;
    logic [57:0]  k19_den;
    logic [6:0]   k19_ln;
    logic [5:0]   k19_ld;
    logic         k19_valid, k19_poison, k19_cand;
    always_ff @(posedge clk) begin
        logic [6:0] ln;
        logic [5:0] ld;
        ln = 7'd0;
        for (int i = 0; i < 70; i++) if (k18_n[i]) ln = 7'(i + 1);
        ld = 6'd0;
        for (int i = 0; i < 58; i++) if (k18_den[i]) ld = 6'(i + 1);
        k19_n <= k18_n[69:0];
        k19_den <= k18_den[57:0];
        k19_ln <= ln;
        k19_ld <= ld;
        k19_valid <= k18_valid;
        k19_poison <= k18_poison;
        k19_cand <= k18_cand && k18_n > 0;
    end

    // ================================================================ K20: normalise operands
    logic [69:0]         k20_nn;
    logic [57:0]         k20_dn;
    logic signed [10:0]  k20_exp;
    logic                k20_valid, k20_poison, k20_cand;
    always_ff @(posedge clk) begin
        k20_nn <= k19_n << (7'd70 - k19_ln);
        k20_dn <= k19_den << (6'd58 - k19_ld);
        k20_exp <= 11'($signed({4'd0, k19_ln})) - 11'($signed({5'd0, k19_ld})) - 11'sd26 + 11'(texp);
        k20_valid <= k19_valid;
        k20_poison <= k19_poison;
        k20_cand <= k19_cand;
    end

    // ================================================================ K21-K47: division
    // q = floor(nn * 2^14 / dn) (27 bits), sticky = remainder != 0: one quotient bit per
    // stage, restoring. The dividend's bits below the initial window enter one per stage.
    logic [58:0] dv_r   [28];
    logic [57:0] dv_d   [28];
    logic [12:0] dv_low [28];   // nn[12:0], consumed MSB first
    logic [26:0] dv_q   [28];
    assign dv_r[0] = {2'b00, k20_nn[69:13]};
    assign dv_d[0] = k20_dn;
    assign dv_low[0] = k20_nn[12:0];
    assign dv_q[0] = 27'd0;
    for (genvar j = 0; j < 27; j++) begin : g_div
        always_ff @(posedge clk) begin
            logic [58:0] r;
            r = {dv_r[j][57:0], dv_low[j][12]};
            if (r >= {1'b0, dv_d[j]}) begin
                dv_r[j+1] <= r - {1'b0, dv_d[j]};
                dv_q[j+1] <= {dv_q[j][25:0], 1'b1};
            end else begin
                dv_r[j+1] <= r;
                dv_q[j+1] <= {dv_q[j][25:0], 1'b0};
            end
            dv_d[j+1] <= dv_d[j];
            dv_low[j+1] <= {dv_low[j][11:0], 1'b0};
        end
    end
    logic signed [10:0] k47_exp;
    logic               k47_valid, k47_poison, k47_cand;
    delay #(.W(14), .N(27)) u_d47 (.clk, .d({k20_exp, k20_valid, k20_poison, k20_cand}),
                                   .q({k47_exp, k47_valid, k47_poison, k47_cand}));

    // ================================================================ K48: round to f32
    logic [31:0] t_bits;
    always_comb begin
        logic [27:0]        q;          // quotient with a zero bit on top
        logic               sticky;
        logic signed [10:0] e;
        logic signed [10:0] drop;
        logic [4:0]         dr;
        logic [27:0]        mant;
        logic               half, rest;
        logic [5:0]         p;
        q = {1'b0, dv_q[27]};
        sticky = dv_r[27] != 0;
        p = q[26] ? 6'd27 : 6'd26;
        e = 11'(p) - 11'sd1 + k47_exp;
        // Bits to drop: down to 24 significant bits, or to the subnormal grid 2^-149.
        drop = (e >= -11'sd126) ? 11'(p) - 11'sd24 : -11'sd149 - k47_exp;
        dr = (drop > 11'sd28) ? 5'd28 : 5'(drop);
        mant = q >> dr;
        half = q[dr - 5'd1];
        rest = (q & ((28'd1 << (dr - 5'd1)) - 28'd1)) != 0;
        if (half && (rest || sticky || mant[0])) mant = mant + 28'd1;
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
        out_valid <= k47_valid;
        t <= t_bits;
        if (k47_poison) kind <= 2'd2;
        else if (k47_cand && t_bits != 32'd0 && t_bits != 32'h7F80_0000) kind <= 2'd1;
        else kind <= 2'd0;
    end
    assign out_tag = tag_q;
endmodule
