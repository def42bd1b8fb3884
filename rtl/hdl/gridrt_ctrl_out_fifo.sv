// gridrt_ctrl_out_fifo: the controller's reply FIFO (DEPTH words of 32 data bits and the FSL
// control bit), read on the reply stream m_* (AXI4-Stream: the head word is offered while the
// FIFO is not empty and stays until taken). The controller pushes at most one word per cycle
// and only with room (it takes a request word only while DEPTH/2 + 1 words are free, enough
// for a RESULT); count_o is the fill level.
module gridrt_ctrl_out_fifo #(
    parameter int DEPTH = 16
) (
    input  logic                       clk_i,
    input  logic                       en_i,   // the co-processor's clock enable: every register holds while low
    input  logic                       rst_i,        // synchronous, active high
    input  logic                       push_i,
    input  logic [32:0]                push_word_i,  // {control bit, data}
    output logic [31:0]                m_tdata_o,
    output logic                       m_tlast_o,
    output logic                       m_tvalid_o,
    input  logic                       m_tready_i,
    output logic [$clog2(DEPTH+1)-1:0] count_o
);
    localparam int PW = $clog2(DEPTH);
    localparam int CW = $clog2(DEPTH + 1);

    logic [32:0]   mem_q [DEPTH];
    logic [PW-1:0] rd_d, rd_q, wr_d, wr_q;
    logic [CW-1:0] count_d, count_q;
    logic          pop;

    assign m_tvalid_o = count_q != 0;
    assign {m_tlast_o, m_tdata_o} = mem_q[rd_q];
    assign count_o = count_q;

    always_comb begin
        pop = m_tvalid_o && m_tready_i;
        wr_d = wr_q + PW'(push_i);
        rd_d = rd_q + PW'(pop);
        count_d = count_q + CW'(push_i) - CW'(pop);
    end

    always_ff @(posedge clk_i) if (en_i) begin
        if (rst_i) begin
            count_q <= '0;
            rd_q <= '0;
            wr_q <= '0;
        end else begin
            count_q <= count_d;
            rd_q <= rd_d;
            wr_q <= wr_d;
        end
    end

    always_ff @(posedge clk_i) if (en_i) begin
        if (!rst_i && push_i) mem_q[wr_q] <= push_word_i;
    end

`ifndef SYNTHESIS
    // Bounds: no push into a full FIFO, no pop from an empty one.
    PushNotFull: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) push_i |-> count_q < CW'(DEPTH))
        else $error("gridrt_ctrl_out_fifo: push into a full FIFO");
    PopNotEmpty: assert property (@(posedge clk_i) disable iff (!en_i || rst_i) pop |-> count_q != 0)
        else $error("gridrt_ctrl_out_fifo: pop from an empty FIFO");
`endif
endmodule
