// gridrt_f32_to_fixed: the exact f32 -> integer conversion Q(x, k) = round_half_away(x * 2^k).
//
// Spec: rtl/README.md §3.1; twin: `to_fixed` of the coproc crate's `isect::watertight_q23`. `huge` is set (and `q` is 0) when
// |x * 2^k| >= 2^54. `x` must be finite.
//
// Pipeline: 4 stages (inputs | unpack and shift amount | shift, round and range | sign); one
// conversion per cycle; `out_valid` follows `in_valid` by LATENCY cycles.
module gridrt_f32_to_fixed (
    input  logic               clk_i,
    input  logic               en_i,   // the co-processor's clock enable: every register holds while low
    input  logic               in_valid_i,
    input  logic [31:0]        x_i,
    input  logic signed [9:0]  k_i,
    output logic               out_valid_o,
    output logic signed [54:0] q_o,
    output logic               huge_o
);
    localparam int LATENCY = 4;

    // ---------------------------------------------------------------- stage 0: inputs
    logic               s0_valid;
    logic [31:0]        s0_x;
    logic signed [9:0]  s0_k;
    always_ff @(posedge clk_i) if (en_i) begin
        s0_valid <= in_valid_i;
        s0_x <= x_i;
        s0_k <= k_i;
    end

    // ---------------------------------------------------------------- stage 1: unpack
    // |x| = mant * 2^(e2), e2 = field - 150 (normal) or -149 (subnormal); sh = e2 + k.
    logic [23:0] mant;
    logic [4:0]  len;
    assign mant = (s0_x[30:23] == 0) ? {1'b0, s0_x[22:0]} : {1'b1, s0_x[22:0]};
    gridrt_bit_length #(.W(24)) u_len (.x_i(mant), .len_o(len));

    logic               s1_valid, s1_sign, s1_left;
    logic [23:0]        s1_mant;
    logic [4:0]         s1_len;
    logic signed [10:0] s1_shift;
    logic [5:0]         s1_sh;  // left shift (s1_left) or right shift d = min(-sh, 25)
    always_ff @(posedge clk_i) if (en_i) begin
        logic signed [10:0] sh;
        sh = ((s0_x[30:23] == 0) ? -11'sd149 : $signed({3'b000, s0_x[30:23]}) - 11'sd150) + 11'(s0_k);
        s1_valid <= s0_valid;
        s1_sign <= s0_x[31];
        s1_mant <= mant;
        s1_len <= len;
        s1_shift <= sh;
        s1_left <= sh >= 0;
        // Right shift by d = -sh with the half-away rounding bit; d >= 25 always gives 0.
        s1_sh <= (sh >= 0) ? sh[5:0] : (sh < -11'sd25) ? 6'd25 : 6'(-sh);
    end

    // ---------------------------------------------------------------- stage 2: shift, round
    logic        s2_valid, s2_sign, s2_huge;
    logic [54:0] s2_mag;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [24:0] rounded;
        logic        huge_v;
        rounded = ({1'b0, s1_mant} + (25'd1 << (s1_sh - 6'd1))) >> s1_sh;
        huge_v = s1_mant != 0 && s1_left && $signed({6'd0, s1_len}) + s1_shift > 11'sd54;
        s2_valid <= s1_valid;
        s2_sign <= s1_sign;
        s2_huge <= huge_v;
        if (huge_v) s2_mag <= 55'd0;
        else if (s1_left) s2_mag <= 55'(s1_mant) << s1_sh;
        else s2_mag <= 55'(rounded);
    end

    // ---------------------------------------------------------------- stage 3: sign
    always_ff @(posedge clk_i) if (en_i) begin
        out_valid_o <= s2_valid;
        huge_o <= s2_huge;
        q_o <= s2_sign ? -$signed(s2_mag) : $signed(s2_mag);
    end
endmodule
