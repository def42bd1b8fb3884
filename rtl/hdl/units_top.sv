// units_top: the datapath blocks side by side, for the unit co-simulation
// (rtl/sim/units_main.cpp, rtl/tests/units.rs). Not part of the co-processor.
module units_top (
    input  logic               clk,
    // f32_addsub
    input  logic               add_valid,
    input  logic [31:0]        add_a, add_b,
    input  logic               add_sub,
    output logic               add_out_valid,
    output logic [31:0]        add_y,
    // f32_mul
    input  logic               mul_valid,
    input  logic [31:0]        mul_a, mul_b,
    output logic               mul_out_valid,
    output logic [31:0]        mul_y,
    // f32_to_fixed
    input  logic               fx_valid,
    input  logic [31:0]        fx_x,
    input  logic signed [9:0]  fx_k,
    output logic               fx_out_valid,
    output logic signed [54:0] fx_q,
    output logic               fx_huge,
    // isect_pipe
    input  logic               is_valid,
    input  logic [287:0]       is_rec,
    input  logic signed [33:0] is_o0, is_o1, is_o2,
    input  logic [1:0]         is_kz,
    input  logic signed [24:0] is_sx, is_sy,
    input  logic               is_dz_neg,
    input  logic [23:0]        is_dz_abs,
    input  logic signed [9:0]  is_texp,
    input  logic               is_ray_overflow,
    output logic               is_out_valid,
    output logic [1:0]         is_kind,
    output logic [31:0]        is_t
);
    f32_addsub u_add (.clk, .in_valid(add_valid), .a(add_a), .b(add_b), .sub(add_sub),
                      .out_valid(add_out_valid), .y(add_y));
    f32_mul u_mul (.clk, .in_valid(mul_valid), .a(mul_a), .b(mul_b), .out_valid(mul_out_valid), .y(mul_y));
    f32_to_fixed u_fx (.clk, .in_valid(fx_valid), .x(fx_x), .k(fx_k), .out_valid(fx_out_valid), .q(fx_q),
                       .huge(fx_huge));
    logic is_tag_unused;
    isect_pipe #(.TAG_W(1)) u_is (
        .clk, .in_valid(is_valid), .in_tag(1'b0), .rec(is_rec),
        .o0(is_o0), .o1(is_o1), .o2(is_o2), .kz(is_kz), .sx(is_sx), .sy(is_sy),
        .dz_neg(is_dz_neg), .dz_abs(is_dz_abs), .texp(is_texp), .ray_overflow(is_ray_overflow),
        .out_valid(is_out_valid), .out_tag(is_tag_unused), .kind(is_kind), .t(is_t));
endmodule
