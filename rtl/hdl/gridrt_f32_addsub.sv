// gridrt_f32_addsub: IEEE-754 binary32 a + b or a - b, round to nearest even, subnormals in and out.
//
// Spec: rtl/README.md §3 (IEEE-754 units). Bit-exact with Rust's `f32` `+`/`-` except that every NaN
// result is the canonical quiet NaN 0x7FC00000 (the co-processor's only NaN sources are
// inf - inf and inf * 0 in the normal, which the model canonicalises the same way).
//
// Pipeline: 7 stages (operands | unpack and swap | align | add | leading zeros | normalise |
// round and pack); one operation per cycle; `out_valid` follows `in_valid` by LATENCY
// cycles. The operand registers keep the callers' operand selection out of the swap's
// compare (tri_loader's was a long path of a placed 4-PE design).
module gridrt_f32_addsub (
    input  logic        clk_i,
    input  logic        en_i,   // the co-processor's clock enable: every register holds while low
    input  logic        in_valid_i,
    input  logic [31:0] a_i,
    input  logic [31:0] b_i,
    input  logic        sub_i,        // 1: a - b
    output logic        out_valid_o,
    output logic [31:0] y_o
);
    localparam int LATENCY = 7;

    // ---------------------------------------------------------------- stage 0: operands
    logic        s0_valid;
    logic [31:0] s0_a, s0_b;    // s0_b: b with the operation's sign
    always_ff @(posedge clk_i) if (en_i) begin
        s0_valid <= in_valid_i;
        s0_a <= a_i;
        s0_b <= {b_i[31] ^ sub_i, b_i[30:0]};
    end

    // ---------------------------------------------------------------- stage 1: unpack, order
    logic        a_big;
    logic [31:0] hi, lo;
    always_comb begin
        a_big = s0_a[30:0] >= s0_b[30:0];
        hi    = a_big ? s0_a : s0_b;
        lo    = a_big ? s0_b : s0_a;
    end

    logic        s1_valid, s1_nan, s1_inf, s1_sign_hi, s1_subtract, s1_zero_sign;
    logic [7:0]  s1_exp;        // effective exponent of hi (subnormal: 1)
    logic [7:0]  s1_diff;       // exponent difference
    logic [23:0] s1_mhi, s1_mlo;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [7:0] ehi, elo;
        ehi = hi[30:23];
        elo = lo[30:23];
        s1_valid    <= s0_valid;
        s1_nan      <= (ehi == 8'hFF && hi[22:0] != 0) || (elo == 8'hFF && lo[22:0] != 0)
                       || (ehi == 8'hFF && elo == 8'hFF && hi[31] != lo[31]);
        s1_inf      <= ehi == 8'hFF;
        s1_sign_hi  <= hi[31];
        s1_subtract <= hi[31] != lo[31];
        // Sign of an exact zero sum: -0 only for (-0) + (-0).
        s1_zero_sign <= hi[31] & lo[31];
        s1_exp      <= (ehi == 0) ? 8'd1 : ehi;
        s1_diff     <= ((ehi == 0) ? 8'd1 : ehi) - ((elo == 0) ? 8'd1 : elo);
        s1_mhi      <= {ehi != 0, hi[22:0]};
        s1_mlo      <= {elo != 0, lo[22:0]};
    end

    // ---------------------------------------------------------------- stage 2: align
    // Mantissas carry 3 extra bits (guard, round, sticky); the sum has one carry bit on top.
    logic        s2_valid, s2_nan, s2_inf, s2_sign, s2_zero_sign, s2_subtract;
    logic [7:0]  s2_exp;
    logic [23:0] s2_mhi;
    logic [26:0] s2_lo;     // aligned, sticky in bit 0
    always_ff @(posedge clk_i) if (en_i) begin
        logic [26:0] lo_ext;
        logic [26:0] shifted;
        logic        st;
        lo_ext = {s1_mlo, 3'b000};
        if (s1_diff >= 8'd27) begin
            shifted = 27'd0;
            st = s1_mlo != 0;
        end else begin
            shifted = lo_ext >> s1_diff;
            st = (lo_ext & ((27'd1 << s1_diff) - 27'd1)) != 0;
        end
        s2_lo        <= {shifted[26:1], shifted[0] | st};
        s2_valid     <= s1_valid;
        s2_nan       <= s1_nan;
        s2_inf       <= s1_inf;
        s2_sign      <= s1_sign_hi;
        s2_zero_sign <= s1_zero_sign;
        s2_subtract  <= s1_subtract;
        s2_exp       <= s1_exp;
        s2_mhi       <= s1_mhi;
    end

    // ---------------------------------------------------------------- stage 3: add
    logic        s3_valid, s3_nan, s3_inf, s3_sign, s3_zero_sign;
    logic [7:0]  s3_exp;
    logic [27:0] s3_sum;
    always_ff @(posedge clk_i) if (en_i) begin
        if (s2_subtract) s3_sum <= {1'b0, s2_mhi, 3'b000} - {1'b0, s2_lo};
        else             s3_sum <= {1'b0, s2_mhi, 3'b000} + {1'b0, s2_lo};
        s3_valid     <= s2_valid;
        s3_nan       <= s2_nan;
        s3_inf       <= s2_inf;
        s3_sign      <= s2_sign;
        s3_zero_sign <= s2_zero_sign;
        s3_exp       <= s2_exp;
    end

    // ---------------------------------------------------------------- stage 4: leading zeros
    logic [4:0]  sum_len;
    gridrt_bit_length #(.W(28)) u_sum_len (.x_i(s3_sum), .len_o(sum_len));
    logic        s4_valid, s4_nan, s4_inf, s4_sign, s4_zero_sign;
    logic [7:0]  s4_exp;
    logic [27:0] s4_sum;
    logic [4:0]  s4_shift;  // left shift when there is no carry out
    always_ff @(posedge clk_i) if (en_i) begin
        logic [4:0] lz;
        lz = 5'd28 - sum_len;
        // lz >= 1 without a carry; shift left by lz - 1, but never below exponent 1 (subnormal).
        s4_shift     <= (10'(lz) - 10'd1 > {2'b00, s3_exp} - 10'd1) ? 5'(s3_exp - 8'd1) : 5'(lz - 5'd1);
        s4_sum       <= s3_sum;
        s4_valid     <= s3_valid;
        s4_nan       <= s3_nan;
        s4_inf       <= s3_inf;
        s4_sign      <= s3_sign;
        s4_zero_sign <= s3_zero_sign;
        s4_exp       <= s3_exp;
    end

    // ---------------------------------------------------------------- stage 5: normalise
    logic        s5_valid, s5_nan, s5_inf, s5_sign, s5_zero_sign, s5_zero;
    logic [9:0]  s5_e;      // signed headroom for the exponent arithmetic
    logic [27:0] s5_norm;
    always_ff @(posedge clk_i) if (en_i) begin
        if (s4_sum[27]) begin
            // Carry out: shift right by one, keeping the lost bit sticky.
            s5_norm <= {1'b0, s4_sum[27:2], s4_sum[1] | s4_sum[0]};
            s5_e <= {2'b00, s4_exp} + 10'd1;
        end else begin
            s5_norm <= s4_sum << s4_shift;
            s5_e <= {2'b00, s4_exp} - 10'(s4_shift);
        end
        s5_zero      <= s4_sum == 0;
        s5_valid     <= s4_valid;
        s5_nan       <= s4_nan;
        s5_inf       <= s4_inf;
        s5_sign      <= s4_sign;
        s5_zero_sign <= s4_zero_sign;
    end

    // ---------------------------------------------------------------- stage 6: round, pack
    // s5_norm[26] is the hidden bit (0 for a subnormal result); s5_norm[2:0] = G, R, S.
    logic [31:0] result;
    gridrt_f32_round_pack u_round (
        .nan_i(s5_nan), .inf_i(s5_inf), .zero_i(s5_zero), .sign_i(s5_sign), .zero_sign_i(s5_zero_sign),
        .exp_i({1'b0, s5_e}), .mant_i(s5_norm[26:3]), .guard_i(s5_norm[2]),
        .sticky_i(s5_norm[1] | s5_norm[0]), .y_o(result));

    always_ff @(posedge clk_i) if (en_i) begin
        out_valid_o <= s5_valid;
        y_o <= result;
    end
endmodule
