// gridrt_f32_round_pack: the last step of gridrt_f32_addsub and gridrt_f32_mul, shared:
// round a normalised mantissa to nearest even and pack an IEEE-754 binary32 (combinational).
//
// mant_i is the hidden bit (0 for a subnormal result, whose exponent is then 1) and the 23
// fraction bits; guard_i is the first bit below them, sticky_i the OR of every lower bit.
// A carry out of the rounding shifts the mantissa right and raises the exponent; an exponent
// of 255 or more gives an infinity. Special results come first: NaN (canonical 0x7FC00000),
// infinity, exact zero (with zero_sign_i).
module gridrt_f32_round_pack (
    input  logic               nan_i,
    input  logic               inf_i,
    input  logic               zero_i,
    input  logic               sign_i,
    input  logic               zero_sign_i,  // sign of an exact zero result
    input  logic [10:0]        exp_i,        // biased exponent (signed), at least 1
    input  logic [23:0]        mant_i,
    input  logic               guard_i,
    input  logic               sticky_i,
    output logic [31:0]        y_o
);
    always_comb begin
        logic [24:0]        mant;
        logic [10:0]        e;
        mant = {1'b0, mant_i};
        e = exp_i;
        if (guard_i && (sticky_i || mant[0])) mant = mant + 25'd1;
        if (mant[24]) begin
            mant = mant >> 1;
            e = e + 11'd1;
        end
        if (nan_i)
            y_o = 32'h7FC0_0000;
        else if (inf_i)
            y_o = {sign_i, 8'hFF, 23'd0};
        else if (zero_i)
            y_o = {zero_sign_i, 31'd0};
        else if ($signed(e) >= 11'sd255)
            y_o = {sign_i, 8'hFF, 23'd0};
        else if (!mant[23])
            y_o = {sign_i, 8'd0, mant[22:0]};    // subnormal (e is 1)
        else
            y_o = {sign_i, e[7:0], mant[22:0]};
    end
endmodule
