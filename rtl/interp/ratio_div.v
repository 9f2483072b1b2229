// SPDX-License-Identifier: Apache-2.0
// Pipelined restoring divider for the interpolator's ratio angle stage (enc_interp ANGLE = 1):
// m_quo = floor(s_num * 2**(QB-1) / s_den) for s_num <= s_den (all ones when s_den = 0), one
// quotient bit per stage, a new operand pair every clock. Model: hapgate.golden.angle.ratio_code.
// Latency: QB clocks (operands presented in cycle k, quotient valid in cycle k + QB).
`timescale 1ns / 1ps
`default_nettype none

module ratio_div #(
    parameter integer W  = 12,  // operand width (unsigned magnitudes)
    parameter integer QB = 11   // quotient bits (the first is num >= den: 1 only when num = den)
) (
    input  wire          clk,
    input  wire [W-1:0]  s_num,   // smaller magnitude (<= s_den)
    input  wire [W-1:0]  s_den,   // larger magnitude
    output wire [QB-1:0] m_quo
);
    generate
        if (W < 2 || W > 16) begin : g_bad_w
            ratio_div_W_must_be_2_to_16 u_stop ();
        end
        if (QB < 2 || QB > 16) begin : g_bad_qb
            ratio_div_QB_must_be_2_to_16 u_stop ();
        end
    endgenerate

    // stage j holds the remainder (< den), the divisor and the quotient bits so far (shifted in
    // from the right: after QB stages the register holds the whole quotient). Stage j's registers
    // live in its generate block; the flat wires carry them to stage j + 1.
    wire [W*QB-1:0]  rem;
    wire [W*QB-1:0]  den;
    wire [QB*QB-1:0] quo;

    genvar j;
    generate
        for (j = 0; j < QB; j = j + 1) begin : g_stage
            wire [W-1:0]  rem_p = (j == 0) ? s_num : rem[((j == 0) ? 0 : j - 1) * W +: W];
            wire [W-1:0]  den_p = (j == 0) ? s_den : den[((j == 0) ? 0 : j - 1) * W +: W];
            wire [QB-1:0] quo_p = (j == 0) ? {QB{1'b0}} : quo[((j == 0) ? 0 : j - 1) * QB +: QB];
            // stage 0 compares num itself (the integer bit), the others twice the remainder
            wire [W:0]    r2 = (j == 0) ? {1'b0, rem_p} : {rem_p, 1'b0};  // < 2 den <= 2**(W+1)
            wire          ge = (r2 >= {1'b0, den_p});
            wire [W:0]    rs = r2 - {1'b0, den_p};
            reg  [W-1:0]  rem_q, den_q;
            reg  [QB-1:0] quo_q;
            always @(posedge clk) begin
                rem_q <= ge ? rs[W-1:0] : r2[W-1:0];             // < den: fits W bits
                den_q <= den_p;
                quo_q <= {quo_p[QB-2:0], ge};
            end
            assign rem[j * W +: W]   = rem_q;
            assign den[j * W +: W]   = den_q;
            assign quo[j * QB +: QB] = quo_q;
            wire unused_top = &{1'b0, rs[W], quo_p[QB-1]};
        end
    endgenerate

    assign m_quo = quo[(QB - 1) * QB +: QB];
    wire unused_last = &{1'b0, rem[(QB - 1) * W +: W], den[(QB - 1) * W +: W]};
endmodule

`default_nettype wire
