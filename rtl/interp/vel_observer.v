// SPDX-License-Identifier: Apache-2.0
// Tracking velocity observer, one axis: a type-II loop (AD2S1210 / ODrive PLL family) on the
// interpolated position, optionally with an acceleration state (type III), one update per sample,
// gains as shifts of a bandwidth code. Bit-exact model and normative algorithm:
// models/hapgate/golden/velobs.py. Output in the window FIR's unit (counts per 2**VEL_LOG2W samples).
`timescale 1ns / 1ps
`default_nettype none

module vel_observer #(
    parameter integer VEL_LOG2W = 8          // output unit: counts per 2**VEL_LOG2W samples (2..12)
) (
    input  wire        clk,
    input  wire        rst,
    input  wire        s_valid,              // one sample: update the loop
    input  wire [31:0] s_pos,                // the interpolator's position (only bits 15:0 used)
    input  wire        s_hold,               // signal loss: hold the loop
    input  wire        s_ovs,                // a two-quadrant step on this sample: re-seed
    input  wire [3:0]  cfg_bw,               // bandwidth code s (x = 2**-s; clamped to 2..8)
    input  wire        cfg_type3,            // 1: with the acceleration state (type III)
    output wire [31:0] m_vel                 // velocity after the last update, signed, rounded
);
    localparam integer F    = 28;                 // fraction bits of P, V, A
    localparam integer PW   = 16 + F;             // P and the error: 16 integer bits, wrap
    localparam integer VW   = 9 + F + 1;          // V: -2**(9+F) .. 2**(9+F)-1 (+-512 counts/sample)
    localparam integer AW   = F + 1;              // A: -2**F .. 2**F-1 (+-1 count/sample**2)
    localparam integer SW   = PW + 2;             // sums before saturation
    localparam integer OSH  = F - VEL_LOG2W;      // output shift
    localparam integer OW   = VEL_LOG2W + 9 + 1;  // output bits (signed)
    localparam integer LOCK = 12 + F;             // |e| >= 2**LOCK: lost lock

    generate
        if (VEL_LOG2W < 2 || VEL_LOG2W > 12) begin : g_bad_vel_log2w
            vel_observer_VEL_LOG2W_must_be_2_to_12 u_stop ();
        end
    endgenerate

    localparam signed [SW-1:0] V_HI = {{(SW - VW + 1){1'b0}}, {(VW - 1){1'b1}}};
    localparam signed [SW-1:0] V_LO = {{(SW - VW + 1){1'b1}}, {(VW - 1){1'b0}}};
    localparam signed [SW-1:0] A_HI = {{(SW - AW + 1){1'b0}}, {(AW - 1){1'b1}}};
    localparam signed [SW-1:0] A_LO = {{(SW - AW + 1){1'b1}}, {(AW - 1){1'b0}}};

    reg                 first, was_held;
    reg [15:0]          pos_prev;                   // the previous sample's position (low bits)
    reg [PW-1:0]        p_q;
    reg signed [VW-1:0] v_q;
    reg signed [AW-1:0] a_q;

    // shift amounts from the clamped code
    wire [3:0] s  = (cfg_bw < 4'd2) ? 4'd2 : (cfg_bw > 4'd8) ? 4'd8 : cfg_bw;
    wire [3:0] s1 = s - 4'd1;

    wire [PW-1:0]        x_in = {s_pos[15:0], {F{1'b0}}};
    wire [PW-1:0]        e_u  = x_in - p_q;                 // wraps: the wrap-aware error
    wire signed [PW-1:0] e    = e_u;
    wire                 in_lock = (e_u[PW-1:LOCK] == {(PW - LOCK){1'b0}})
                                || (e_u[PW-1:LOCK] == {(PW - LOCK){1'b1}} && |e_u[LOCK-1:0]);
    wire                 seed = first | s_ovs | was_held | ~in_lock;
    // a seed after an overspeed step or a lost lock restarts at the last step's speed
    wire [15:0]          step = s_pos[15:0] - pos_prev;
    wire signed [SW-1:0] step_x = {{(SW - 16 - F){step[15]}}, step, {F{1'b0}}};

    // floor shifts compose exactly (floor(floor(e / 2^a) / 2^b) = floor(e / 2^(a+b))), so the
    // five shifts e >>> (s-1, s, 2s-1, 2s, 3s) are three shifters by s-1, s, s and two wires.
    // In lock |e| < 2^LOCK, so the shifters take LOCK + 1 bits.
    wire signed [LOCK:0] e_l = e[LOCK:0];
    wire signed [LOCK:0] e1  = e_l >>> s1;
    wire signed [LOCK:0] e0  = e1 >>> 1;
    wire signed [LOCK:0] e21 = e1 >>> s;
    wire signed [LOCK:0] e2  = e21 >>> 1;
    wire signed [LOCK:0] e3  = e2 >>> s;

    wire signed [SW-1:0] v_ext  = {{(SW - VW){v_q[VW-1]}}, v_q};
    wire signed [SW-1:0] a_ext  = {{(SW - AW){a_q[AW-1]}}, a_q};
    wire signed [SW-1:0] e1_x   = {{(SW - LOCK - 1){e1[LOCK]}}, e1};
    wire signed [SW-1:0] e0_x   = {{(SW - LOCK - 1){e0[LOCK]}}, e0};
    wire signed [SW-1:0] e21_x  = {{(SW - LOCK - 1){e21[LOCK]}}, e21};
    wire signed [SW-1:0] e2_x   = {{(SW - LOCK - 1){e2[LOCK]}}, e2};
    wire signed [SW-1:0] e3_x   = {{(SW - LOCK - 1){e3[LOCK]}}, e3};

    wire [SW-1:0]        p_sum  = {2'b00, p_q} + v_ext + e1_x + (cfg_type3 ? e0_x : {SW{1'b0}});
    wire signed [SW-1:0] v_sum  = cfg_type3 ? v_ext + a_ext + e21_x + e2_x : v_ext + e2_x;
    wire signed [SW-1:0] a_sum  = a_ext + e3_x;
    wire signed [SW-1:0] v_sat  = (v_sum > V_HI) ? V_HI : (v_sum < V_LO) ? V_LO : v_sum;
    wire signed [SW-1:0] a_sat  = (a_sum > A_HI) ? A_HI : (a_sum < A_LO) ? A_LO : a_sum;
    wire signed [SW-1:0] d_sat  = (step_x > V_HI) ? V_HI : (step_x < V_LO) ? V_LO : step_x;

    always @(posedge clk) begin
        if (rst) begin
            first    <= 1'b1;
            was_held <= 1'b0;
            p_q      <= {PW{1'b0}};
            pos_prev <= 16'd0;
            v_q      <= {VW{1'b0}};
            a_q      <= {AW{1'b0}};
        end else if (s_valid) begin
            pos_prev <= s_pos[15:0];
            if (s_hold) begin
                was_held <= 1'b1;
            end else if (seed) begin
                first    <= 1'b0;
                was_held <= 1'b0;
                p_q      <= x_in;
                a_q      <= {AW{1'b0}};
                if (!first && !was_held) v_q <= d_sat[VW-1:0];
            end else begin
                p_q <= p_sum[PW-1:0];
                v_q <= v_sat[VW-1:0];
                a_q <= cfg_type3 ? a_sat[AW-1:0] : {AW{1'b0}};
            end
        end
    end

    // output: V rounded to counts per 2**VEL_LOG2W samples, clamped to OW bits
    wire signed [VW:0]   v_rnd = {v_q[VW-1], v_q} + ({{VW{1'b0}}, 1'b1} <<< (OSH - 1));
    wire signed [VW:0]   v_out = v_rnd >>> OSH;
    localparam signed [VW:0] O_HI = {{(VW - OW + 2){1'b0}}, {(OW - 1){1'b1}}};
    wire signed [VW:0]   v_clp = (v_out > O_HI) ? O_HI : v_out;
    assign m_vel = {{(32 - OW){v_clp[OW-1]}}, v_clp[OW-1:0]};
    wire unused_hi = &{1'b0, s_pos[31:16], e[PW-1:LOCK+1], p_sum[SW-1:PW], v_sat[SW-1:VW],
                       a_sat[SW-1:AW], v_clp[VW:OW], d_sat[SW-1:VW]};
endmodule

`default_nettype wire
