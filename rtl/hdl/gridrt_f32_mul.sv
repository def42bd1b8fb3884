// gridrt_f32_mul: IEEE-754 binary32 a * b, round to nearest even, subnormals in and out.
//
// Spec: rtl/README.md §3 (IEEE-754 units). Bit-exact with Rust's `f32` `*` except that every NaN result is
// the canonical quiet NaN 0x7FC00000.
//
// Pipeline: LATENCY stages (24x24 product in MULT18X18D blocks | leading zeros | normalise |
// subnormal shift | round and pack); one operation per cycle; `out_valid` follows
// `in_valid` by LATENCY cycles.
module gridrt_f32_mul (
    input  logic        clk_i,
    input  logic        en_i,   // the co-processor's clock enable: every register holds while low
    input  logic        in_valid_i,
    input  logic [31:0] a_i,
    input  logic [31:0] b_i,
    output logic        out_valid_o,
    output logic [31:0] y_o
);
    localparam int MUL_LAT = 4;     // mul_pipe in DSP blocks
    localparam int LATENCY = MUL_LAT + 4;

    // ---------------------------------------------------------------- product (MUL_LAT)
    logic [49:0] prod50;
    gridrt_mul_pipe #(.A_W(25), .B_W(25), .LATENCY(MUL_LAT)) u_prod (
        .clk_i, .en_i(en_i), .a_i({1'b0, a_i[30:23] != 0, a_i[22:0]}), .b_i({1'b0, b_i[30:23] != 0, b_i[22:0]}), .p_o(prod50));

    logic       f_valid, f_nan, f_inf, f_zero, f_sign;
    logic [10:0] f_exp;     // signed: ea + eb - 127 with subnormals counted as exponent 1
    logic       p_valid, p_nan, p_inf, p_zero, p_sign;
    logic [10:0] p_exp;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [7:0] ea, eb, ea1, eb1;
        logic a_nan, b_nan, a_inf, b_inf, a_zero, b_zero;
        ea = a_i[30:23];
        eb = b_i[30:23];
        ea1 = (ea == 0) ? 8'd1 : ea;
        eb1 = (eb == 0) ? 8'd1 : eb;
        a_nan  = ea == 8'hFF && a_i[22:0] != 0;
        b_nan  = eb == 8'hFF && b_i[22:0] != 0;
        a_inf  = ea == 8'hFF && a_i[22:0] == 0;
        b_inf  = eb == 8'hFF && b_i[22:0] == 0;
        a_zero = a_i[30:0] == 0;
        b_zero = b_i[30:0] == 0;
        f_valid <= in_valid_i;
        f_nan   <= a_nan || b_nan || (a_inf && b_zero) || (b_inf && a_zero);
        f_inf   <= a_inf || b_inf;
        f_zero  <= a_zero || b_zero;
        f_sign  <= a_i[31] ^ b_i[31];
        f_exp   <= {3'b000, ea1} + {3'b000, eb1} - 11'd127;
    end
    gridrt_delay #(.W(16), .N(MUL_LAT - 1)) u_flags (.clk_i, .en_i(en_i), .d_i({f_valid, f_nan, f_inf, f_zero, f_sign, f_exp}),
                                              .q_o({p_valid, p_nan, p_inf, p_zero, p_sign, p_exp}));
    logic [47:0] p_prod;
    assign p_prod = prod50[47:0];

    // ---------------------------------------------------------------- stage 1: leading zeros
    // The product of two 1.23 mantissas is 2.46: bit 46 is the units bit. The leading one
    // goes to bit 47: exponent of the result = exp + 1 - lz.
    logic [5:0]  prod_len;
    gridrt_bit_length #(.W(48)) u_prod_len (.x_i(p_prod), .len_o(prod_len));
    logic        s1_valid, s1_nan, s1_inf, s1_zero, s1_sign;
    logic [47:0] s1_prod;
    logic [5:0]  s1_lz;
    logic [10:0] s1_exp;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [5:0] lz;
        lz = 6'd48 - prod_len;
        s1_valid <= p_valid;
        s1_nan   <= p_nan;
        s1_inf   <= p_inf;
        s1_zero  <= p_zero;
        s1_sign  <= p_sign;
        s1_prod  <= p_prod;
        s1_lz    <= lz;
        // exp + 1 - lz, from the length directly: one adder after bit_length, not two.
        s1_exp   <= p_exp + 11'(prod_len) - 11'd47;
    end

    // ---------------------------------------------------------------- stage 2: normalise
    // Shift left by lz; a result below exponent 1 will shift right by rs = 1 - e instead.
    // The bits a right shift by rs drops are marked here (bit i below rs), as one compare per
    // bit: the mask as (1 << rs) - 1 was a 48-bit carry chain after the shifter in stage 3.
    logic        s2_valid, s2_nan, s2_inf, s2_zero, s2_sign, s2_sub;
    logic [47:0] s2_p, s2_drop;
    logic [10:0] s2_exp, s2_rs;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [10:0] rs;
        rs = 11'd1 - s1_exp;
        s2_valid <= s1_valid;
        s2_nan   <= s1_nan;
        s2_inf   <= s1_inf;
        s2_zero  <= s1_zero;
        s2_sign  <= s1_sign;
        s2_p     <= s1_prod << s1_lz;
        s2_sub   <= $signed(s1_exp) < 1;
        s2_exp   <= ($signed(s1_exp) < 1) ? 11'd1 : s1_exp;
        s2_rs    <= rs;
        for (int i = 0; i < 48; i++) s2_drop[i] <= rs > 11'(i);
    end

    // ---------------------------------------------------------------- stage 3: subnormal
    // Subnormal: shift right until the exponent is 1, shifted-out bits into the sticky bit
    // (a shift by 48 or more drops every bit: the mask is all ones, the shift gives 0).
    logic        s3_valid, s3_nan, s3_inf, s3_zero, s3_sign, s3_sticky;
    logic [47:0] s3_norm;
    logic [10:0] s3_exp;
    always_ff @(posedge clk_i) if (en_i) begin
        logic [47:0] p;
        logic        st;
        p = s2_p;
        st = 1'b0;
        if (s2_sub) begin
            st = (p & s2_drop) != 0;
            p = p >> s2_rs;
        end
        s3_valid  <= s2_valid;
        s3_nan    <= s2_nan;
        s3_inf    <= s2_inf;
        s3_zero   <= s2_zero;
        s3_sign   <= s2_sign;
        s3_norm   <= p;
        s3_exp    <= s2_exp;
        s3_sticky <= st;
    end

    // ---------------------------------------------------------------- stage 4: round, pack
    // s3_norm[47] hidden bit, [46:24] fraction, [23] guard, [22:0] | sticky round.
    logic [31:0] result;
    gridrt_f32_round_pack u_round (
        .nan_i(s3_nan), .inf_i(s3_inf), .zero_i(s3_zero), .sign_i(s3_sign), .zero_sign_i(s3_sign),
        .exp_i(s3_exp), .mant_i(s3_norm[47:24]), .guard_i(s3_norm[23]),
        .sticky_i((s3_norm[22:0] != 0) || s3_sticky), .y_o(result));

    always_ff @(posedge clk_i) if (en_i) begin
        out_valid_o <= s3_valid;
        y_o <= result;
    end
endmodule
