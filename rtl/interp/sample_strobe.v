// SPDX-License-Identifier: Apache-2.0
// ADC sample strobe: one clock high every CLK_HZ / SAMPLE_HZ clocks (every clock when they are
// equal, the lowest clock the interpolator supports). The ADC word is captured at the end of the
// cycle in which `strobe` is high.
`timescale 1ns / 1ps
`default_nettype none

module sample_strobe #(
    parameter integer CLK_HZ    = 48_000_000,  // FPGA clock
    parameter integer SAMPLE_HZ = 1_000_000    // ADC sample rate; CLK_HZ must be a multiple
) (
    input  wire clk,
    input  wire rst,
    output reg  strobe
);
    localparam integer DIV = CLK_HZ / SAMPLE_HZ;
    localparam integer CW  = (DIV > 1) ? $clog2(DIV) : 1;
    localparam integer  LAST_I = DIV - 1;
    localparam [CW-1:0] LAST   = LAST_I[CW-1:0];

    generate
        if (SAMPLE_HZ < 1 || CLK_HZ < SAMPLE_HZ || DIV * SAMPLE_HZ != CLK_HZ) begin : g_bad_rate
            sample_strobe_CLK_HZ_must_be_a_multiple_of_SAMPLE_HZ u_stop ();
        end
    endgenerate

    reg [CW-1:0] cnt;

    always @(posedge clk) begin
        if (rst) begin
            cnt    <= {CW{1'b0}};
            strobe <= 1'b0;
        end else begin
            cnt    <= (cnt == LAST) ? {CW{1'b0}} : cnt + 1'b1;
            strobe <= (cnt == LAST);
        end
    end
endmodule

`default_nettype wire
