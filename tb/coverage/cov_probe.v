// SPDX-License-Identifier: MIT
// A tiny design with known coverage counts for tb/coverage/test_covdat.py: a counter that
// counts while `sel` is high. Its harness drives a known number of clocks in each branch.
`timescale 1ns / 1ps
`default_nettype none
module cov_probe (
    input  wire       clk,  // clock
    input  wire       rst,  // synchronous active-high reset
    input  wire       sel,  // count enable
    output reg  [3:0] q,    // the count
    output wire [127:0] w   // the count in a wide port's low bits (above: constant 0)
);
    always @(posedge clk) begin
        if (rst)
            q <= 4'd0;
        else if (sel)
            q <= q + 4'd1;
        else
            q <= q;
    end
    assign w = {124'd0, q};
endmodule
`default_nettype wire
