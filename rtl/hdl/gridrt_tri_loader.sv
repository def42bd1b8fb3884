// gridrt_tri_loader: what LOAD_PE computes for one triangle (rtl/README.md §4.4; twin:
// `record` of the coproc crate's `isect::watertight_q23`, model: `geometric_normal`).
//
// - The record: the 9 frame coordinates Q(v, s + 23) - Q(min), POISON (0x80000000) where
//   one does not fit i32; if none overflowed and the quantised vertices are collinear
//   (exact integer cross product zero) all 9 are 0. Word 9 is the prim id.
// - The normal (b - a) x (c - a) in f32 (RNE), as glam's Vec3 computes it.
// Takes LATENCY cycles from `start` to `done`.
module gridrt_tri_loader (
    input  logic               clk_i,
    input  logic               en_i,   // the co-processor's clock enable: every register holds while low
    input  logic               start_i,
    input  logic [8:0][31:0]   v_i,          // ax ay az bx by bz cx cy cz (f32)
    input  logic signed [9:0]  frame_s_i,
    input  logic [2:0][54:0]   frame_qm_i,   // signed elements
    input  logic [2:0]         frame_huge_i,
    output logic               done_o,
    output logic [8:0][31:0]   coord_o,
    output logic [2:0][31:0]   normal_o
);
    // Schedule (steps from 1): subtractions d1, d2 in steps 1-6; the six products from
    // STEP_MUL; the three normal subtractions from STEP_NSUB; conversions in 1-9 and the
    // degenerate test's products from STEP_DEG_MUL (below). `done` at LATENCY.
    localparam int ADD_LAT = 7;         // f32_addsub
    localparam int MUL_LAT = 8;         // f32_mul
    localparam int STEP_MUL = 7 + ADD_LAT;
    localparam int STEP_NSUB = STEP_MUL + 4 + MUL_LAT;
    localparam int LATENCY = STEP_NSUB + 2 + ADD_LAT;

    logic [5:0] step;

    // ---------------------------------------------------------------- conversions (1..9)
    logic [31:0]        cv_x;
    logic signed [54:0] cv_q;
    logic               cv_huge;
    logic [3:0]         ci;
    assign ci = 4'(step - 6'd1);
    logic        cv_in, cv_out_unused;
    localparam int CV_LAT = 4;          // f32_to_fixed
    assign cv_in = step >= 6'd1 && step <= 6'd9;
    assign cv_x = cv_in ? v_i[ci] : 32'd0;
    gridrt_f32_to_fixed u_cv (.clk_i, .en_i, .in_valid_i(cv_in), .x_i(cv_x), .k_i(frame_s_i + 10'sd23), .out_valid_o(cv_out_unused),
                       .q_o(cv_q), .huge_o(cv_huge));

    logic        ovf;
    logic [31:0] c [9];

    // ---------------------------------------------------------------- f32 units
    logic        add_in, add_out, mul_in, mul_out;
    logic [31:0] add_a, add_b, add_y, mul_a, mul_b, mul_y;
    gridrt_f32_addsub u_add (.clk_i, .en_i, .in_valid_i(add_in), .a_i(add_a), .b_i(add_b), .sub_i(1'b1), .out_valid_o(add_out), .y_o(add_y));
    gridrt_f32_mul u_mul (.clk_i, .en_i, .in_valid_i(mul_in), .a_i(mul_a), .b_i(mul_b), .out_valid_o(mul_out), .y_o(mul_y));
    logic [31:0] dd [6];    // d1 = b - a (0..2), d2 = c - a (3..5)
    logic [31:0] pp [6];    // cross-product terms
    // Subtractions issued in steps 1..6 (d) and STEP_NSUB.. (n); products from STEP_MUL.
    always_comb begin
        add_in = 1'b0;
        add_a = 32'd0;
        add_b = 32'd0;
        mul_in = 1'b0;
        mul_a = 32'd0;
        mul_b = 32'd0;
        // d1 = b - a, d2 = c - a; then the normal's three differences of products.
        for (int i = 0; i < 6; i++) begin
            if (step == 6'(1 + i)) begin
                add_in = 1'b1;
                add_a = v_i[3 + i];
                add_b = v_i[i % 3];
            end
        end
        for (int i = 0; i < 3; i++) begin
            if (step == 6'(STEP_NSUB + i)) begin
                add_in = 1'b1;
                add_a = pp[2 * i];
                add_b = pp[2 * i + 1];
            end
        end
        // x = d1y*d2z - d2y*d1z, y = d1z*d2x - d2z*d1x, z = d1x*d2y - d2x*d1y
        unique case (step)
            6'(STEP_MUL):     begin mul_in = 1'b1; mul_a = dd[1]; mul_b = dd[5]; end
            6'(STEP_MUL + 1): begin mul_in = 1'b1; mul_a = dd[4]; mul_b = dd[2]; end
            6'(STEP_MUL + 2): begin mul_in = 1'b1; mul_a = dd[2]; mul_b = dd[3]; end
            6'(STEP_MUL + 3): begin mul_in = 1'b1; mul_a = dd[5]; mul_b = dd[0]; end
            6'(STEP_MUL + 4): begin mul_in = 1'b1; mul_a = dd[0]; mul_b = dd[4]; end
            6'(STEP_MUL + 5): begin mul_in = 1'b1; mul_a = dd[3]; mul_b = dd[1]; end
            default: ;
        endcase
    end

    // ---------------------------------------------------------------- degenerate test
    // e1 = c1 - c0, e2 = c2 - c0 (33-bit); n = e1 x e2 == 0 (six exact products).
    logic signed [32:0] e1 [3], e2 [3];
    logic signed [32:0] ma, mb;
    logic signed [65:0] mp;
    localparam int DEG_MUL_LAT = 4;     // mul_pipe in DSP blocks
    localparam int STEP_DEG_MUL = 11 + CV_LAT;  // first of the six products (edges in the step before)
    gridrt_mul_pipe #(.A_W(33), .B_W(33), .LATENCY(DEG_MUL_LAT)) u_dm (.clk_i, .en_i(en_i), .a_i(ma), .b_i(mb), .p_o(mp));
    always_comb begin
        ma = '0;
        mb = '0;
        unique case (step)
            6'(STEP_DEG_MUL):     begin ma = e1[1]; mb = e2[2]; end
            6'(STEP_DEG_MUL + 1): begin ma = e1[2]; mb = e2[1]; end
            6'(STEP_DEG_MUL + 2): begin ma = e1[2]; mb = e2[0]; end
            6'(STEP_DEG_MUL + 3): begin ma = e1[0]; mb = e2[2]; end
            6'(STEP_DEG_MUL + 4): begin ma = e1[0]; mb = e2[1]; end
            6'(STEP_DEG_MUL + 5): begin ma = e1[1]; mb = e2[0]; end
            default: ;
        endcase
    end
    logic signed [65:0] dp [6];
    logic               degenerate;

    always_ff @(posedge clk_i) if (en_i) begin
        done_o <= 1'b0;
        if (start_i) begin
            step <= 6'd1;
            ovf <= 1'b0;
        end else if (step != 0) begin
            step <= (step == 6'(LATENCY)) ? 6'd0 : step + 6'd1;
            // Coordinates: converted in steps 1-9, minus the frame minimum CV_LAT steps later.
            // (Constant indices: a variable index into a packed array costs a multiplier.)
            for (int j = 0; j < 9; j++) begin
                if (step == 6'(1 + CV_LAT + j)) begin
                    logic signed [55:0] x;
                    x = 56'(cv_q) - 56'($signed(frame_qm_i[j % 3]));
                    // |x| > 2^31 - 1 as bit tests.
                    if (cv_huge || frame_huge_i[j % 3] || (x[55] ? (x[54:31] != '1 || x[30:0] == 0) : x[54:31] != 0)) begin
                        c[j] <= 32'h8000_0000;
                        ovf <= 1'b1;
                    end else begin
                        c[j] <= 32'(x);
                    end
                end
            end
            if (step == 6'(STEP_DEG_MUL - 1)) begin
                for (int a = 0; a < 3; a++) begin
                    e1[a] <= 33'($signed(c[3 + a])) - 33'($signed(c[a]));
                    e2[a] <= 33'($signed(c[6 + a])) - 33'($signed(c[a]));
                end
            end
            // Product issued in step s is ready in step s + DEG_MUL_LAT.
            if (step >= 6'(STEP_DEG_MUL + DEG_MUL_LAT) && step <= 6'(STEP_DEG_MUL + 5 + DEG_MUL_LAT))
                dp[3'(step - 6'(STEP_DEG_MUL + DEG_MUL_LAT))] <= mp;
            if (step == 6'(STEP_DEG_MUL + 6 + DEG_MUL_LAT))
                degenerate <= dp[0] == dp[1] && dp[2] == dp[3] && dp[4] == dp[5];
            if (add_out && step >= 6'(1 + ADD_LAT) && step <= 6'(6 + ADD_LAT)) dd[3'(step - 6'(1 + ADD_LAT))] <= add_y;
            if (mul_out) pp[3'(step - 6'(STEP_MUL + MUL_LAT))] <= mul_y;
            for (int i = 0; i < 3; i++) if (step == 6'(STEP_NSUB + ADD_LAT + i)) normal_o[i] <= add_y;
            if (step == 6'(LATENCY)) begin
                for (int i = 0; i < 9; i++) coord_o[i] <= (!ovf && degenerate) ? 32'd0 : c[i];
                done_o <= 1'b1;
            end
        end
    end
endmodule
