// SPDX-License-Identifier: Apache-2.0
// Board-level ADC adapter for boards whose headers cannot carry 48 ADC data lines: the A and B
// converter of each axis share one 8-bit bus (three-state outputs, active-low output enables).
// In every sample period (started by the core's adc_strobe) the A converters drive the bus in
// the first half, the B converters in the second, with an idle clock between them for bus
// turnaround; each word is taken at the end of its window (the index channels with the A words,
// so they stay aligned). The core captures the previous period's words at its next strobe: one
// sample (1 / SAMPLE_HZ) of added latency, no change to the core. Timing figures and the enable/disable budget: rtl/boards/README.md.
`timescale 1ns / 1ps
`default_nettype none

module adc_pair_mux #(
    parameter integer CLK_HZ    = 12_000_000, // FPGA clock
    parameter integer SAMPLE_HZ = 1_000_000   // ADC sample rate (the core's strobe rate)
) (
    input  wire        clk,
    input  wire        rst,        // the core's reset: the first period starts with it
    input  wire        strobe,     // the core's adc_strobe: a sample period starts after it
    input  wire [23:0] pin_d,      // the three shared buses, axis 0 in the low bits
    input  wire [2:0]  pin_index,  // index channels (digital), taken with the A words
    output reg         pin_oe_a_n, // A converters drive pin_d while low
    output reg         pin_oe_b_n, // B converters drive pin_d while low
    output wire [23:0] core_a,     // words of the last complete period (stable at the strobe)
    output wire [23:0] core_b,
    output wire [2:0]  core_index  // the index delayed like the words (keeps them aligned)
);
    localparam integer DIV  = CLK_HZ / SAMPLE_HZ;    // clocks per sample period
    localparam integer HALF = DIV / 2;
    localparam integer CW   = $clog2(DIV);
    // Phase 0 is the strobe clock (and the clock after reset: the core's strobe counter starts
    // with the same reset, DIV clocks before its first strobe). A window: phases 1 .. HALF-1,
    // word taken at the end of HALF-1; turnaround at HALF; B window: HALF+1 .. DIV-1, word taken
    // at the end of DIV-1, the clock before the strobe.
    localparam integer  A_LAST_I  = HALF - 1;
    localparam integer  B_FIRST_I = HALF + 1;
    localparam integer  B_LAST_I  = DIV - 1;
    localparam [CW-1:0] ONE     = 1;
    localparam [CW-1:0] A_LAST  = A_LAST_I[CW-1:0];
    localparam [CW-1:0] B_FIRST = B_FIRST_I[CW-1:0];
    localparam [CW-1:0] B_LAST  = B_LAST_I[CW-1:0];

    generate
        if (DIV * SAMPLE_HZ != CLK_HZ || DIV < 8) begin : g_bad_rate
            adc_pair_mux_needs_CLK_HZ_a_multiple_of_SAMPLE_HZ_and_8_clocks_per_sample u_stop ();
        end
    endgenerate

    reg  [CW-1:0] phase;
    wire [CW-1:0] phase_next = strobe ? ONE : (phase == B_LAST) ? {CW{1'b0}} : phase + ONE;
    reg  [23:0]   a_q, b_q;
    reg  [2:0]    idx_q;

    always @(posedge clk) begin
        if (rst) begin
            phase      <= {CW{1'b0}};
            pin_oe_a_n <= 1'b1;
            pin_oe_b_n <= 1'b1;
        end else begin
            phase      <= phase_next;
            // registered enables: low exactly during the clocks of their window
            pin_oe_a_n <= !(phase_next >= ONE && phase_next <= A_LAST);
            pin_oe_b_n <= !(phase_next >= B_FIRST && phase_next <= B_LAST);
        end
    end

    // datapath: not reset
    always @(posedge clk) begin
        if (phase == A_LAST) begin
            a_q   <= pin_d;
            idx_q <= pin_index;
        end
        if (phase == B_LAST) b_q <= pin_d;
    end
    assign core_a     = a_q;   // B_LAST is the clock before the strobe: every word is stable
    assign core_b     = b_q;   // through the strobe clock, when the core captures them
    assign core_index = idx_q;
endmodule

`default_nettype wire
