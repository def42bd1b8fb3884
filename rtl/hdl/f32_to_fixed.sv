// f32_to_fixed: the exact f32 -> integer conversion Q(x, k) = round_half_away(x * 2^k).
//
// Spec: rtl/README.md §3.1; twin: `twin::to_fixed`. `huge` is set (and `q` is 0) when
// |x * 2^k| >= 2^54. `x` must be finite.
//
// Pipeline: 3 stages (unpack, shift amount and range | shift and round | sign); one
// conversion per cycle; `out_valid` follows `in_valid` by LATENCY cycles.
module f32_to_fixed (
    input  logic               clk,
    input  logic               in_valid,
    input  logic [31:0]        x,
    input  logic signed [9:0]  k,
    output logic               out_valid,
    output logic signed [54:0] q,
    output logic               huge
);
    localparam int LATENCY = 3;

    // ---------------------------------------------------------------- stage 1: unpack
    // |x| = mant * 2^(e2), e2 = field - 150 (normal) or -149 (subnormal); sh = e2 + k.
    logic [23:0] mant;
    logic [4:0]  len;
    assign mant = (x[30:23] == 0) ? {1'b0, x[22:0]} : {1'b1, x[22:0]};
    bit_length #(.W(24)) u_len (.x(mant), .len(len));

    logic        s1_valid, s1_sign, s1_left, s1_huge;
    logic [23:0] s1_mant;
    logic [5:0]  s1_sh;     // left shift (s1_left) or right shift d = min(-sh, 25)
    always_ff @(posedge clk) begin
        logic signed [10:0] sh;
        sh = ((x[30:23] == 0) ? -11'sd149 : $signed({3'b000, x[30:23]}) - 11'sd150) + 11'(k);
        s1_valid <= in_valid;
        s1_sign <= x[31];
        s1_mant <= mant;
        s1_left <= sh >= 0;
        s1_huge <= mant != 0 && sh >= 0 && $signed({6'd0, len}) + sh > 11'sd54;
        // Right shift by d = -sh with the half-away rounding bit; d >= 25 always gives 0.
        s1_sh <= (sh >= 0) ? sh[5:0] : (sh < -11'sd25) ? 6'd25 : 6'(-sh);
    end

    // ---------------------------------------------------------------- stage 2: shift, round
    logic        s2_valid, s2_sign, s2_huge;
    logic [54:0] s2_mag;
    always_ff @(posedge clk) begin
        logic [24:0] rounded;
        rounded = ({1'b0, s1_mant} + (25'd1 << (s1_sh - 6'd1))) >> s1_sh;
        s2_valid <= s1_valid;
        s2_sign <= s1_sign;
        s2_huge <= s1_huge;
        if (s1_huge) s2_mag <= 55'd0;
        else if (s1_left) s2_mag <= 55'(s1_mant) << s1_sh;
        else s2_mag <= 55'(rounded);
    end

    // ---------------------------------------------------------------- stage 3: sign
    always_ff @(posedge clk) begin
        out_valid <= s2_valid;
        huge <= s2_huge;
        q <= s2_sign ? -$signed(s2_mag) : $signed(s2_mag);
    end
endmodule
