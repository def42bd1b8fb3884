// f32_to_fixed: the exact f32 -> integer conversion Q(x, k) = round_half_away(x * 2^k).
//
// Spec: rtl/README.md §3.1; twin: `twin::to_fixed`. `huge` is set (and `q` is 0) when
// |x * 2^k| >= 2^54. `x` must be finite. Combinational.
module f32_to_fixed (
    input  logic [31:0]        x,
    input  logic signed [9:0]  k,
    output logic signed [54:0] q,
    output logic               huge
);
    always_comb begin
        logic [23:0]       mant;
        logic signed [10:0] sh;
        logic [4:0]        len;
        logic [54:0]       mag;
        logic [5:0]        d;
        logic [24:0]       rounded;
        mant = (x[30:23] == 0) ? {1'b0, x[22:0]} : {1'b1, x[22:0]};
        // |x| = mant * 2^(e2), e2 = field - 150 (normal) or -149 (subnormal).
        sh = ((x[30:23] == 0) ? -11'sd149 : $signed({3'b000, x[30:23]}) - 11'sd150) + 11'(k);
        len = 5'd0;
        for (int i = 0; i < 24; i++) if (mant[i]) len = 5'(i + 1);
        huge = 1'b0;
        mag = 55'd0;
        d = 6'd0;
        rounded = 25'd0;
        if (mant == 0) begin
            mag = 55'd0;
        end else if (sh >= 0) begin
            if ($signed({6'd0, len}) + sh > 11'sd54) huge = 1'b1;
            else mag = 55'(mant) << sh[5:0];
        end else begin
            // Right shift by d = -sh with the half-away rounding bit; d >= 25 always gives 0.
            d = (sh < -11'sd25) ? 6'd25 : 6'(-sh);
            rounded = ({1'b0, mant} + (25'd1 << (d - 6'd1))) >> d;
            mag = 55'(rounded);
        end
        q = x[31] ? -$signed(mag) : $signed(mag);
    end
endmodule
