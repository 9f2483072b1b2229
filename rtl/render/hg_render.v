// SPDX-License-Identifier: Apache-2.0
// Local contact rendering at the commutation frame rate (issue 37): at every frame strobe, from
// the three joints' positions and velocities, one linearised wall (joint space) and a diagonal
// joint spring, from a model the firmware loads at its servo rate with a time-to-live in frames;
// the result is added to the firmware's torque under the per-axis TQ_LIMIT clamp. The law, the
// formats and the timing: rtl/render/README.md; bit-exact model: models/hapgate/golden/render.py.
`timescale 1ns / 1ps
`default_nettype none

module hg_render #(
    parameter integer CLK_HZ    = 48_000_000, // FPGA clock (a frame must hold LATENCY clocks)
    parameter integer FRAME_NS  = 16000,      // commutation frame: s_frame at most once per frame
    parameter integer MUL_DIGIT = 18,         // data bits multiplied per clock: 18 one product a
                                              // clock (a DSP block); 1, 2, 3, 6, 9 shift-add (LUTs)
    parameter integer TTL_BITS  = 16          // time-to-live width: a model renders < 2**TTL_BITS frames
) (
    input  wire                clk,
    input  wire                rst,
    // the frame: positions and velocities sampled at the end of the clock with s_frame high
    input  wire                s_frame,
    input  wire [95:0]         s_pos,         // POS_HOMED per axis (axis 0 low), counts, 2^20/rev
    input  wire [95:0]         s_vel,         // VEL per axis, counts per 2^VEL_LOG2W samples
    // the model: 16 words written into the shadow bank, committed by ctl_load
    input  wire                cfg_we,
    input  wire [3:0]          cfg_addr,
    input  wire [31:0]         cfg_wdata,
    input  wire                ctl_load,      // commit the shadow bank at the next s_frame (or this one)
    input  wire [TTL_BITS-1:0] ctl_ttl,       // frames the committed model renders (read with ctl_load)
    input  wire                ctl_zero,      // fault path: m_torque zero in this clock, model dropped
    // the firmware's torque and the per-axis clamp
    input  wire [47:0]         s_torque,      // signed 16 per axis, torque code
    input  wire [47:0]         ctl_tq_limit,  // unsigned 16 per axis: |torque| <= min(limit, 32768)
    output wire [47:0]         m_torque,      // clamp(s_torque + m_render), signed 16 per axis
    output wire [50:0]         m_render,      // the rendered torque, signed 17 per axis
    output reg                 m_valid,       // m_render shows a frame's result from this clock
    output wire                m_live,        // a model is rendering
    output wire                m_pending      // a committed model waits for its frame strobe
);
    // ---------------------------------------------------------------- formats
    localparam integer XW    = 18;              // data operand: e, v, F (signed integers, symmetric)
    localparam integer CW    = 24;              // coefficient: signed, FRAC fraction bits
    localparam integer FRAC  = 12;
    localparam integer PW    = CW + XW;         // product
    localparam integer AW    = 44;              // accumulator: F0 + six products < 2^43
    localparam integer RW    = 17;              // rendered torque, +-65535
    localparam integer NDIG  = XW / MUL_DIGIT;  // multiply clocks per product
    localparam integer STEP_CLOCKS  = NDIG + 3; // read p0 / read coefficient, digits, accumulate
    localparam integer LATENCY      = 3 + 12 * STEP_CLOCKS;   // s_frame clock to m_valid clock
    localparam integer FRAME_CLOCKS = CLK_HZ / 1000 * FRAME_NS / 1_000_000;

    // model words (one bank): the linear forms' coefficients, the reference pose, the force offset
    localparam [3:0] W_A = 4'd0, W_C = 4'd3, W_G = 4'd6, W_S = 4'd9, W_P0 = 4'd12, W_F0 = 4'd15;
    // the phases of a step; digits are phases 2 .. NDIG+1
    localparam integer PH_ACC_I = NDIG + 2;
    localparam [4:0] PH_X = 5'd0, PH_C = 5'd1, PH_MUL0 = 5'd2, PH_ACC = PH_ACC_I[4:0];
    localparam [3:0] LAST_STEP = 4'd12;
    localparam signed [AW-1:0] HALF = 44'sd2048;           // 2^(FRAC-1): round half up
    localparam [XW-1:0] F_MAX = 18'h1FFFF;                // the force saturates at 2^17 - 1

    // Elaboration-time checks: a bad configuration instantiates a module that does not exist,
    // whose name is the message.
    generate
        if (MUL_DIGIT < 1 || MUL_DIGIT > XW || XW % MUL_DIGIT != 0) begin : g_bad_digit
            hg_render_MUL_DIGIT_must_divide_18 u_stop ();
        end
        if (CLK_HZ < 1000 || CLK_HZ > 134_000_000) begin : g_bad_clk
            hg_render_CLK_HZ_must_be_1kHz_to_134MHz u_stop ();
        end
        if (LATENCY > FRAME_CLOCKS) begin : g_bad_frame
            hg_render_LATENCY_must_fit_in_one_frame u_stop ();
        end
        if (TTL_BITS < 1 || TTL_BITS > 24) begin : g_bad_ttl
            hg_render_TTL_BITS_must_be_1_to_24 u_stop ();
        end
    endgenerate

    // clamp a signed 32-bit value to the symmetric data range +-(2^17 - 1)
    function [XW-1:0] sat_x;
        input [31:0] v;
        begin
            if (!v[31] && v[30:17] != 14'd0)
                sat_x = 18'h1FFFF;
            else if (v[31] && (v[30:17] != 14'h3FFF || v[16:0] == 17'd0))
                sat_x = 18'h20001;
            else
                sat_x = v[XW-1:0];
        end
    endfunction

    // ---------------------------------------------------------------- control
    reg                 live_q, pending_q, busy_q, bank_q;
    reg  [TTL_BITS-1:0] ttl_q, left_q;
    reg  [3:0]          step_q;
    reg  [4:0]          ph_q;

    // At a frame strobe a waiting (or this clock's) load is taken; the model then renders TTL
    // frames, the taking one first; the strobe after its last frame expires it.
    wire                take     = pending_q | ctl_load;
    wire [TTL_BITS-1:0] ttl_now  = ctl_load ? ctl_ttl : ttl_q;
    wire [TTL_BITS-1:0] left_now = take ? ttl_now : (live_q ? left_q : {TTL_BITS{1'b0}});
    wire                render   = left_now != {TTL_BITS{1'b0}};
    wire                step_end = busy_q && ph_q == PH_ACC;
    wire                seq_done = step_end && step_q == LAST_STEP;

    always @(posedge clk) begin
        if (rst || ctl_zero) begin
            live_q    <= 1'b0;
            pending_q <= 1'b0;
            busy_q    <= 1'b0;
            m_valid   <= 1'b0;
            if (rst)
                bank_q <= 1'b0;
        end else begin
            m_valid <= seq_done && !s_frame;
            if (ctl_load) begin
                pending_q <= 1'b1;
                ttl_q     <= ctl_ttl;
            end
            if (s_frame) begin                       // (restarts a computation in progress)
                if (take) begin
                    bank_q    <= ~bank_q;
                    pending_q <= 1'b0;
                end
                live_q <= render;
                left_q <= left_now - {{(TTL_BITS-1){1'b0}}, render};
                busy_q <= render;
                step_q <= 4'd0;
                ph_q   <= PH_X;
            end else if (busy_q) begin
                if (step_q == 4'd0 && ph_q == PH_C) begin  // step 0 only loads F0
                    step_q <= 4'd1;
                    ph_q   <= PH_X;
                end else if (step_end) begin
                    step_q <= step_q + 4'd1;
                    ph_q   <= PH_X;
                    if (seq_done)
                        busy_q <= 1'b0;
                end else begin
                    ph_q <= ph_q + 5'd1;
                end
            end
        end
    end
    assign m_live    = live_q;
    assign m_pending = pending_q;

    // ---------------------------------------------------------------- the steps
    //  step  data x       coefficient   accumulator              after it
    //   0    -            F0 (32-bit)   acc  = F0
    //   1-3  e_i          A_i           acc += A_i e_i           gate = acc > 0 (after 3)
    //   4-6  v_i          C_i           acc += C_i v_i           F = gate & acc >= 0 ? sat(acc >> 12) : 0
    //   7    F            G_0           acc  = 2^11 + G_0 F
    //   8    e_0          S_0           acc += S_0 e_0           r_0 = sat(acc >> 12)
    //   9-12 the same for axes 1 and 2; r_0..r_2 shown together after step 12
    // e_i = sat(p_i - p0_i) is formed from the latched position and the word p0_i each time.
    reg  [1:0] ax;                 // axis of the step
    reg  [3:0] cw;                 // coefficient word
    reg        use_e, use_v, half;
    always @(*) begin
        ax    = 2'd0;
        cw    = W_F0;
        use_e = 1'b0;
        use_v = 1'b0;
        half  = 1'b0;
        case (step_q)
            4'd1, 4'd2, 4'd3: begin
                ax    = step_q[1:0] - 2'd1;
                cw    = W_A + {2'd0, ax};
                use_e = 1'b1;
            end
            4'd4, 4'd5, 4'd6: begin
                ax    = step_q[1:0];               // 4, 5, 6 -> 0, 1, 2
                cw    = W_C + {2'd0, ax};
                use_v = 1'b1;
            end
            4'd7, 4'd9, 4'd11: begin
                ax    = step_q[2:1] - 2'd3;        // 7, 9, 11 -> 0, 1, 2
                cw    = W_G + {2'd0, ax};
                half  = 1'b1;
            end
            4'd8, 4'd10, 4'd12: begin
                ax    = step_q[2:1];               // 8, 10, 12 -> 0, 1, 2 (mod 4)
                cw    = W_S + {2'd0, ax};
                use_e = 1'b1;
            end
            default: ;
        endcase
    end
    wire [3:0] xw = (step_q == 4'd0) ? W_F0 : W_P0 + {2'd0, ax};

    // ---------------------------------------------------------------- model memory: two banks
    // Written into the shadow bank (~bank_q), read from the active one. Synchronous read: the
    // word addressed in one clock is in rdata the next; the coefficient's address is held through
    // the digits, so rdata is the coefficient for the whole multiply.
    reg  [31:0] mem [0:31];
    reg  [31:0] rdata;
    wire [4:0]  raddr = {bank_q, (ph_q == PH_X) ? xw : cw};
    always @(posedge clk) begin
        if (cfg_we)
            mem[{~bank_q, cfg_addr}] <= cfg_wdata;
        rdata <= mem[raddr];
    end

    // ---------------------------------------------------------------- datapath
    reg  [95:0]           pos_q;         // positions latched at the strobe
    reg  [95:0]           vel_q;         // velocities latched at the strobe
    reg  [XW-1:0]         x_q;           // the data operand (shifted out MSB first)
    reg  signed [PW-1:0]  p_q;           // the product
    reg  signed [AW-1:0]  acc_q;
    reg                   gate_q;        // the spring part of the wall force is positive
    reg  [XW-1:0]         f_q;           // the wall force F >= 0
    reg  [2*RW-1:0]       r_stage;       // r_0, r_1 until r_2 is done
    reg  [3*RW-1:0]       r_q;

    // one subtractor and one saturation for both: e_i = sat(p_i - p0_i), v_i = sat(vel_i - 0)
    wire [31:0]    src    = use_e ? pos_q[32*ax +: 32] : vel_q[32*ax +: 32];
    wire [XW-1:0]  ev_ax  = sat_x(src - (use_e ? rdata : 32'd0));
    wire [XW-1:0]  x_next = (use_e | use_v) ? ev_ax : f_q;
    wire signed [CW-1:0] coef = rdata[CW-1:0];
    wire signed [PW-1:0] p_next;

    generate
        if (NDIG == 1) begin : g_par                // one product per clock (a DSP block)
            assign p_next = coef * $signed(x_q);
        end else begin : g_ser                      // Horner over MUL_DIGIT-bit digits, MSB first
            wire                     first = ph_q == PH_MUL0;
            wire [MUL_DIGIT-1:0]     dig   = x_q[XW-1 -: MUL_DIGIT];
            wire signed [MUL_DIGIT:0] dig_s = {first & dig[MUL_DIGIT-1], dig}; // top digit signed
            wire signed [CW+MUL_DIGIT:0] pp = coef * dig_s;
            wire signed [PW-1:0]     p_prev = first ? {PW{1'b0}} : p_q;
            assign p_next = (p_prev <<< MUL_DIGIT) + {{(PW-CW-MUL_DIGIT-1){pp[CW+MUL_DIGIT]}}, pp};
        end
    endgenerate

    wire signed [AW-1:0] acc_new = (half ? HALF : acc_q) + {{(AW-PW){p_q[PW-1]}}, p_q};
    wire [AW-FRAC-1:0]   acc_int = acc_new[AW-1:FRAC];          // floor(acc / 2^12)
    // the force: floor, saturated to 2^17 - 1; the torque: saturated to +-65535
    wire [XW-1:0] f_sat = (acc_int[AW-FRAC-1:XW-1] != {(AW-FRAC-XW+1){1'b0}}) ? F_MAX
                                                                               : acc_int[XW-1:0];
    wire          r_pos_over = !acc_int[AW-FRAC-1] && acc_int[AW-FRAC-2:RW-1] != {(AW-FRAC-RW){1'b0}};
    wire          r_neg_over = acc_int[AW-FRAC-1] && (acc_int[AW-FRAC-2:RW-1] != {(AW-FRAC-RW){1'b1}}
                                                       || acc_int[RW-2:0] == {(RW-1){1'b0}});
    wire [RW-1:0] r_sat = r_pos_over ? 17'h0FFFF : (r_neg_over ? 17'h10001 : acc_int[RW-1:0]);

    always @(posedge clk) begin
        if (s_frame) begin
            pos_q <= s_pos;
            vel_q <= s_vel;
        end
        if (busy_q) begin
            if (ph_q == PH_C) begin
                x_q <= x_next;
                if (step_q == 4'd0)
                    acc_q <= {{(AW-32){rdata[31]}}, rdata};      // F0
            end else if (ph_q != PH_X && ph_q != PH_ACC) begin
                p_q <= p_next;
                x_q <= x_q << MUL_DIGIT;
            end
            if (step_end) begin
                acc_q <= acc_new;
                if (step_q == 4'd3)
                    gate_q <= !acc_new[AW-1] && acc_new != {AW{1'b0}};
                if (step_q == 4'd6)
                    f_q <= (gate_q && !acc_new[AW-1]) ? f_sat : {XW{1'b0}};
                if (step_q == 4'd8)
                    r_stage[0 +: RW] <= r_sat;
                if (step_q == 4'd10)
                    r_stage[RW +: RW] <= r_sat;
            end
        end
    end

    // The rendered torque: cleared at reset, by ctl_zero (so from the clock after it rises) and
    // when the model expires; written after the last step (a strobe in that clock restarts).
    always @(posedge clk) begin
        if (rst || ctl_zero || (s_frame && !render))
            r_q <= {3*RW{1'b0}};
        else if (seq_done && !s_frame)
            r_q <= {r_sat, r_stage};
    end
    assign m_render = r_q;

    // ---------------------------------------------------------------- the sum and the clamp
    // Per axis: s_torque + m_render, clamped to [-L, min(L, 32767)] with L = min(limit, 32768):
    // the commutator's clamp (rtl/commutation/commutator.v), which this output then passes.
    genvar i;
    generate
        for (i = 0; i < 3; i = i + 1) begin : g_clamp
            wire [15:0]        lim  = ctl_tq_limit[16*i +: 16];
            wire signed [17:0] sum  = {{2{s_torque[16*i+15]}}, s_torque[16*i +: 16]}
                                    + {r_q[RW*i+RW-1], r_q[RW*i +: RW]};
            wire signed [17:0] hi   = lim[15] ? 18'sd32767 : {2'b00, lim};
            wire signed [17:0] lo   = lim[15] ? -18'sd32768 : -{2'b00, lim};
            wire signed [17:0] out  = (sum > hi) ? hi : ((sum < lo) ? lo : sum);
            wire unused_out = &{1'b0, out[17:16]};
            assign m_torque[16*i +: 16] = ctl_zero ? 16'd0 : out[15:0];
        end
    endgenerate
endmodule

`default_nettype wire
