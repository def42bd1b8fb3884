// f32_mul: IEEE-754 binary32 a * b, round to nearest even, subnormals in and out.
//
// Spec: rtl/README.md §3.5. Bit-exact with Rust's `f32` `*` except that every NaN result is
// the canonical quiet NaN 0x7FC00000.
//
// Pipeline: 3 stages (unpack and 24x24 product | normalise | round and pack).
module f32_mul (
    input  logic        clk,
    input  logic        in_valid,
    input  logic [31:0] a,
    input  logic [31:0] b,
    output logic        out_valid,
    output logic [31:0] y
);
    localparam int LATENCY = 3;

    // ---------------------------------------------------------------- stage 1: product
    logic        s1_valid, s1_nan, s1_inf, s1_zero, s1_sign;
    logic [47:0] s1_prod;
    logic [10:0] s1_exp;    // signed: ea + eb - 127 with subnormals counted as exponent 1
    always_ff @(posedge clk) begin
        logic [7:0] ea, eb, ea1, eb1;
        logic a_nan, b_nan, a_inf, b_inf, a_zero, b_zero;
        ea = a[30:23];
        eb = b[30:23];
        ea1 = (ea == 0) ? 8'd1 : ea;
        eb1 = (eb == 0) ? 8'd1 : eb;
        a_nan  = ea == 8'hFF && a[22:0] != 0;
        b_nan  = eb == 8'hFF && b[22:0] != 0;
        a_inf  = ea == 8'hFF && a[22:0] == 0;
        b_inf  = eb == 8'hFF && b[22:0] == 0;
        a_zero = a[30:0] == 0;
        b_zero = b[30:0] == 0;
        s1_valid <= in_valid;
        s1_nan   <= a_nan || b_nan || (a_inf && b_zero) || (b_inf && a_zero);
        s1_inf   <= a_inf || b_inf;
        s1_zero  <= a_zero || b_zero;
        s1_sign  <= a[31] ^ b[31];
        s1_prod  <= {24'd0, ea != 0, a[22:0]} * {24'd0, eb != 0, b[22:0]};
        s1_exp   <= {3'b000, ea1} + {3'b000, eb1} - 11'd127;
    end

    // ---------------------------------------------------------------- stage 2: normalise
    // The product of two 1.23 mantissas is 2.46: bit 46 is the units bit. Normalise so the
    // leading one sits at bit 47 ... but never below exponent 1; then shift right for
    // subnormal results, folding shifted-out bits into the sticky bit.
    logic        s2_valid, s2_nan, s2_inf, s2_zero, s2_sign, s2_sticky;
    logic [47:0] s2_norm;
    logic [10:0] s2_exp;
    always_ff @(posedge clk) begin
        logic [5:0]  lz;
        logic [47:0] p;
        logic [10:0] e;
        logic        st;
        lz = 6'd48;
        for (int i = 0; i < 48; i++) if (s1_prod[i]) lz = 6'(47 - i);
        // Value = prod * 2^(exp - 1 - 46) with prod's units bit at 46; place the leading one
        // at bit 47: exponent of the result = exp + 1 - lz.
        p = s1_prod << lz;
        e = s1_exp + 11'd1 - 11'(lz);
        st = 1'b0;
        if ($signed(e) < 1) begin
            // Subnormal: shift right until the exponent is 1.
            logic [10:0] rs;
            rs = 11'd1 - e;
            if (rs >= 11'd48) begin
                st = p != 0;
                p = 48'd0;
            end else begin
                st = (p & ((48'd1 << rs) - 48'd1)) != 0;
                p = p >> rs;
            end
            e = 11'd1;
        end
        s2_valid  <= s1_valid;
        s2_nan    <= s1_nan;
        s2_inf    <= s1_inf;
        s2_zero   <= s1_zero;
        s2_sign   <= s1_sign;
        s2_norm   <= p;
        s2_exp    <= e;
        s2_sticky <= st;
    end

    // ---------------------------------------------------------------- stage 3: round, pack
    logic [31:0] result;
    always_comb begin
        logic [24:0] mant;
        logic [10:0] e;
        logic        g, r;
        // p[47] hidden bit, p[46:24] fraction, p[23] guard, p[22:0] | sticky round.
        mant = {1'b0, s2_norm[47:24]};
        g = s2_norm[23];
        r = (s2_norm[22:0] != 0) || s2_sticky;
        e = s2_exp;
        if (g && (r || mant[0])) mant = mant + 25'd1;
        if (mant[24]) begin
            mant = mant >> 1;
            e = e + 11'd1;
        end
        if (s2_nan)
            result = 32'h7FC0_0000;
        else if (s2_inf)
            result = {s2_sign, 8'hFF, 23'd0};
        else if (s2_zero)
            result = {s2_sign, 31'd0};
        else if ($signed(e) >= 255)
            result = {s2_sign, 8'hFF, 23'd0};
        else if (!mant[23])
            result = {s2_sign, 8'd0, mant[22:0]};
        else
            result = {s2_sign, e[7:0], mant[22:0]};
    end

    always_ff @(posedge clk) begin
        out_valid <= s2_valid;
        y <= result;
    end
endmodule
