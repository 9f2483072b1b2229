// SPDX-License-Identifier: Apache-2.0
// Simulation only: dac_sched's idle-clock skip hook for the native commutation harness
// (tb/native/commutation/), instantiated inside dac_sched by `HG_SIM_SKIP_HOOK
// (rtl/include/hg_sim.vh) when HG_SIM_SKIP is defined; absent from synthesis and every other
// simulation. Before a rising edge the harness may write skip = N with 1 <= N <= room; that
// edge then advances dac_sched's frame and slot counters by 1 + N, exactly as 1 + N ordinary
// edges would. room is 0 unless the scheduler is idle: every request answered (pending = 0,
// s_valid low), no strobe pending or low, no request and no frame start in this clock; and it
// ends the 1 + N edges at the latest in the slot's last clock and before the frame's last, so
// no slot wrap, request, frame start or DAC port change can fall in the skipped clocks (the
// slot wrap needs no skip term). Never written, skip stays 0 and dac_sched behaves as the
// synthesized one.
`timescale 1ns / 1ps
`default_nettype none

module dac_sched_skip #(
    parameter integer FW           = 16,  // dac_sched's frame counter width
    parameter integer SW           = 8,   // ... its slot counter width
    parameter integer CW           = 3,   // ... its slot number width
    parameter integer SKEW_CYCLES  = 96,  // clocks per slot
    parameter integer FRAME_CYCLES = 768, // clocks per frame
    parameter integer CHANNELS     = 6    // slots per frame
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          m_req,      // dac_sched's request, answer, strobe and counters
    input  wire          s_valid,
    input  wire          wr_go,
    input  wire          dac_wr_n,
    input  wire          m_frame,
    input  wire [SW-1:0] slot_cnt,
    input  wire [FW-1:0] frame_cnt,
    output wire [FW-1:0] skip        // extra clocks of the next edge (the harness writes it)
);
    reg  [FW-1:0] sim_skip /*verilator public_flat_rw*/;  // extra clocks of the next edge
    reg  [CW:0]   sim_pending;                             // requests not yet answered by s_valid
    localparam integer SKEW_ROOM_I  = SKEW_CYCLES - 2;
    localparam integer FRAME_ROOM_I = FRAME_CYCLES - 2;
    localparam [FW-1:0] SKEW_ROOM   = SKEW_ROOM_I[FW-1:0];
    localparam [FW-1:0] FRAME_ROOM  = FRAME_ROOM_I[FW-1:0];
    wire          sim_idle   = sim_pending == {(CW+1){1'b0}} && !s_valid && !wr_go && dac_wr_n
                               && !m_req && !m_frame;
    wire [FW-1:0] sim_slot   = {{(FW-SW){1'b0}}, slot_cnt};
    wire [FW-1:0] room_slot  = (sim_slot < SKEW_ROOM) ? SKEW_ROOM - sim_slot : {FW{1'b0}};
    wire [FW-1:0] room_frame = (frame_cnt < FRAME_ROOM) ? FRAME_ROOM - frame_cnt : {FW{1'b0}};
    wire [FW-1:0] sim_room /*verilator public_flat_rd*/ =
        !sim_idle ? {FW{1'b0}} : ((room_slot < room_frame) ? room_slot : room_frame);
    generate
        if (CHANNELS < 2) begin : g_sim_channels  // (so that the slot counter is narrower)
            dac_sched_skip_needs_CHANNELS_of_at_least_2 u_stop ();
        end
    endgenerate
    initial sim_skip = {FW{1'b0}};
    always @(posedge clk) begin
        if (rst)
            sim_pending <= {(CW+1){1'b0}};
        else
            sim_pending <= sim_pending + {{CW{1'b0}}, m_req} - {{CW{1'b0}}, s_valid};
    end
    assign skip = sim_skip;
endmodule

`default_nettype wire
