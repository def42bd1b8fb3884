// gridrt_ray_setup: the per-ray constants every PE shares (rtl/README.md §3.2; twin: `setup` of the
// coproc crate's `isect::watertight_q23`).
//
// From the f32 origin and direction and the frame: the dominant axis kz (pbrt-v4's
// max_dimension), the direction Q(d, 23 - E) with E = floor(log2 |d_kz|), the origin
// Q(o, s + 23) - Q(min) (overflow outside +-2^33), the shear trunc(-d * 2^23 / dz) for x
// and y (two restoring dividers, two quotient bits per cycle), and the t exponent -s - E.
// Takes LATENCY cycles from `start` to `done` whatever the input.
module gridrt_ray_setup (
    input  logic                clk_i,
    input  logic                en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                start_i,
    input  logic [2:0][31:0]    org_i,
    input  logic [2:0][31:0]    dir_i,
    input  logic signed [9:0]   frame_s_i,
    input  logic [2:0][54:0]    frame_qm_i,   // signed elements
    input  logic [2:0]          frame_huge_i,
    output logic                done_o,
    output logic [2:0][33:0]    o_o,          // signed elements
    output logic [1:0]          kz_o,
    output logic signed [24:0]  sx_o, sy_o,
    output logic                dz_neg_o,
    output logic [23:0]         dz_abs_o,
    output logic signed [9:0]   texp_o,
    output logic                overflow_o
);
    // Schedule (steps from 1): the dominant axis in step 1; the converter takes the three
    // direction components in steps 2-4 and the origin in 5-7, each ready CV_LAT steps later;
    // the permutation once the direction is in; DIV_STEPS divider steps; `done` after them.
    localparam int CV_LAT = 4;                          // f32_to_fixed
    localparam int STEP_DIR = 2;                        // first direction conversion
    localparam int STEP_ORG = 5;                        // first origin conversion
    localparam int STEP_PERMUTE = STEP_DIR + 3 + CV_LAT;
    localparam int DIV_STEPS = 12;                      // 24 quotient bits, 2 per step
    localparam int LATENCY = STEP_PERMUTE + DIV_STEPS + 1;

    // One converter, used for the three direction and then the three origin components.
    logic               cv_in, cv_out_unused;
    logic [31:0]        cv_x;
    logic signed [9:0]  cv_k;
    logic signed [54:0] cv_q;
    logic               cv_huge;
    gridrt_f32_to_fixed u_cv (.clk_i, .en_i, .in_valid_i(cv_in), .x_i(cv_x), .k_i(cv_k), .out_valid_o(cv_out_unused), .q_o(cv_q), .huge_o(cv_huge));

    logic [5:0]         step;      // 0 idle; 1.. running
    logic signed [9:0]  e_max;
    logic signed [24:0] d [3];     // world order
    logic [23:0]        den;
    logic [25:0]        den3;      // 3 * den, registered in the first divider step
    logic [23:0]        rx, ry;    // partial remainders (< den)
    logic [23:0]        qx, qy;
    logic               sx_neg, sy_neg;
    logic signed [55:0] od;        // origin component minus the frame minimum
    logic               od_bad;

    function automatic [30:0] mag(input [31:0] f);
        mag = f[30:0];
    endfunction

    // floor(log2 |f|) of a finite nonzero f32.
    function automatic logic signed [9:0] floor_log2(input [31:0] f);
        logic [4:0] msb;
        msb = 5'd0;
        for (int i = 0; i < 23; i++) if (f[i]) msb = 5'(i);
        if (f[30:23] != 0) floor_log2 = $signed({2'b00, f[30:23]}) - 10'sd127;
        else floor_log2 = $signed({5'd0, msb}) - 10'sd149;
    endfunction

    always_comb begin
        cv_in = 1'b0;
        cv_x = 32'd0;
        cv_k = 10'sd0;
        if (step >= 6'(STEP_DIR) && step < 6'(STEP_DIR + 3)) begin
            cv_in = 1'b1;
            cv_x = dir_i[2'(step - 6'(STEP_DIR))];
            cv_k = 10'sd23 - e_max;
        end else if (step >= 6'(STEP_ORG) && step < 6'(STEP_ORG + 3)) begin
            cv_in = 1'b1;
            cv_x = org_i[2'(step - 6'(STEP_ORG))];
            cv_k = frame_s_i + 10'sd23;
        end
    end

    // Two steps of the restoring division of |v| * 2^23 by den: remainder and quotient.
    // `first`: the remainder starts as |v| (the dividend's bits above 2^23), not doubled.
    // The two quotient bits are one radix-4 digit, floor(x / dv) for x = 4r (2r first):
    // x against dv, 2dv and 3dv in three parallel subtractors, so a step holds one carry
    // chain, not two in series (the 1-PE design's critical path, 20.3 ns). Equal to two
    // restoring steps because r <= dv (|v| <= den: kz is the dominant axis) and dv > 0 (a
    // zero direction is refused before, SPEC error 11), so x < 4dv (x <= 2dv in the first
    // step, which needs no 3dv: it is registered during that step).
    function automatic logic [47:0] div2(input logic [23:0] r0, input logic [23:0] q0,
                                         input logic [23:0] dv, input logic [25:0] dv3,
                                         input logic first);
        logic [25:0] x;
        logic [26:0] s1, s2, s3;
        logic [1:0]  digit;
        logic [23:0] rem;
        x = first ? {1'b0, r0, 1'b0} : {r0, 2'b00};
        s1 = {1'b0, x} - {3'b000, dv};
        s2 = {1'b0, x} - {2'b00, dv, 1'b0};
        s3 = {1'b0, x} - {1'b0, dv3};
        if (!first && !s3[26]) begin digit = 2'd3; rem = 24'(s3); end
        else if (!s2[26]) begin digit = 2'd2; rem = 24'(s2); end
        else if (!s1[26]) begin digit = 2'd1; rem = 24'(s1); end
        else begin digit = 2'd0; rem = 24'(x); end
        div2 = {rem, q0[21:0], digit};
    endfunction

    always_ff @(posedge clk_i) if (en_i) begin
        done_o <= 1'b0;
        if (start_i) begin
            step <= 6'd1;
            overflow_o <= 1'b0;
        end else if (step != 0) begin
            step <= (step == 6'(LATENCY)) ? 6'd0 : step + 6'd1;
            if (step == 6'd1) begin
                // max_dimension: x if |x| >= |y| and |x| >= |z|, else y if |y| >= |z|, else z.
                logic [1:0] k;
                if (mag(dir_i[0]) >= mag(dir_i[1]) && mag(dir_i[0]) >= mag(dir_i[2])) k = 2'd0;
                else if (mag(dir_i[1]) >= mag(dir_i[2])) k = 2'd1;
                else k = 2'd2;
                kz_o <= k;
                // E of all three components beside the compares, then a 3-way select (the
                // select before the leading-one search was a placed 4-PE design's path).
                e_max <= (k == 2'd0) ? floor_log2(dir_i[0]) : (k == 2'd1) ? floor_log2(dir_i[1]) : floor_log2(dir_i[2]);
            end
            if (step >= 6'(STEP_DIR + CV_LAT) && step < 6'(STEP_DIR + CV_LAT + 3))
                d[2'(step - 6'(STEP_DIR + CV_LAT))] <= 25'(cv_q);
            // Origin: subtract the frame minimum as each conversion arrives, then the range.
            // (Constant indices: a variable index into a packed array costs a multiplier.)
            for (int i = 0; i < 3; i++) begin
                if (step == 6'(STEP_ORG + CV_LAT + i)) begin
                    od <= 56'(cv_q) - 56'($signed(frame_qm_i[i]));
                    od_bad <= cv_huge || frame_huge_i[i];
                end
                if (step == 6'(STEP_ORG + CV_LAT + 1 + i)) begin
                    // |od| >= 2^33 as bit tests.
                    if (od_bad || (od[55] ? (od[54:33] != '1 || od[32:0] == 0) : od[54:33] != 0))
                        overflow_o <= 1'b1;
                    o_o[i] <= 34'(od);
                end
            end
            if (step == 6'(STEP_PERMUTE)) begin
                // Permute the direction (kz=0: y,z,x; kz=1: z,x,y; kz=2: x,y,z) and set up the
                // two divisions trunc(-dx * 2^23 / dz), trunc(-dy * 2^23 / dz).
                logic signed [24:0] px, py, pz;
                unique case (kz_o)
                    2'd0: begin px = d[1]; py = d[2]; pz = d[0]; end
                    2'd1: begin px = d[2]; py = d[0]; pz = d[1]; end
                    default: begin px = d[0]; py = d[1]; pz = d[2]; end
                endcase
                den <= (pz < 0) ? 24'(-pz) : 24'(pz);
                dz_neg_o <= pz < 0;
                dz_abs_o <= (pz < 0) ? 24'(-pz) : 24'(pz);
                // -d/dz is negative when d and dz have the same sign (d = 0 gives q = 0).
                sx_neg <= (px < 0) == (pz < 0);
                sy_neg <= (py < 0) == (pz < 0);
                rx <= (px < 0) ? 24'(-px) : 24'(px);
                ry <= (py < 0) ? 24'(-py) : 24'(py);
                qx <= '0;
                qy <= '0;
                texp_o <= -frame_s_i - e_max;
            end
            if (step > 6'(STEP_PERMUTE) && step <= 6'(STEP_PERMUTE + DIV_STEPS)) begin
                // Quotient bits 23 and 22 first.
                {rx, qx} <= div2(rx, qx, den, den3, step == 6'(STEP_PERMUTE + 1));
                {ry, qy} <= div2(ry, qy, den, den3, step == 6'(STEP_PERMUTE + 1));
                den3 <= 26'(den) + {1'b0, den, 1'b0};
            end
            if (step == 6'(LATENCY)) begin
                sx_o <= sx_neg ? -$signed({1'b0, qx}) : $signed({1'b0, qx});
                sy_o <= sy_neg ? -$signed({1'b0, qy}) : $signed({1'b0, qy});
                done_o <= 1'b1;
            end
        end
    end
endmodule
