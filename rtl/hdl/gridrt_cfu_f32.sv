// gridrt_cfu_f32: f32 add, sub and mul as a Custom Function Unit of LiteX's VexRiscv
// (`full+cfu`: VexRiscv's CfuPlugin), so the firmware's f32 arithmetic runs in hardware.
//
// Spec: rtl/README.md §7. Rust twin: `gridrt_shared::cfu::execute` (word for word, pinned by
// rtl/tests/units.rs). The instruction is custom-0 (opcode 0x0B), R-type; the CPU sends
// function_id = {funct7, funct3} with rs1 and rs2 and writes the response to rd:
//
//   funct7 0, funct3 0: rs1 + rs2     funct7 0, funct3 1: rs1 - rs2     funct7 0, funct3 2: rs1 * rs2
//
// IEEE-754 binary32, round to nearest even, subnormals in and out, every NaN result the
// canonical 0x7FC00000 (gridrt_f32_addsub, gridrt_f32_mul). Any other function id answers
// 0x7FC00000, so an unknown instruction never hangs the CPU.
//
// One command at a time: cmd_ready_o is high only while idle (it depends on no input). A
// command's handshake at clock edge k gives rsp_valid_o from edge k + LATENCY - 1 on (the
// earliest response handshake is at edge k + LATENCY): LATENCY = 7 for add and sub, 8 for
// mul, 1 for an unknown id. rsp_valid_o and rsp_outputs_0_o then hold until rsp_ready_i; the
// next command can be taken in the cycle after the response's handshake. The reset rst_i is
// synchronous and active high (LiteX's sys reset).
module gridrt_cfu_f32 (
    input  logic        clk_i,
    input  logic        rst_i,
    input  logic        cmd_valid_i,
    output logic        cmd_ready_o,
    input  logic [9:0]  cmd_function_id_i,   // {funct7, funct3}
    input  logic [31:0] cmd_inputs_0_i,      // rs1
    input  logic [31:0] cmd_inputs_1_i,      // rs2
    output logic        rsp_valid_o,
    input  logic        rsp_ready_i,
    output logic [31:0] rsp_outputs_0_o      // rd
);
    localparam logic [9:0]  FN_ADD = {7'd0, 3'd0};
    localparam logic [9:0]  FN_SUB = {7'd0, 3'd1};
    localparam logic [9:0]  FN_MUL = {7'd0, 3'd2};
    localparam logic [31:0] CANONICAL_NAN = 32'h7FC0_0000;
    localparam int          ADD_LATENCY = 7;    // gridrt_f32_addsub's
    localparam int          MUL_LATENCY = 8;    // gridrt_f32_mul's

    typedef enum logic [1:0] {
        Idle,   // cmd_ready_o
        Wait,   // an operation in a unit; its result is at the unit's output when wait_q is 0
        Hold    // the response in rsp_q, offered until taken
    } state_e;

    state_e      state_d, state_q;
    logic [2:0]  wait_d, wait_q;            // cycles until the unit's result
    logic        is_mul_d, is_mul_q;        // Wait: the result comes from the multiplier
    logic [31:0] rsp_d, rsp_q;

    logic        cmd_fire, rsp_fire, op_add, op_sub, op_mul;
    logic        add_valid, mul_valid, add_out_valid, mul_out_valid;
    logic [31:0] add_y, mul_y, unit_y;

    // ---------------------------------------------------------------- the units
    assign cmd_ready_o = state_q == Idle;
    assign cmd_fire    = cmd_valid_i && cmd_ready_o;
    assign op_add      = cmd_function_id_i == FN_ADD;
    assign op_sub      = cmd_function_id_i == FN_SUB;
    assign op_mul      = cmd_function_id_i == FN_MUL;
    assign add_valid   = cmd_fire && !rst_i && (op_add || op_sub);
    assign mul_valid   = cmd_fire && !rst_i && op_mul;

    gridrt_f32_addsub u_add (.clk_i, .en_i(1'b1), .in_valid_i(add_valid), .a_i(cmd_inputs_0_i), .b_i(cmd_inputs_1_i),
                             .sub_i(op_sub), .out_valid_o(add_out_valid), .y_o(add_y));
    gridrt_f32_mul u_mul (.clk_i, .en_i(1'b1), .in_valid_i(mul_valid), .a_i(cmd_inputs_0_i), .b_i(cmd_inputs_1_i),
                          .out_valid_o(mul_out_valid), .y_o(mul_y));

    // ---------------------------------------------------------------- response
    // A unit's result is offered straight from its output register in the cycle it arrives
    // (no extra cycle), and kept in rsp_q if the CPU does not take it then.
    assign unit_y          = is_mul_q ? mul_y : add_y;
    assign rsp_valid_o     = state_q == Hold || (state_q == Wait && wait_q == 3'd0);
    assign rsp_outputs_0_o = state_q == Hold ? rsp_q : unit_y;
    assign rsp_fire        = rsp_valid_o && rsp_ready_i;

    always_comb begin
        state_d  = state_q;
        wait_d   = wait_q;
        is_mul_d = is_mul_q;
        rsp_d    = rsp_q;
        unique case (state_q)
            Idle: begin
                if (cmd_fire) begin
                    if (op_add || op_sub || op_mul) begin
                        state_d  = Wait;
                        wait_d   = op_mul ? 3'(MUL_LATENCY - 1) : 3'(ADD_LATENCY - 1);
                        is_mul_d = op_mul;
                    end else begin
                        state_d = Hold;
                        rsp_d   = CANONICAL_NAN;
                    end
                end
            end
            Wait: begin
                if (wait_q != 3'd0) begin
                    wait_d = wait_q - 3'd1;
                end else if (rsp_fire) begin
                    state_d = Idle;
                end else begin
                    state_d = Hold;
                    rsp_d   = unit_y;
                end
            end
            Hold: begin
                if (rsp_fire) state_d = Idle;
            end
            default: state_d = Idle;
        endcase
    end

    always_ff @(posedge clk_i) begin
        if (rst_i) begin
            state_q <= Idle;
            wait_q  <= 3'd0;
        end else begin
            state_q <= state_d;
            wait_q  <= wait_d;
        end
    end

    always_ff @(posedge clk_i) begin
        is_mul_q <= is_mul_d;
        rsp_q    <= rsp_d;
    end

`ifndef SYNTHESIS
    // The response handshake: a response once offered stays offered, unchanged, until taken.
    RspValidHeld: assert property (@(posedge clk_i) disable iff (rst_i)
        rsp_valid_o && !rsp_ready_i |=> rsp_valid_o)
        else $error("gridrt_cfu_f32: rsp_valid_o dropped before rsp_ready_i");
    RspDataStable: assert property (@(posedge clk_i) disable iff (rst_i)
        rsp_valid_o && !rsp_ready_i |=> $stable(rsp_outputs_0_o))
        else $error("gridrt_cfu_f32: rsp_outputs_0_o changed while waiting for rsp_ready_i");
    // One command at a time: no response offered while a command is taken.
    OneOutstanding: assert property (@(posedge clk_i) disable iff (rst_i) !(cmd_ready_o && rsp_valid_o))
        else $error("gridrt_cfu_f32: cmd_ready_o with a response pending");
    // The latency counted in wait_q is the unit's: its result is at its output when it ends.
    ResultOnTime: assert property (@(posedge clk_i) disable iff (rst_i)
        state_q == Wait && wait_q == 3'd0 |-> (is_mul_q ? mul_out_valid : add_out_valid))
        else $error("gridrt_cfu_f32: the unit's result is not there when the latency says");
`endif
endmodule
