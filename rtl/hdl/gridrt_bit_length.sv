// gridrt_bit_length: the number of significant bits of an unsigned W-bit value (0 for 0), as
// 8-bit groups (each group's leading one), a priority over the groups and a select: a few
// logic levels where a W-long priority chain would be W deep.
module gridrt_bit_length #(
    parameter int W = 64
) (
    input  logic [W-1:0]             x_i,
    output logic [$clog2(W+1)-1:0]   len_o
);
    localparam int G = (W + 7) / 8;
    localparam int GW = (G > 1) ? $clog2(G) : 1;
    localparam int LW = $clog2(W + 1);
    logic [8*G-1:0] xp;
    logic [G-1:0]   any;
    logic [2:0]     top [G];
    assign xp = (8*G)'(x_i);
    always_comb begin
        for (int g = 0; g < G; g++) begin
            any[g] = xp[8*g +: 8] != 0;
            top[g] = 3'd0;
            for (int i = 0; i < 8; i++) if (xp[8*g + i]) top[g] = 3'(i);
        end
    end
    always_comb begin
        logic [GW-1:0] grp;
        grp = '0;
        for (int g = 0; g < G; g++) if (any[g]) grp = GW'(g);
        len_o = (any == 0) ? LW'(0) : LW'({grp, top[grp]}) + LW'(1);
    end
endmodule
