// SPDX-License-Identifier: Apache-2.0
// Formal property wrapper of rtl/dac_sched/dac_sched.v (SymbiYosys, tb/formal/README.md). The
// producer is the documented contract (the result of request k comes PIPE_CYCLES clocks after
// it, with its channel; any data); rst is free at every clock. Proven: every frame has exactly
// CHANNELS loads (rising dac_wr_n), channel k at k*SKEW + PIPE + 2 + WR_CYCLES clocks after the
// frame start, so successive loads exactly SKEW_CYCLES apart and channel 0 exactly FRAME_CYCLES
// apart; the strobe low exactly WR_CYCLES clocks with data and address stable from one clock
// before it falls to one clock after it rises; no load while held in reset ("killed").
// The .sby script connects the peek_* wires to the scheduler's counters (bind-free: `connect`
// after `flatten`) so that k-induction can state the invariant that relates them.
`timescale 1ns / 1ps
`default_nettype none

module dac_sched_formal #(
    parameter integer CLK_HZ      = 2_000_000,
    parameter integer SKEW_NS     = 2000,
    parameter integer FRAME_NS    = 16000,
    parameter integer SETTLE_NS   = 16000,
    parameter integer CHANNELS    = 6,
    parameter integer WR_CYCLES   = 1,
    parameter integer PIPE_CYCLES = 5
) (
    input wire        clk,
    input wire        rst,
    input wire [13:0] s_data
);
    localparam integer CLK_KHZ      = CLK_HZ / 1000;
    localparam integer SKEW_CYCLES  = CLK_KHZ * SKEW_NS / 1_000_000;
    localparam integer FRAME_CYCLES = CLK_KHZ * FRAME_NS / 1_000_000;
    localparam integer LOAD         = PIPE_CYCLES + 2 + WR_CYCLES;
    localparam integer FW           = $clog2(FRAME_CYCLES);
    localparam integer SW           = $clog2(SKEW_CYCLES);

    wire        m_frame, m_req;
    wire [2:0]  m_req_ch;
    wire [13:0] dac_data;
    wire [2:0]  dac_addr;
    wire        dac_wr_n;
    reg  [PIPE_CYCLES-1:0] v_pipe = 0;
    reg  [3*PIPE_CYCLES-1:0] ch_pipe = 0;
    wire        s_valid = v_pipe[PIPE_CYCLES-1];
    wire [2:0]  s_ch    = ch_pipe[3*PIPE_CYCLES-1 -: 3];

    dac_sched #(
        .CLK_HZ(CLK_HZ), .SKEW_NS(SKEW_NS), .FRAME_NS(FRAME_NS), .SETTLE_NS(SETTLE_NS),
        .CHANNELS(CHANNELS), .ADDR_BITS(3), .DAC_BITS(14), .WR_CYCLES(WR_CYCLES),
        .PIPE_CYCLES(PIPE_CYCLES)
    ) dut (
        .clk(clk), .rst(rst), .m_frame(m_frame), .m_req(m_req), .m_req_ch(m_req_ch),
        .s_valid(s_valid), .s_ch(s_ch), .s_data(s_data),
        .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n)
    );

    // the producer contract (the commutator's pipeline; reset like its valid bits)
    always @(posedge clk) begin
        if (rst) v_pipe <= 0;
        else     v_pipe <= {v_pipe[PIPE_CYCLES-2:0], m_req};
        ch_pipe <= {ch_pipe[3*PIPE_CYCLES-4:0], m_req_ch};
    end

`ifdef FORMAL
    (* keep *) wire [FW-1:0] peek_frame_cnt;
    (* keep *) wire [SW-1:0] peek_slot_cnt;
    (* keep *) wire [3:0]    peek_ch_cnt;
    (* keep *) wire          peek_wr_go;
    (* keep *) wire [3:0]    peek_wr_left;

    reg init = 1'b1;
    always @(posedge clk) init <= 1'b0;
    always @(*) if (init) assume (rst);

    reg        wr_q = 1'b1, rst_q = 1'b0, rst_qq = 1'b0;
    reg [13:0] data_q;
    reg [2:0]  addr_q;
    always @(posedge clk) begin
        wr_q   <= dac_wr_n;
        rst_q  <= rst;
        rst_qq <= rst_q;
        data_q <= dac_data;
        addr_q <= dac_addr;
    end
    wire load = dac_wr_n && !wr_q;           // the DAC loads on this rising edge
    wire load_run = load && !rst_q;          // (not the strobe the reset edge cut short)
    wire fall = !dac_wr_n && wr_q;

    // clocks since the frame start (frame 0 starts at the last edge with rst high)
    reg [FW:0] since = 0;
    reg [3:0]  loads = 0;                    // loads in this frame
    reg [3:0]  low = 0;                      // clocks the strobe has been low
    always @(posedge clk) begin
        if (rst || m_frame) begin
            since <= 0;
            loads <= 0;
        end else begin
            since <= since + 1'b1;
            if (load_run) loads <= loads + 1'b1;
        end
        low <= dac_wr_n ? 4'd0 : low + 4'd1;
    end

    always @(*) begin
        // no load while held in reset (the edge that enters reset may end a strobe in progress)
        if (!init && rst_q && rst_qq) assert (!load);
        if (!init && !rst_q) begin
            // every load at its documented clock: channel k at k*SKEW + LOAD after the frame start
            if (load) assert (dac_addr < CHANNELS && since == dac_addr * SKEW_CYCLES + LOAD
                              && loads == dac_addr);
            // a frame ends with all its loads done
            if (m_frame) assert (loads == CHANNELS);
            // the strobe: low exactly WR_CYCLES clocks; data, address stable around it
            if (load) assert (low == WR_CYCLES);
            if (!dac_wr_n) assert (low < WR_CYCLES);
            if (!wr_q || fall) assert (dac_data == data_q && dac_addr == addr_q);
        end
        // inductive strengthening: the scheduler's counters follow the frame
        if (!init && !rst_q) begin
            assert (peek_frame_cnt == since);
            assert (peek_slot_cnt == since % SKEW_CYCLES);
            assert (peek_ch_cnt == ((since / SKEW_CYCLES) < CHANNELS ? since / SKEW_CYCLES
                                                                   : CHANNELS));
        end
    end

    // loads exactly SKEW apart and channel 0 exactly FRAME apart (what the DAC sees)
    reg [FW+1:0] gap = 0, gap0 = 0;
    reg          any = 1'b0, any0 = 1'b0;
    always @(posedge clk) begin
        if (rst) begin
            any  <= 1'b0;
            any0 <= 1'b0;
        end else begin
            if (load_run) any <= 1'b1;
            if (load_run && dac_addr == 0) any0 <= 1'b1;
        end
        gap  <= load ? 1 : (gap == {(FW+2){1'b1}} ? gap : gap + 1'b1);
        gap0 <= (load && dac_addr == 0) ? 1 : (gap0 == {(FW+2){1'b1}} ? gap0 : gap0 + 1'b1);
    end
    always @(*) begin
        if (!init && !rst_q && load && any && dac_addr != 0) assert (gap == SKEW_CYCLES);
        if (!init && !rst_q && load && any0 && dac_addr == 0) assert (gap0 == FRAME_CYCLES);
    end

    // ---- inductive strengthening for the long frames (12 and 48 MHz): where every tracker
    // stands, as a function of the clock in the frame (only wrapper state and the peeks)
    localparam integer LAST = (CHANNELS - 1) * SKEW_CYCLES + LOAD;   // last load's clock
    reg [7:0] run_n = 0;                     // clocks since reset (saturating)
    always @(posedge clk) run_n <= rst ? 8'd0 : ((run_n == 8'hff) ? run_n : run_n + 8'd1);

    function integer loads_before;           // loads in a frame before clock c
        input integer c;
        begin
            if (c <= LOAD) loads_before = 0;
            else if ((c - LOAD - 1) / SKEW_CYCLES + 1 > CHANNELS) loads_before = CHANNELS;
            else loads_before = (c - LOAD - 1) / SKEW_CYCLES + 1;
        end
    endfunction
    function is_req;                         // a request clock (m_req) of the frame
        input integer c;
        begin
            is_req = (c % SKEW_CYCLES == 0) && (c / SKEW_CYCLES < CHANNELS);
        end
    endfunction

    function in_strobe;                      // clocks of the frame with dac_wr_n low
        input integer c;
        begin
            in_strobe = (c >= PIPE_CYCLES + 2) && ((c - PIPE_CYCLES - 2) % SKEW_CYCLES < WR_CYCLES)
                        && ((c - PIPE_CYCLES - 2) / SKEW_CYCLES < CHANNELS);
        end
    endfunction

    integer j;
    always @(*) begin
        // the clock after a reset edge: every tracker and the scheduler start afresh
        if (!init && rst_q)
            assert (since == 0 && loads == 0 && run_n == 0 && v_pipe == 0 && dac_wr_n
                    && !peek_wr_go && peek_frame_cnt == 0 && peek_slot_cnt == 0
                    && peek_ch_cnt == 0 && !any && !any0);
        if (!init && run_n != 8'hff) assert (since == run_n % FRAME_CYCLES);
        if (!init && !rst_q && (peek_wr_go || !dac_wr_n))
            assert (dac_addr == (since - PIPE_CYCLES - 1) / SKEW_CYCLES);
        if (!init && !rst_q) begin
            assert (!dac_wr_n == in_strobe(since));
            if (!dac_wr_n) assert (low == (since - PIPE_CYCLES - 2) % SKEW_CYCLES);
        end
        if (!init && !rst_q) begin
            assert (since < FRAME_CYCLES);
            assert (m_frame == (since == FRAME_CYCLES - 1));
            assert (loads == loads_before(since));
            assert (m_req == is_req(since));
            if (any && loads != 0) assert (gap == since - ((loads - 1) * SKEW_CYCLES + LOAD));
            if (any && loads == 0) assert (gap == since + FRAME_CYCLES - LAST);
            if (any0 && loads != 0) assert (gap0 == since - LOAD);
            if (any0 && loads == 0) assert (gap0 == since + FRAME_CYCLES - LOAD);
            if (!dac_wr_n) assert (peek_wr_left == WR_CYCLES - 1 - low);
        end
        // the producer pipeline and the strobe trigger: requests of the last clocks, none
        // from before the reset
        for (j = 0; j < PIPE_CYCLES; j = j + 1)
            if (!init && !rst_q)
                assert (v_pipe[j] == (j < run_n && is_req((since + FRAME_CYCLES - 1 - j)
                                                           % FRAME_CYCLES))
                        && (!v_pipe[j] || ch_pipe[3*j +: 3]
                            == ((since + FRAME_CYCLES - 1 - j) % FRAME_CYCLES) / SKEW_CYCLES));
        if (!init && !rst_q)
            assert (peek_wr_go == (PIPE_CYCLES < run_n
                                   && is_req((since + FRAME_CYCLES - PIPE_CYCLES - 1)
                                             % FRAME_CYCLES)));
    end
`endif
endmodule

`default_nettype wire
