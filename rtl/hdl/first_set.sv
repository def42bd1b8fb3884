// first_set: index of the lowest set bit of an N-bit vector (N a multiple of 16), as two
// levels of 16-way priority encoders (log depth instead of an N-long chain). `index` is N
// when no bit is set.
module first_set #(
    parameter int N = 256
) (
    input  logic [N-1:0]       bits,
    output logic [$clog2(N):0] index
);
    localparam int G = N / 16;
    localparam int GW = (G > 1) ? $clog2(G) : 1;
    logic [G-1:0] any;
    logic [3:0]   low [G];
    always_comb begin
        for (int g = 0; g < G; g++) begin
            any[g] = bits[16*g +: 16] != 0;
            low[g] = 4'd0;
            for (int i = 15; i >= 0; i--) if (bits[16*g + i]) low[g] = 4'(i);
        end
    end
    always_comb begin
        logic [GW-1:0] grp;
        grp = '0;
        for (int g = G - 1; g >= 0; g--) if (any[g]) grp = GW'(g);
        if (any == 0) index = ($clog2(N)+1)'(N);
        else index = ($clog2(N)+1)'({grp, low[grp]});
    end
endmodule
