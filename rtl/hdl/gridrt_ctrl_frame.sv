// gridrt_ctrl_frame: the FRAME packet's computation and the fixed-point frame it sets
// (rtl/README.md §2 and §3.1), for the controller.
//
// The receiver writes the box (min xyz, max xyz: f32 words 0..5) and checks it; start_i
// then runs the schedule, one step per cycle while run_i: max - min in steps 1-3 on one f32
// adder, the largest difference as the extent, s = 4 - ceil(log2 extent) (0 for a zero
// extent) in STEP_S, the three conversions Q(min_a, s + 23) from STEP_CV, and the frame set
// in STEP_END, when done_o is high. After reset the frame is the identity (s 0, min 0).
module gridrt_ctrl_frame (
    input  logic               clk_i,
    input  logic               en_i,   // the co-processor's clock enable: every register holds while low
    input  logic               rst_i,          // synchronous, active high
    // The box, word by word as the FRAME packet brings it.
    input  logic               box_we_i,
    input  logic [2:0]         box_idx_i,
    input  logic [31:0]        box_word_i,
    output logic [5:0][31:0]   box_o,
    // The computation.
    input  logic               start_i,        // go to step 1
    input  logic               run_i,          // the controller is in its FRAME phase
    output logic               done_o,         // the last step: the frame is set at this edge
    // The frame, for the triangle loader and the ray setup.
    output logic signed [9:0]  frame_s_o,
    output logic [2:0][54:0]   frame_qm_o,     // signed elements
    output logic [2:0]         frame_huge_o
);
    localparam int ADD_LAT = 7;      // gridrt_f32_addsub
    localparam int CV_LAT = 4;       // gridrt_f32_to_fixed
    localparam int STEP_S = 4 + ADD_LAT;
    localparam int STEP_CV = STEP_S + 1;
    localparam int STEP_END = STEP_CV + 2 + CV_LAT;

    logic [5:0][31:0]   box_q;
    logic [4:0]         step_d, step_q;
    logic [31:0]        ext_d, ext_q;     // the largest max - min so far
    logic signed [9:0]  s_d, s_q;
    logic               sub_in, sub_out_unused, cv_in, cv_out_unused;
    logic [31:0]        sub_a, sub_b, sub_y, cv_x;
    logic signed [54:0] cv_q;
    logic               cv_huge;

    assign box_o = box_q;

    gridrt_f32_addsub u_sub (.clk_i, .en_i, .in_valid_i(sub_in), .a_i(sub_a), .b_i(sub_b), .sub_i(1'b1),
                             .out_valid_o(sub_out_unused), .y_o(sub_y));
    gridrt_f32_to_fixed u_cv (.clk_i, .en_i, .in_valid_i(cv_in), .x_i(cv_x), .k_i(s_q + 10'sd23),
                              .out_valid_o(cv_out_unused), .q_o(cv_q), .huge_o(cv_huge));

    always_comb begin
        sub_in = run_i && step_q >= 5'd1 && step_q <= 5'd3;
        sub_a = box_q[3 + int'(step_q) - 1];
        sub_b = box_q[int'(step_q) - 1];
        cv_in = run_i && step_q >= 5'(STEP_CV) && step_q <= 5'(STEP_CV + 2);
        cv_x = box_q[cv_in ? int'(step_q) - STEP_CV : 0];
        done_o = run_i && step_q == 5'(STEP_END);
    end

    // Next step, extent and scale.
    always_comb begin
        logic signed [9:0] e;
        logic              pow2;
        logic [4:0]        msb;
        step_d = step_q;
        ext_d = ext_q;
        s_d = s_q;
        if (start_i) step_d = 5'd1;
        else if (run_i) step_d = step_q + 5'd1;
        // Steps 1-3 issue max - min, results ADD_LAT steps later; the extent is the largest.
        if (step_q == 5'(1 + ADD_LAT)) ext_d = sub_y;
        if (step_q == 5'(2 + ADD_LAT) || step_q == 5'(3 + ADD_LAT))
            if (sub_y[30:0] > ext_q[30:0]) ext_d = sub_y;
        // s = 4 - ceil(log2 extent); 0 for a zero extent.
        msb = 5'd0;
        for (int i = 0; i < 23; i++) if (ext_q[i]) msb = 5'(i);
        if (ext_q[30:23] == 8'hFF) begin
            e = 10'sd128;
            pow2 = 1'b1;
        end else if (ext_q[30:23] != 0) begin
            e = $signed({2'b00, ext_q[30:23]}) - 10'sd127;
            pow2 = ext_q[22:0] == 0;
        end else begin
            e = $signed({5'd0, msb}) - 10'sd149;
            pow2 = (ext_q[22:0] & (ext_q[22:0] - 23'd1)) == 0;
        end
        if (step_q == 5'(STEP_S)) s_d = (ext_q[30:0] == 0) ? 10'sd0 : (pow2 ? 10'sd4 - e : 10'sd3 - e);
    end

    always_ff @(posedge clk_i) if (en_i) begin
        if (box_we_i) box_q[box_idx_i] <= box_word_i;
    end

    // The schedule's registers change only outside reset, the computed ones only while run_i.
    always_ff @(posedge clk_i) if (en_i) begin
        if (!rst_i && (start_i || run_i)) step_q <= step_d;
        if (!rst_i && run_i) begin
            ext_q <= ext_d;
            s_q <= s_d;
        end
    end

    // The frame: the conversions of the minimum, ready CV_LAT steps after each, then s.
    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) begin
            frame_s_o <= '0;
            frame_qm_o <= '0;
            frame_huge_o <= '0;
        end else if (run_i) begin
            for (int a = 0; a < 3; a++) begin
                if (step_q == 5'(STEP_CV + CV_LAT + a)) begin
                    frame_qm_o[a] <= cv_q;
                    frame_huge_o[a] <= cv_huge;
                end
            end
            if (step_q == 5'(STEP_END)) frame_s_o <= s_q;
        end
    end
endmodule
