// Cfu: LiteX's name for the module on VexRiscv's CfuPlugin port (`VexRiscv.add_cfu` instantiates
// `Cfu` with these port names), here the floating-point CFU `gridrt_cfu_f32` (rtl/README.md,
// "The CPU's floating-point CFU"). Wiring only: the unit and its assertions are in rtl/hdl/.
// The module name and ports are LiteX's contract, hence no gridrt_ prefix and no _i/_o.
module Cfu (
    input  logic        clk,
    input  logic        reset,
    input  logic        cmd_valid,
    output logic        cmd_ready,
    input  logic [9:0]  cmd_payload_function_id,
    input  logic [31:0] cmd_payload_inputs_0,
    input  logic [31:0] cmd_payload_inputs_1,
    output logic        rsp_valid,
    input  logic        rsp_ready,
    output logic [31:0] rsp_payload_outputs_0
);
    gridrt_cfu_f32 u_cfu (
        .clk_i             (clk),
        .rst_i             (reset),
        .cmd_valid_i       (cmd_valid),
        .cmd_ready_o       (cmd_ready),
        .cmd_function_id_i (cmd_payload_function_id),
        .cmd_inputs_0_i    (cmd_payload_inputs_0),
        .cmd_inputs_1_i    (cmd_payload_inputs_1),
        .rsp_valid_o       (rsp_valid),
        .rsp_ready_i       (rsp_ready),
        .rsp_outputs_0_o   (rsp_payload_outputs_0)
    );
endmodule
