// gridrt_units_top: the datapath blocks side by side, for the unit co-simulation
// (rtl/sim/units_main.cpp, rtl/tests/units.rs). Not part of the co-processor.
module gridrt_units_top (
    input  logic               clk_i,
    // f32_addsub
    input  logic               add_valid_i,
    input  logic [31:0]        add_a_i, add_b_i,
    input  logic               add_sub_i,
    output logic               add_out_valid_o,
    output logic [31:0]        add_y_o,
    // f32_mul
    input  logic               mul_valid_i,
    input  logic [31:0]        mul_a_i, mul_b_i,
    output logic               mul_out_valid_o,
    output logic [31:0]        mul_y_o,
    // f32_to_fixed
    input  logic               fx_valid_i,
    input  logic [31:0]        fx_x_i,
    input  logic signed [9:0]  fx_k_i,
    output logic               fx_out_valid_o,
    output logic signed [54:0] fx_q_o,
    output logic               fx_huge_o,
    // isect_pipe
    input  logic               is_valid_i,
    input  logic [287:0]       is_rec_i,
    input  logic signed [33:0] is_o0_i, is_o1_i, is_o2_i,
    input  logic [1:0]         is_kz_i,
    input  logic signed [24:0] is_sx_i, is_sy_i,
    input  logic               is_dz_neg_i,
    input  logic [23:0]        is_dz_abs_i,
    input  logic signed [9:0]  is_texp_i,
    input  logic               is_ray_overflow_i,
    output logic               is_out_valid_o,
    output logic [1:0]         is_kind_o,
    output logic [31:0]        is_t_o,
    // cfu_f32 (the CPU's CFU bus; the only unit here with a reset)
    input  logic               cfu_rst_i,
    input  logic               cfu_cmd_valid_i,
    output logic               cfu_cmd_ready_o,
    input  logic [9:0]         cfu_cmd_function_id_i,
    input  logic [31:0]        cfu_cmd_inputs_0_i, cfu_cmd_inputs_1_i,
    output logic               cfu_rsp_valid_o,
    input  logic               cfu_rsp_ready_i,
    output logic [31:0]        cfu_rsp_outputs_0_o
);
    gridrt_f32_addsub u_add (.clk_i, .en_i(1'b1), .in_valid_i(add_valid_i), .a_i(add_a_i), .b_i(add_b_i), .sub_i(add_sub_i),
                      .out_valid_o(add_out_valid_o), .y_o(add_y_o));
    gridrt_f32_mul u_mul (.clk_i, .en_i(1'b1), .in_valid_i(mul_valid_i), .a_i(mul_a_i), .b_i(mul_b_i), .out_valid_o(mul_out_valid_o), .y_o(mul_y_o));
    gridrt_f32_to_fixed u_fx (.clk_i, .en_i(1'b1), .in_valid_i(fx_valid_i), .x_i(fx_x_i), .k_i(fx_k_i), .out_valid_o(fx_out_valid_o), .q_o(fx_q_o),
                       .huge_o(fx_huge_o));
    logic is_tag_unused;
    gridrt_isect_pipe #(.TAG_W(1)) u_is (
        .clk_i, .en_i(1'b1), .rst_i(1'b0), .in_valid_i(is_valid_i), .in_tag_i(1'b0), .rec_i(is_rec_i),
        .o0_i(is_o0_i), .o1_i(is_o1_i), .o2_i(is_o2_i), .kz_i(is_kz_i), .sx_i(is_sx_i), .sy_i(is_sy_i),
        .dz_neg_i(is_dz_neg_i), .dz_abs_i(is_dz_abs_i), .texp_i(is_texp_i), .ray_overflow_i(is_ray_overflow_i),
        .out_valid_o(is_out_valid_o), .out_tag_o(is_tag_unused), .kind_o(is_kind_o), .t_o(is_t_o));
    gridrt_cfu_f32 u_cfu (
        .clk_i, .rst_i(cfu_rst_i), .cmd_valid_i(cfu_cmd_valid_i), .cmd_ready_o(cfu_cmd_ready_o),
        .cmd_function_id_i(cfu_cmd_function_id_i), .cmd_inputs_0_i(cfu_cmd_inputs_0_i), .cmd_inputs_1_i(cfu_cmd_inputs_1_i),
        .rsp_valid_o(cfu_rsp_valid_o), .rsp_ready_i(cfu_rsp_ready_i), .rsp_outputs_0_o(cfu_rsp_outputs_0_o));
endmodule
