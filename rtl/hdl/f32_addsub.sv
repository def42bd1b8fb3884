// f32_addsub: IEEE-754 binary32 a + b or a - b, round to nearest even, subnormals in and out.
//
// Spec: rtl/README.md §3.5. Bit-exact with Rust's `f32` `+`/`-` except that every NaN
// result is the canonical quiet NaN 0x7FC00000 (the co-processor's only NaN sources are
// inf - inf and inf * 0 in the normal, which the model canonicalises the same way).
//
// Pipeline: 3 stages (unpack and swap | align and add | normalise and round); one operation
// per cycle; `out_valid` follows `in_valid` by LATENCY cycles.
module f32_addsub (
    input  logic        clk,
    input  logic        in_valid,
    input  logic [31:0] a,
    input  logic [31:0] b,
    input  logic        sub,        // 1: a - b
    output logic        out_valid,
    output logic [31:0] y
);
    localparam int LATENCY = 3;

    // ---------------------------------------------------------------- stage 1: unpack, order
    logic [31:0] b_eff;
    logic        a_big;
    logic [31:0] hi, lo;
    always_comb begin
        b_eff = {b[31] ^ sub, b[30:0]};
        a_big = a[30:0] >= b_eff[30:0];
        hi    = a_big ? a : b_eff;
        lo    = a_big ? b_eff : a;
    end

    logic        s1_valid, s1_nan, s1_inf, s1_sign_hi, s1_subtract, s1_zero_sign;
    logic [7:0]  s1_exp;        // effective exponent of hi (subnormal: 1)
    logic [7:0]  s1_diff;       // exponent difference
    logic [23:0] s1_mhi, s1_mlo;
    always_ff @(posedge clk) begin
        logic [7:0] ehi, elo;
        ehi = hi[30:23];
        elo = lo[30:23];
        s1_valid    <= in_valid;
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

    // ---------------------------------------------------------------- stage 2: align, add
    // Mantissas carry 3 extra bits (guard, round, sticky); the sum has one carry bit on top.
    logic [26:0] lo_aligned;
    logic [27:0] sum;
    always_comb begin
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
        lo_aligned = {shifted[26:1], shifted[0] | st};
        if (s1_subtract) sum = {1'b0, s1_mhi, 3'b000} - {1'b0, lo_aligned};
        else             sum = {1'b0, s1_mhi, 3'b000} + {1'b0, lo_aligned};
    end

    logic        s2_valid, s2_nan, s2_inf, s2_sign, s2_zero_sign;
    logic [7:0]  s2_exp;
    logic [27:0] s2_sum;
    always_ff @(posedge clk) begin
        s2_valid     <= s1_valid;
        s2_nan       <= s1_nan;
        s2_inf       <= s1_inf;
        s2_sign      <= s1_sign_hi;
        s2_zero_sign <= s1_zero_sign;
        s2_exp       <= s1_exp;
        s2_sum       <= sum;
    end

    // ---------------------------------------------------------------- stage 3: normalise, round
    logic [31:0] result;
    always_comb begin
        logic [4:0]  lz;
        logic [27:0] norm;
        logic [9:0]  e;         // signed headroom for the exponent arithmetic
        logic [24:0] mant;
        logic        g, r;
        logic [4:0]  shift;
        shift = 5'd0;
        g = 1'b0;
        r = 1'b0;
        mant = 25'd0;
        result = 32'd0;
        lz = 5'd28;
        for (int i = 0; i < 28; i++) if (s2_sum[i]) lz = 5'(27 - i);
        if (s2_sum[27]) begin
            // Carry out: shift right by one, keeping the lost bit sticky.
            norm = {1'b0, s2_sum[27:2], s2_sum[1] | s2_sum[0]};
            e = {2'b00, s2_exp} + 10'd1;
        end else begin
            // lz >= 1 here; shift left by lz - 1, but never below exponent 1 (subnormal).
            shift = (10'(lz) - 10'd1 > {2'b00, s2_exp} - 10'd1) ? 5'(s2_exp - 8'd1) : 5'(lz - 5'd1);
            norm = s2_sum << shift;
            e = {2'b00, s2_exp} - 10'(shift);
        end
        // norm[26] is the hidden bit (0 for a subnormal result); norm[2:0] = G, R, S.
        g = norm[2];
        r = norm[1] | norm[0];
        mant = {1'b0, norm[26:3]};
        if (g && (r || mant[0])) mant = mant + 25'd1;
        if (mant[24]) begin
            mant = mant >> 1;
            e = e + 10'd1;
        end
        if (s2_nan)
            result = 32'h7FC0_0000;
        else if (s2_inf)
            result = {s2_sign, 8'hFF, 23'd0};
        else if (s2_sum == 0)
            result = {s2_zero_sign, 31'd0};
        else if (e >= 10'd255)
            result = {s2_sign, 8'hFF, 23'd0};
        else if (!mant[23])
            result = {s2_sign, 8'd0, mant[22:0]};    // subnormal (e is 1)
        else
            result = {s2_sign, e[7:0], mant[22:0]};
    end

    always_ff @(posedge clk) begin
        out_valid <= s2_valid;
        y <= result;
    end
endmodule
