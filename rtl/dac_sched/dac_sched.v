// SPDX-License-Identifier: Apache-2.0
// Six-channel DAC scheduler: a frame of FRAME_NS in which channel k (0..CHANNELS-1) is requested
// from the producer at k*SKEW_NS after the frame start, and each result is written to the
// parallel DAC port (data, channel address, active-low write strobe). All counts come from CLK_HZ.
// Bit-exact timing model: models/hapgate/golden/commutation.py (load_times_ns).
//
// Frame start = the rising edge that ends the clock with m_frame high (the producer latches its
// inputs there); channel k is requested in clock k*SKEW_CYCLES after it (m_req, m_req_ch).
// Write timing for a result presented on s_valid (one clock each, WR_CYCLES = 1):
//
//   clk       _/~\_/~\_/~\_/~\_/~\_/~\_
//   s_valid   __/~~~\__________________
//   dac_data  ======X==== code =========  (held until the next write, SKEW_CYCLES later)
//   dac_wr_n  ~~~~~~~~~~~\___/~~~~~~~~~~  (falls 1 clock after data: setup; rises WR_CYCLES later:
//                                          the DAC loads on this rising edge; hold >= SKEW - 2)
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module dac_sched #(
    parameter integer CLK_HZ      = 48_000_000, // FPGA clock: a multiple of 1 kHz, up to 134 MHz
    parameter integer SKEW_NS     = 2000,       // time between successive channel loads
    parameter integer FRAME_NS    = 16000,      // frame period: every channel loaded once per frame
    parameter integer SETTLE_NS   = 16000,      // DAC settling: no channel rewritten sooner
    parameter integer CHANNELS    = 6,          // channels per frame (3 motors x 2 phases)
    parameter integer ADDR_BITS   = 3,          // DAC channel address width
    parameter integer DAC_BITS    = 14,         // DAC data width
    parameter integer WR_CYCLES   = 1,          // clocks the write strobe is held low (1..15)
    parameter integer PIPE_CYCLES = 5           // producer latency, m_req clock to s_valid clock
) (
    input  wire                  clk,
    input  wire                  rst,
    output wire                  m_frame,    // inputs are latched at the end of this clock
    output wire                  m_req,      // compute channel m_req_ch (one clock)
    output wire [ADDR_BITS-1:0]  m_req_ch,
    input  wire                  s_valid,    // result for channel s_ch, PIPE_CYCLES after m_req
    input  wire [ADDR_BITS-1:0]  s_ch,
    input  wire [DAC_BITS-1:0]   s_data,
    output reg  [DAC_BITS-1:0]   dac_data,
    output reg  [ADDR_BITS-1:0]  dac_addr,
    output reg                   dac_wr_n
);
    localparam integer CLK_KHZ      = CLK_HZ / 1000;
    localparam integer SKEW_CYCLES  = CLK_KHZ * SKEW_NS / 1_000_000;
    localparam integer FRAME_CYCLES = CLK_KHZ * FRAME_NS / 1_000_000;
    localparam integer FW           = $clog2(FRAME_CYCLES);         // frame counter width
    localparam integer SW           = $clog2(SKEW_CYCLES);          // slot counter width
    localparam integer CW           = ADDR_BITS + 1;                // channel counter width
    localparam integer WW           = 4;                            // strobe counter width
    localparam integer FRAME_LAST_I = FRAME_CYCLES - 1;
    localparam integer SKEW_LAST_I  = SKEW_CYCLES - 1;
    localparam integer WR_LAST_I    = WR_CYCLES - 1;
    localparam [FW-1:0] FRAME_LAST  = FRAME_LAST_I[FW-1:0];
    localparam [SW-1:0] SKEW_LAST   = SKEW_LAST_I[SW-1:0];
    localparam [CW-1:0] CH_END      = CHANNELS[CW-1:0];
    localparam [WW-1:0] WR_LAST     = WR_LAST_I[WW-1:0];

    // Elaboration-time checks: a bad configuration instantiates a module that does not exist,
    // whose name is the message.
    generate
        if (CLK_HZ % 1000 != 0 || CLK_KHZ > 2147483647 / FRAME_NS ||
            CLK_KHZ > 2147483647 / SKEW_NS) begin : g_bad_clk
            dac_sched_CLK_HZ_must_be_a_multiple_of_1kHz_and_small_enough u_stop ();
        end
        if (CLK_KHZ * SKEW_NS % 1_000_000 != 0 || CLK_KHZ * FRAME_NS % 1_000_000 != 0) begin : g_inexact
            dac_sched_SKEW_NS_and_FRAME_NS_must_be_whole_clocks_of_CLK_HZ u_stop ();
        end
        if (CHANNELS < 1 || CHANNELS > (1 << ADDR_BITS)) begin : g_bad_channels
            dac_sched_CHANNELS_must_fit_ADDR_BITS u_stop ();
        end
        if (SKEW_CYCLES * CHANNELS > FRAME_CYCLES) begin : g_skew_frame
            dac_sched_CHANNELS_times_SKEW_must_not_exceed_FRAME u_stop ();
        end
        if (FRAME_NS < SETTLE_NS) begin : g_settle
            dac_sched_FRAME_NS_must_be_at_least_SETTLE_NS u_stop ();
        end
        if (WR_CYCLES < 1 || WR_CYCLES > 15 || SKEW_CYCLES < WR_CYCLES + 3) begin : g_bad_wr
            dac_sched_needs_1_le_WR_CYCLES_le_15_and_SKEW_CYCLES_ge_WR_CYCLES_plus_3 u_stop ();
        end
        if (PIPE_CYCLES < 0 || (CHANNELS - 1) * SKEW_CYCLES + PIPE_CYCLES + WR_CYCLES + 3
                               > FRAME_CYCLES) begin : g_late
            dac_sched_last_write_must_end_within_the_frame u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- frame and slot counters
    reg [FW-1:0] frame_cnt;  // clocks since the frame start
    reg [SW-1:0] slot_cnt;   // clocks since the current slot's request
    reg [CW-1:0] ch_cnt;     // slot number; CHANNELS = no more requests this frame
    reg          wr_go;      // data went out last clock: drop the strobe now (one clock of setup)

    `HG_SIM_SKIP_HOOK  // simulation only (rtl/include/hg_sim.vh): the idle-clock skip

    always @(posedge clk) begin
        if (rst || frame_cnt == FRAME_LAST) begin  // frame 0 starts at the last edge with rst high
            frame_cnt <= {FW{1'b0}};
            slot_cnt  <= {SW{1'b0}};
            ch_cnt    <= {CW{1'b0}};
        end else begin
            frame_cnt <= frame_cnt + 1'b1 `HG_SIM_SKIP_ADD(FW);
            slot_cnt  <= (slot_cnt == SKEW_LAST) ? {SW{1'b0}} : slot_cnt + 1'b1 `HG_SIM_SKIP_ADD(SW);
            if (slot_cnt == SKEW_LAST && ch_cnt != CH_END)
                ch_cnt <= ch_cnt + 1'b1;
        end
    end

    assign m_frame  = (frame_cnt == FRAME_LAST);
    assign m_req    = (slot_cnt == {SW{1'b0}}) && (ch_cnt != CH_END);
    assign m_req_ch = ch_cnt[ADDR_BITS-1:0];

    // ---------------------------------------------------------------- DAC write strobe
    reg [WW-1:0] wr_left;  // further clocks the strobe stays low

    // The strobe is high from FPGA configuration on, before the first clock and reset: a low
    // strobe would load the DACs with whatever is on the data pins when it rises. (Yosys keeps
    // the initial value on iCE40 and ECP5 flip-flops; tb/dac_sched checks it at gate level.)
    initial dac_wr_n = 1'b1;

    always @(posedge clk) begin
        if (s_valid) begin  // datapath: not reset (the strobe is)
            dac_data <= s_data;
            dac_addr <= s_ch;
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            wr_go    <= 1'b0;
            wr_left  <= {WW{1'b0}};
            dac_wr_n <= 1'b1;
        end else begin
            wr_go <= s_valid;
            if (wr_go) begin
                dac_wr_n <= 1'b0;
                wr_left  <= WR_LAST;
            end else if (!dac_wr_n) begin
                if (wr_left == {WW{1'b0}})
                    dac_wr_n <= 1'b1;
                else
                    wr_left <= wr_left - 1'b1;
            end
        end
    end
endmodule

`default_nettype wire
