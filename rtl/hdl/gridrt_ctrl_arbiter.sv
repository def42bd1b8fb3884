// gridrt_ctrl_arbiter: what the controller's arbitration decides on (rtl/README.md §4.4):
// the first open list entry and the first hit entry over all PEs (each PE reports its own,
// registered; MAX_LIST: none) and the number of tests issued.
//
// The minimum over the PEs is registered here, so a decision in a cycle sees the PEs' events
// of two cycles before. The entry bits only get set during a ray, so deciding on that state
// picks the same winner later; the test count is taken one cycle further back to match
// (issued_o is the sum of two cycles before).
module gridrt_ctrl_arbiter #(
    parameter int PES = 4,
    parameter int MAX_LIST = 256
) (
    input  logic                                clk_i,
    input  logic                                en_i,   // the co-processor's clock enable: every register holds while low
    input  logic [PES-1:0][$clog2(MAX_LIST):0]  pe_open_k_i,
    input  logic [PES-1:0][$clog2(MAX_LIST):0]  pe_hit_k_i,
    input  logic [PES-1:0][31:0]                pe_issued_i,
    output logic [$clog2(MAX_LIST):0]           first_open_o,
    output logic [$clog2(MAX_LIST):0]           first_hit_o,
    output logic [34:0]                         issued_o
);
    localparam int KW = $clog2(MAX_LIST);

    logic [KW:0] first_hit_d, first_open_d;
    logic [34:0] issued_d, issued_q;
    always_comb begin
        first_hit_d = (KW+1)'(MAX_LIST);
        first_open_d = (KW+1)'(MAX_LIST);
        issued_d = '0;
        for (int p = 0; p < PES; p++) begin
            if (pe_hit_k_i[p] < first_hit_d) first_hit_d = pe_hit_k_i[p];
            if (pe_open_k_i[p] < first_open_d) first_open_d = pe_open_k_i[p];
            issued_d = issued_d + 35'(pe_issued_i[p]);
        end
    end

    always_ff @(posedge clk_i) if (en_i) begin
        first_hit_o <= first_hit_d;
        first_open_o <= first_open_d;
        issued_q <= issued_d;
        issued_o <= issued_q;
    end
endmodule
