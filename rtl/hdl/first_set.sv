// first_set: index of the lowest set bit of an N-bit register (N a multiple of 16), as two
// levels of 16-way priority encoders, the first level registered.
//
// The caller passes `bits_next`, the value its register takes at this clock edge; the
// first level (any bit and lowest bit of each 16-bit group) is registered from it, so
// `index` is the lowest set bit of the register's current value, as if encoded from the
// register itself, with one encoder level instead of two after the flip-flops. `index` is
// N when no bit is set.
module first_set #(
    parameter int N = 256
) (
    input  logic               clk,
    input  logic [N-1:0]       bits_next,
    output logic [$clog2(N):0] index
);
    localparam int G = N / 16;
    localparam int GW = (G > 1) ? $clog2(G) : 1;
    logic [G-1:0] any;
    logic [3:0]   low [G];
    always_ff @(posedge clk) begin
        for (int g = 0; g < G; g++) begin
            logic [3:0] l;
            l = 4'd0;
            for (int i = 15; i >= 0; i--) if (bits_next[16*g + i]) l = 4'(i);
            any[g] <= bits_next[16*g +: 16] != 0;
            low[g] <= l;
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
