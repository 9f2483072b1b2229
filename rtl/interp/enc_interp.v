// SPDX-License-Identifier: Apache-2.0
// Sin/cos encoder interpolator, one axis: sign-bit quadrant + arcsine LUT on the smaller channel
// (the paper's method), 32-bit position, index latch and homing, window-difference velocity,
// sticky faults. Bit-exact model and full description: models/hapgate/golden/interp.py.
// Latency: 5 clocks from the cycle with s_valid high to the cycle with m_valid high, + 1 with CAL = 1
// (the online calibration stage enc_calib.v between capture and angle, models/hapgate/golden/enccal.py),
// + ANGLE_REG, + RATIO_BITS + 1 with ANGLE = 1 (the ratio divider ratio_div.v; golden/angle.py),
// + HARM (the harmonic correction table lookup).
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module enc_interp #(
    parameter integer LUT_BITS     = 7,         // arcsine LUT codes per 45 deg = 2**LUT_BITS (5..9)
    parameter         LUT_FILE     = "asin.hex", // $readmemh file, 129 entries (models/hapgate/golden/interp.py)
    parameter integer VEL_LOG2W    = 8,         // velocity window W = 2**VEL_LOG2W samples (2..12)
    parameter integer AMP_MIN      = 40,        // signal-loss window on sqrt(a^2+b^2), ADC codes
    parameter integer AMP_MAX      = 170,
    parameter integer LOSS_SAMPLES = 16,        // consecutive out-of-window samples -> signal loss
    parameter integer INVERT       = 0,         // 1: count the other way (A and B swapped at capture)
    parameter integer CAL          = 0,         // 1: build the online calibration stage (enc_calib)
    parameter         CAL_LUT_FILE = "asin512.hex", // CAL = 1: 512-entry table (enccal.cal_table)
    parameter integer CAL_LINES_LOG2 = 3,       // CAL = 1: calibration block 2**N lines
    parameter integer CAL_NLOG     = 14,        // CAL = 1: blocks of 2**N samples or more ignored
    parameter integer COARSE       = 0,         // 1: plain quadrature, the fine angle zeroed (4 steps/line)
    // fit options (bit-identical results; rtl/boards/README.md "Fit"):
    parameter integer SQ_RAM       = 0,         // 1: the signal-loss squares a*a, b*b from a block-RAM table
    parameter integer HOLD_C       = 0,         // 1: stage E takes stage C's held registers (no stage-D
                                                //    copies); needs s_valid never high two clocks in a row
    parameter integer ANGLE        = 0,         // fine angle: 0 arcsine of the smaller channel (paper),
                                                // 1 ratio table atan(smaller / larger), pipelined divider
    parameter integer RATIO_BITS   = 10,        // ANGLE = 1: ratio table 2**RATIO_BITS entries (6..12)
    parameter         RATIO_FILE   = "atan.hex", // ANGLE = 1: $readmemh table (golden.angle.ratio_table)
    parameter integer ANGLE_REG    = 0,         // 1: a register after abs/compare/select (latency + 1)
    parameter integer HARM         = 0,         // 1 (needs ANGLE = 1): harmonic correction table
                                                // (latency + 1); RATIO_FILE then has 2 more bits
    parameter integer HARM_LOG2    = 6,         // HARM = 1: 2**HARM_LOG2 entries per line (4..8)
    parameter integer VEL_OBS      = 0          // 1: build the tracking velocity observer (vel_observer)
) (
    input  wire        clk,
    input  wire        rst,
    // ADC sample (two's complement), captured when s_valid is high
    input  wire        s_valid,
    input  wire [7:0]  s_a,
    input  wire [7:0]  s_b,
    input  wire        s_index,
    // control pulses: apply to the first sample captured at or after the pulse
    input  wire        ctl_fault_clear,
    input  wire        ctl_home_arm,
    // calibration controls (CAL = 1; levels captured with each sample, mu read at an update)
    input  wire        ctl_cal_en,
    input  wire        ctl_cal_freeze,
    input  wire [3:0]  cfg_cal_mu,
    // harmonic correction (HARM = 1): enable level captured with each sample; table write port
    // (signed entries in 1/4 count, a write applies to samples whose lookup comes after it);
    // read-back of entry cfg_harm_addr in clocks without a sample in the lookup stage
    input  wire        ctl_harm_en,
    input  wire        cfg_harm_we,
    input  wire [7:0]  cfg_harm_addr,
    input  wire [7:0]  cfg_harm_data,
    output wire [7:0]  m_harm_rdata,
    // velocity observer settings (VEL_OBS = 1): levels read at each sample's observer update,
    // LATENCY - 2 clocks after its capture
    input  wire [3:0]  cfg_obs_bw,        // bandwidth code s: x = 2**-s (2..8)
    input  wire        cfg_obs_type3,     // 1: with the acceleration state
    // results, one per sample
    output reg         m_valid,
    output reg  [31:0] m_pos,             // position, counts (2**(LUT_BITS+3) per line), wraps
    output reg  [31:0] m_pos_homed,       // m_pos - home (home = 0 until homed)
    output reg  [31:0] m_vel,             // pos[n] - pos[n-W], counts per W samples (0 while n < W)
    output reg  [31:0] m_vel_obs,         // the observer's velocity, same unit (0 with VEL_OBS = 0)
    output reg  [31:0] m_index_pos,       // start of the quadrant latched at the last index edge
    output reg  [15:0] m_index_count,     // index rising edges seen (wraps)
    output reg  [15:0] m_overspeed_count, // two-quadrant steps seen (saturates)
    output reg         m_homed,
    output reg  [2:0]  m_faults,          // sticky: {loss, clip, overspeed}
    output wire        m_fault,           // any fault: the commutator zeroes this axis's torque
    // calibration state (live; the identity constants with CAL = 0). In the cycle m_cal_valid
    // is high it is the state after sample k, the samples in the order of m_valid's results.
    output wire        m_cal_valid,
    output wire [15:0] m_cal_ofs_a,       // signed, 1/16 LSB
    output wire [15:0] m_cal_ofs_b,
    output wire [15:0] m_cal_gain_a,      // 2^-14
    output wire [15:0] m_cal_gain_b,
    output wire [15:0] m_cal_phase,       // signed, 2^-14
    output wire [7:0]  m_cal_gear,        // valid blocks since enable (saturating)
    output wire [15:0] m_cal_updates      // valid blocks since reset (wrapping)
    `HG_SIM_PORTS(4)  // simulation only (rtl/include/hg_sim.vh): stage clocks {D+E, C, B, A}
);
    localparam integer FB   = LUT_BITS + 1;             // fine bits per quadrant
    localparam integer QCW  = 32 - FB;                  // quadrant counter width
    localparam integer DW   = LUT_BITS + VEL_LOG2W + 4; // stored velocity bits (see model)
    localparam integer W    = 1 << VEL_LOG2W;
    localparam integer RUNW = $clog2(LOSS_SAMPLES + 1);
    localparam integer AMP2_MIN_I = AMP_MIN * AMP_MIN;
    localparam integer AMP2_MAX_I = AMP_MAX * AMP_MAX;
    localparam [16:0]     AMP2_MIN = AMP2_MIN_I[16:0];
    localparam [16:0]     AMP2_MAX = AMP2_MAX_I[16:0];
    localparam [RUNW-1:0] LOSS_N   = LOSS_SAMPLES[RUNW-1:0];
    localparam [QCW-1:0]  QC_TWO   = {{(QCW - 2){1'b0}}, 2'd2};

    // The stages' clocks: clk (rtl/include/hg_sim.vh: the virtual device's stage clocks)
    wire clk_a  = `HG_SIM_CLK(clk, 0);
    wire clk_b  = `HG_SIM_CLK(clk, 1);
    wire clk_c  = `HG_SIM_CLK(clk, 2);
    wire clk_de = `HG_SIM_CLK(clk, 3);

    // Elaboration-time checks: a bad configuration instantiates a module that does not exist,
    // whose name is the message.
    generate
        if (LUT_BITS < 2 || LUT_BITS > 10) begin : g_bad_lut_bits
            enc_interp_LUT_BITS_must_be_2_to_10 u_stop ();
        end
        if (VEL_LOG2W < 2 || VEL_LOG2W > 12 || DW > 32) begin : g_bad_vel_log2w
            enc_interp_VEL_LOG2W_must_be_2_to_12 u_stop ();
        end
        if (AMP_MIN < 0 || AMP_MAX > 182 || AMP_MIN >= AMP_MAX) begin : g_bad_amp
            enc_interp_needs_0_le_AMP_MIN_lt_AMP_MAX_le_182 u_stop ();
        end
        if (LOSS_SAMPLES < 1 || LOSS_SAMPLES > 65535) begin : g_bad_loss
            enc_interp_LOSS_SAMPLES_must_be_1_to_65535 u_stop ();
        end
        if (INVERT != 0 && INVERT != 1) begin : g_bad_invert
            enc_interp_INVERT_must_be_0_or_1 u_stop ();
        end
        if (CAL != 0 && CAL != 1) begin : g_bad_cal
            enc_interp_CAL_must_be_0_or_1 u_stop ();
        end
        if (CAL != 0 && ANGLE == 0 && LUT_BITS > 8) begin : g_bad_cal_lut
            enc_interp_CAL_with_ANGLE_0_needs_LUT_BITS_at_most_8 u_stop ();
        end
        if (ANGLE != 0 && ANGLE != 1) begin : g_bad_angle
            enc_interp_ANGLE_must_be_0_or_1 u_stop ();
        end
        if (ANGLE_REG != 0 && ANGLE_REG != 1) begin : g_bad_angle_reg
            enc_interp_ANGLE_REG_must_be_0_or_1 u_stop ();
        end
        if (ANGLE != 0 && (RATIO_BITS < 6 || RATIO_BITS > 12)) begin : g_bad_ratio_bits
            enc_interp_RATIO_BITS_must_be_6_to_12 u_stop ();
        end
        if ((HARM != 0 && HARM != 1) || (HARM != 0 && ANGLE == 0)) begin : g_bad_harm
            enc_interp_HARM_must_be_0_or_1_and_needs_ANGLE_1 u_stop ();
        end
        if (HARM != 0 && (HARM_LOG2 < 4 || HARM_LOG2 > 8)) begin : g_bad_harm_log2
            enc_interp_HARM_LOG2_must_be_4_to_8 u_stop ();
        end
        if ((SQ_RAM != 0 && SQ_RAM != 1) || (HOLD_C != 0 && HOLD_C != 1)) begin : g_bad_fit
            enc_interp_SQ_RAM_and_HOLD_C_must_be_0_or_1 u_stop ();
        end
        if (VEL_OBS != 0 && VEL_OBS != 1) begin : g_bad_vel_obs
            enc_interp_VEL_OBS_must_be_0_or_1 u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- stage A: capture
    reg       va;
    reg [7:0] a_a, b_a;
    reg       idx_a, clr_a, arm_a;
    reg       clr_pend, arm_pend_ctl;
    reg       cal_en_a, cal_fr_a, hen_a;

    always @(posedge clk_a) begin
        if (s_valid) begin
            hen_a    <= ctl_harm_en;
            cal_en_a <= ctl_cal_en;
            cal_fr_a <= ctl_cal_freeze;
            // INVERT: A' = B, B' = A is the angle 90deg - phi: the count runs the other way and
            // quadrant 0 (the index quadrant) maps onto itself.
            a_a   <= (INVERT != 0) ? s_b : s_a;
            b_a   <= (INVERT != 0) ? s_a : s_b;
            idx_a <= s_index;
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            va           <= 1'b0;
            clr_a        <= 1'b0;
            arm_a        <= 1'b0;
            clr_pend     <= 1'b0;
            arm_pend_ctl <= 1'b0;
        end else begin
            va <= s_valid;
            if (s_valid) begin
                clr_a        <= clr_pend | ctl_fault_clear;
                arm_a        <= arm_pend_ctl | ctl_home_arm;
                clr_pend     <= 1'b0;
                arm_pend_ctl <= 1'b0;
            end else begin
                clr_pend     <= clr_pend | ctl_fault_clear;
                arm_pend_ctl <= arm_pend_ctl | ctl_home_arm;
            end
        end
    end

    // ---------------------------------------------------------------- stage K: calibration (CAL = 1)
    // The angle stage sees channels of AW bits: the raw codes, or the corrected quarter-LSB ones.
    localparam integer AW    = (CAL != 0) ? 12 : 8;
    localparam integer LUT_N = (CAL != 0) ? 512 : 129;
    wire          v_in;                 // stage B input: valid, channels, index, pulses, faults
    wire [AW-1:0] a_in, b_in;
    wire          idx_in, clr_in, arm_in, clip_in, bad_in, hen_in;

    generate
        if (CAL != 0) begin : g_cal
            wire        vk, clip_k, bad_k;
            wire [11:0] ac_k, bc_k;
            reg         idx_k, clr_k, arm_k, hen_k;
            enc_calib #(
                .LINES_LOG2(CAL_LINES_LOG2), .NLOG(CAL_NLOG), .AMP_MIN(AMP_MIN), .AMP_MAX(AMP_MAX)
            ) u_cal (
                .clk(clk), .rst(rst), .s_valid(va), .s_a(a_a), .s_b(b_a),
                .ctl_en(cal_en_a), .ctl_freeze(cal_fr_a), .cfg_mu(cfg_cal_mu),
                .m_valid(vk), .m_a(ac_k), .m_b(bc_k), .m_clip(clip_k), .m_bad(bad_k),
                .m_ofs_a(m_cal_ofs_a), .m_ofs_b(m_cal_ofs_b), .m_gain_a(m_cal_gain_a),
                .m_gain_b(m_cal_gain_b), .m_phase(m_cal_phase), .m_gear(m_cal_gear),
                .m_updates(m_cal_updates)
            );
            always @(posedge clk) begin
                if (va) begin
                    idx_k <= idx_a;
                    hen_k <= hen_a;
                end
            end
            always @(posedge clk) begin
                if (rst) begin
                    clr_k <= 1'b0;
                    arm_k <= 1'b0;
                end else begin
                    clr_k <= va & clr_a;
                    arm_k <= va & arm_a;
                end
            end
            assign v_in    = vk;
            assign m_cal_valid = vk;
            assign a_in    = ac_k;
            assign b_in    = bc_k;
            assign idx_in  = idx_k;
            assign hen_in  = hen_k;
            assign clr_in  = clr_k;
            assign arm_in  = arm_k;
            assign clip_in = clip_k;
            assign bad_in  = bad_k;
        end else begin : g_nocal
            wire [15:0] a_sq, b_sq;
            if (SQ_RAM != 0) begin : g_sq_ram
                // a block-RAM table of squares, read with the capture (address = the code
                // captured into a_a / b_a): the same squares in the same clock as the product
                reg [14:0] sq_tab [0:255];
                reg [14:0] a_sq_q, b_sq_q;
                integer    t;
                reg [7:0]  m;
                initial begin
                    for (t = 0; t < 256; t = t + 1) begin
                        m         = (t < 128) ? t[7:0] : 8'd0 - t[7:0];  // |code|, two's complement
                        sq_tab[t] = {7'd0, m} * {7'd0, m};            // <= 128 * 128: 15 bits
                    end
                end
                always @(posedge clk_a) begin
                    if (s_valid) begin
                        a_sq_q <= sq_tab[(INVERT != 0) ? s_b : s_a];
                        b_sq_q <= sq_tab[(INVERT != 0) ? s_a : s_b];
                    end
                end
                assign a_sq = {1'b0, a_sq_q};
                assign b_sq = {1'b0, b_sq_q};
            end else begin : g_sq_mul
                assign a_sq = $signed(a_a) * $signed(a_a);
                assign b_sq = $signed(b_a) * $signed(b_a);
            end
            wire        [16:0] amp2 = {1'b0, a_sq} + {1'b0, b_sq};
            assign v_in    = va;
            assign m_cal_valid = va;
            assign a_in    = a_a;
            assign b_in    = b_a;
            assign idx_in  = idx_a;
            assign hen_in  = hen_a;
            assign clr_in  = clr_a;
            assign arm_in  = arm_a;
            assign clip_in = (a_a == 8'h80) || (a_a == 8'h7f) || (b_a == 8'h80) || (b_a == 8'h7f);
            assign bad_in  = (amp2 < AMP2_MIN) || (amp2 > AMP2_MAX);
            assign m_cal_ofs_a   = 16'd0;
            assign m_cal_ofs_b   = 16'd0;
            assign m_cal_gain_a  = 16'h4000;
            assign m_cal_gain_b  = 16'h4000;
            assign m_cal_phase   = 16'd0;
            assign m_cal_gear    = 8'd0;
            assign m_cal_updates = 16'd0;
            wire unused_cal = &{1'b0, cal_en_a, cal_fr_a, cfg_cal_mu};
        end
    endgenerate

    // ---------------------------------------------------------------- stage B: quadrant, LUT
    // Sign bits with the zero code held (+-1/2 LSB hysteresis: every quadrant exactly 90 deg
    // wide, so the decoder tracks to 244.14 rev/s; the position is the same either way at 0).
    reg           sa_prev, sb_prev;
    wire          sa  = (a_in == {AW{1'b0}}) ? sa_prev : a_in[AW-1];
    wire          sb  = (b_in == {AW{1'b0}}) ? sb_prev : b_in[AW-1];
    wire          odd = sa ^ sb;
    wire [AW-1:0] ma  = sa ? (~a_in + 1'b1) : a_in;  // |a| (|-2**(AW-1)| fits AW bits unsigned)
    wire [AW-1:0] mb  = sb ? (~b_in + 1'b1) : b_in;
    wire [AW-1:0] y   = odd ? mb : ma;             // sin of the local angle
    wire [AW-1:0] x   = odd ? ma : mb;             // cos of the local angle
    wire          half = (y >= x);                 // local angle >= 45 deg: the smaller is x
    wire [AW-1:0] msm  = half ? x : y;             // the smaller magnitude

    wire [AW-1:0] mlg  = half ? y : x;             // the larger magnitude (ANGLE = 1)

    // Delay from the select to the table read: ANGLE_REG register(s), then (ANGLE = 1) the
    // divider's RATIO_BITS + 1 stages. Control bits (valid, pulses) are reset, data is not.
    localparam integer QB  = RATIO_BITS + 1;
    localparam integer XD  = ANGLE_REG + ((ANGLE != 0) ? QB : 0);
    localparam integer SBW = 7;
    wire [2:0]     ctl_0 = {v_in, v_in & clr_in, v_in & arm_in};
    wire [SBW-1:0] sbd_0 = {hen_in, sa, odd, half, idx_in, clip_in, bad_in};
    wire [2:0]     ctl_s;                           // at the table read
    wire [SBW-1:0] sbd_s;
    wire [AW-1:0]  msm_r, mlg_r;                    // after the optional ANGLE_REG register
    generate
        if (XD == 0) begin : g_nodelay
            assign ctl_s = ctl_0;
            assign sbd_s = sbd_0;
        end else begin : g_delay
            reg  [3*XD-1:0]   ctl_d;                      // tap i in bits [3i +: 3]
            reg  [SBW*XD-1:0] sbd_d;
            wire [3*XD+2:0]   ctl_sh = {ctl_d, ctl_0};
            wire [SBW*XD+SBW-1:0] sbd_sh = {sbd_d, sbd_0};
            always @(posedge clk) begin
                if (rst) ctl_d <= {(3 * XD){1'b0}};
                else     ctl_d <= ctl_sh[3*XD-1:0];
            end
            always @(posedge clk) sbd_d <= sbd_sh[SBW*XD-1:0];
            wire unused_sh = &{1'b0, ctl_sh[3*XD+2:3*XD], sbd_sh[SBW*XD+SBW-1:SBW*XD]};
            assign ctl_s = ctl_d[3*XD-1 -: 3];
            assign sbd_s = sbd_d[SBW*XD-1 -: SBW];
        end
        if (ANGLE_REG != 0) begin : g_areg
            reg [AW-1:0] msm_q, mlg_q;
            always @(posedge clk) begin
                msm_q <= msm;
                mlg_q <= mlg;
            end
            assign msm_r = msm_q;
            assign mlg_r = mlg_q;
        end else begin : g_noareg
            assign msm_r = msm;
            assign mlg_r = mlg;
        end
    endgenerate

    // ANGLE = 1: the ratio table carries HF = 2 fraction bits (0..2**(LUT_BITS+HF)); the fine
    // angle is rounded back to counts after the (HARM = 1) harmonic correction in 1/4 count
    localparam integer HF  = (ANGLE != 0) ? 2 : 0;
    localparam integer TW  = LUT_BITS + 1 + HF;     // table word
    reg              vb;
    wire [TW-1:0]    t_b;                           // table output: 0..2**(LUT_BITS+HF)
    generate
        if (ANGLE != 0) begin : g_ratio
            // atan(m / M) through floor(m 2**RATIO_BITS / M) (clamped: m = M reads the last entry)
            localparam integer RN = 1 << RATIO_BITS;
            wire [QB-1:0]         quo;
            ratio_div #(.W(AW), .QB(QB)) u_div (
                .clk(clk), .s_num(msm_r), .s_den(mlg_r), .m_quo(quo)
            );
            wire [RATIO_BITS-1:0] addr = quo[QB-1] ? {RATIO_BITS{1'b1}} : quo[RATIO_BITS-1:0];
            reg [TW-1:0]          rtab [0:RN-1];
            reg [TW-1:0]          t_q;
            initial $readmemh(RATIO_FILE, rtab);
            always @(posedge clk) t_q <= rtab[addr];
            assign t_b = t_q;
        end else if (CAL != 0) begin : g_lut_cal
            wire [8:0]         addr = (msm_r > 12'd511) ? 9'd511 : msm_r[8:0];  // the table clamps
            reg [LUT_BITS-1:0] lut [0:LUT_N-1];
            reg [LUT_BITS-1:0] lut_b;
            initial $readmemh(CAL_LUT_FILE, lut);
            always @(posedge clk) lut_b <= lut[addr];
            assign t_b = {1'b0, lut_b};
            wire unused_mlg = &{1'b0, mlg_r};
        end else begin : g_lut
            wire [7:0]         addr = msm_r;                               // 0..128
            reg [LUT_BITS-1:0] lut [0:LUT_N-1];
            reg [LUT_BITS-1:0] lut_b;
            initial $readmemh(LUT_FILE, lut);
            always @(posedge clk_b) lut_b <= lut[addr];
            assign t_b = {1'b0, lut_b};
            wire unused_mlg = &{1'b0, mlg_r};
        end
    endgenerate
    reg [1:0]          q_b;
    reg                half_b, idx_b, clr_b, arm_b, clip_b, bad_b, hen_b;

    always @(posedge clk_b) begin
        hen_b  <= sbd_s[6];
        q_b    <= sbd_s[5:4];
        half_b <= sbd_s[3];
        idx_b  <= sbd_s[2];
        clip_b <= sbd_s[1];
        bad_b  <= sbd_s[0];
    end

    always @(posedge clk) begin
        if (rst) begin
            vb    <= 1'b0;
            clr_b <= 1'b0;
            arm_b <= 1'b0;
        end else begin
            vb    <= ctl_s[2];
            clr_b <= ctl_s[1];
            arm_b <= ctl_s[0];
        end
    end

    always @(posedge clk_b) begin
        if (rst) begin
            sa_prev <= 1'b0;
            sb_prev <= 1'b0;
        end else if (v_in) begin
            sa_prev <= sa;
            sb_prev <= sb;
        end
    end

    // ---------------------------------------------------------------- stage H: harmonic table (HARM = 1)
    // Stage C's inputs: the sample after stage B (or after stage H), fine angle sign-extended.
    wire           vC, clrC, armC, idxC, clipC, badC;
    wire [1:0]     qC;
    wire [31:0]    fineC;
    generate
        if (HARM != 0) begin : g_harm
            localparam integer HN  = 1 << HARM_LOG2;
            localparam integer FH  = FB + HF;                    // fine bits in 1/2**HF count
            localparam [FH:0]  QUAD_H = {1'b1, {FH{1'b0}}};
            wire [FH:0]          fine_h = half_b ? QUAD_H - {1'b0, t_b} : {1'b0, t_b};
            wire [FH+1:0]        lpos   = {q_b, {FH{1'b0}}} + {1'b0, fine_h};  // mod one line
            wire [HARM_LOG2-1:0] hidx   = lpos[FH+1 -: HARM_LOG2];
            reg  [7:0]           htab [0:HN-1];
            reg  [7:0]           h_rd, rdata_q;
            reg                  vh, clr_h, arm_h, rd_smp;
            reg  [1:0]           q_h;
            reg                  idx_h, clip_h, bad_h, hen_h;
            reg  [FH:0]          fine_hq;
            wire [HARM_LOG2-1:0] raddr = vb ? hidx : cfg_harm_addr[HARM_LOG2-1:0];
            always @(posedge clk) begin
                if (cfg_harm_we) htab[cfg_harm_addr[HARM_LOG2-1:0]] <= cfg_harm_data;
                h_rd <= htab[raddr];
            end
            always @(posedge clk) begin
                q_h     <= q_b;
                idx_h   <= idx_b;
                clip_h  <= clip_b;
                bad_h   <= bad_b;
                hen_h   <= hen_b;
                fine_hq <= fine_h;
                if (!rd_smp) rdata_q <= h_rd;                      // a read-back clock
            end
            always @(posedge clk) begin
                if (rst) begin
                    vh     <= 1'b0;
                    clr_h  <= 1'b0;
                    arm_h  <= 1'b0;
                    rd_smp <= 1'b0;
                end else begin
                    vh     <= vb;
                    clr_h  <= clr_b;
                    arm_h  <= arm_b;
                    rd_smp <= vb;
                end
            end
            // fine = (fine_h - H + 2**(HF-1)) >> HF, signed: may leave 0..2**FB by the correction
            wire [31:0] hx   = hen_h ? {{24{h_rd[7]}}, h_rd} : 32'd0;
            wire [31:0] fsum = {{(31 - FH){1'b0}}, fine_hq} - hx + 32'd2;  // + half a count
            wire [31:0] fcor = {{HF{fsum[31]}}, fsum[31:HF]};
            assign vC    = vh;
            assign clrC  = clr_h;
            assign armC  = arm_h;
            assign idxC  = idx_h;
            assign clipC = clip_h;
            assign badC  = bad_h;
            assign qC    = q_h;
            assign fineC = (COARSE != 0) ? 32'd0 : fcor;
            assign m_harm_rdata = rdata_q;
            wire unused_h = &{1'b0, fsum[HF-1:0], cfg_harm_addr, lpos[FH+1-HARM_LOG2:0]};
        end else begin : g_noharm
            // ANGLE = 0: f = h ? 2**FB - T : T; ANGLE = 1: f = round((h ? 2**(FB+HF) - T : T) / 4)
            wire [FB+HF:0] lut_ext = {1'b0, t_b};
            wire [FB+HF:0] quad_e  = {1'b1, {(FB + HF){1'b0}}};
            wire [FB+HF:0] fine_e  = half_b ? quad_e - lut_ext : lut_ext;  // mirror: 2**FB - T
            localparam integer RND_I = (HF == 2) ? 2 : 0;   // half a count in 1/4 count
            localparam [FB+HF:0] RND = RND_I[FB+HF:0];
            wire [FB+HF:0] fine_r  = fine_e + RND;
            wire [FB:0]    fine_i  = fine_r[FB+HF:HF];
            assign vC    = vb;
            assign clrC  = clr_b;
            assign armC  = arm_b;
            assign idxC  = idx_b;
            assign clipC = clip_b;
            assign badC  = bad_b;
            assign qC    = q_b;
            assign fineC = (COARSE != 0) ? 32'd0 : {{(31 - FB){1'b0}}, fine_i};
            assign m_harm_rdata = 8'd0;
            if (HF != 0) begin : g_round
                wire unused_r = &{1'b0, fine_r[HF-1:0]};
            end
            wire unused_h = &{1'b0, hen_b, cfg_harm_we, cfg_harm_addr, cfg_harm_data};
        end
    endgenerate

    // ---------------------------------------------------------------- stage C: count, index, faults

    reg            started, last_up, idx_prev, arm_pend, homed_q;
    reg [1:0]      q_prev;
    reg [QCW-1:0]  qc;
    reg [31:0]     home;
    reg [RUNW-1:0] run;
    reg [2:0]      flags;

    wire [1:0]     dq        = qC - q_prev;
    wire           overspeed = started && (dq == 2'd2);
    reg  [QCW-1:0] qc_next;
    always @(*) begin
        if (!started)
            qc_next = {{(QCW - 2){1'b0}}, qC};
        else case (dq)
            2'd1:    qc_next = qc + 1'b1;
            2'd3:    qc_next = qc - 1'b1;
            2'd2:    qc_next = last_up ? qc + QC_TWO : qc - QC_TWO;  // overspeed: keep going
            default: qc_next = qc;
        endcase
    end

    wire [31:0]     qstart   = {qc_next, {FB{1'b0}}};
    wire [31:0]     pos_next = qstart + fineC;
    // The index is high in quadrant 0 of line 0, so its edge marks a line start; the decoder may
    // still show the neighbouring quadrant there (the channel crossing zero reads 0 and holds its
    // sign), so the latch takes the nearest line start: qc rounded to a multiple of 4.
    wire [QCW-3:0]  qline      = qc_next[QCW-1:2] + {{(QCW - 3){1'b0}}, qc_next[1]};  // (qc+2)/4
    wire [31:0]     line_start = {qline, 2'b00, {FB{1'b0}}};
    wire            rise     = idxC & ~idx_prev;
    wire            home_now = rise & (arm_pend | armC);
    wire [31:0]     home_next = home_now ? line_start : home;
    wire [RUNW-1:0] run_next = !badC ? {RUNW{1'b0}}
                             : (run == LOSS_N) ? run : run + 1'b1;
    wire            loss     = (run_next == LOSS_N);
    wire [2:0]      flags_next = (clrC ? 3'b000 : flags) | {loss, clipC, overspeed};

    reg        vc;
    reg [31:0] pos_c, pos_homed_c, index_pos_c;
    reg [15:0] index_count_c, ovs_count_c;

    always @(posedge clk) begin
        if (rst) vc <= 1'b0;
        else     vc <= vC;
    end

    always @(posedge clk_c) begin
        if (rst) begin
            started       <= 1'b0;
            last_up       <= 1'b1;
            idx_prev      <= 1'b1;
            arm_pend      <= 1'b0;
            homed_q       <= 1'b0;
            home          <= 32'd0;
            run           <= {RUNW{1'b0}};
            flags         <= 3'b000;
            q_prev        <= 2'd0;
            qc            <= {QCW{1'b0}};
            index_pos_c   <= 32'd0;
            index_count_c <= 16'd0;
            ovs_count_c   <= 16'd0;
        end else begin
            if (vC) begin
                started  <= 1'b1;
                q_prev   <= qC;
                qc       <= qc_next;
                if (started && dq == 2'd1) last_up <= 1'b1;
                if (started && dq == 2'd3) last_up <= 1'b0;
                idx_prev <= idxC;
                if (rise) begin
                    index_pos_c   <= line_start;
                    index_count_c <= index_count_c + 16'd1;
                end
                if (armC) begin
                    arm_pend <= 1'b1;
                    homed_q  <= 1'b0;
                end
                if (home_now) begin
                    arm_pend <= 1'b0;
                    homed_q  <= 1'b1;
                end
                home  <= home_next;
                run   <= run_next;
                flags <= flags_next;
                if (overspeed && ovs_count_c != 16'hffff) ovs_count_c <= ovs_count_c + 16'd1;
            end
        end
    end

    reg ovs_c;
    always @(posedge clk_c) begin
        if (vC) begin
            pos_c       <= pos_next;
            pos_homed_c <= pos_next - home_next;
            ovs_c       <= overspeed;
        end
    end

    // ---------------------------------------------------------------- velocity observer (VEL_OBS = 1)
    // Updated with each sample's position at stage D (flags: the sticky faults after that sample);
    // its velocity after the update is registered beside the FIR's at stage E.
    wire [31:0] obs_vel;
    generate
        if (VEL_OBS != 0) begin : g_obs
            vel_observer #(.VEL_LOG2W(VEL_LOG2W)) u_obs (
                .clk(clk), .rst(rst), .s_valid(vc), .s_pos(pos_c), .s_hold(flags[2]),
                .s_ovs(ovs_c), .cfg_bw(cfg_obs_bw), .cfg_type3(cfg_obs_type3),
                .m_vel(obs_vel)
            );
        end else begin : g_noobs
            assign obs_vel = 32'd0;
            wire unused_obs = &{1'b0, cfg_obs_bw, cfg_obs_type3, ovs_c};
        end
    endgenerate

    // ---------------------------------------------------------------- stage D: velocity delay line
    reg [DW-1:0]        hist [0:W-1];        // pos of the last W samples (low DW bits)
    reg [VEL_LOG2W-1:0] wptr;
    reg                 full, full_d, vd;
    reg [DW-1:0]        old_d;
    reg [31:0]          pos_d, pos_homed_d, index_pos_d;
    reg [15:0]          index_count_d, ovs_count_d;
    reg                 homed_d;
    reg [2:0]           flags_d;

    always @(posedge clk_de) begin
        if (vc) begin
            hist[wptr] <= pos_c[DW-1:0];
            old_d      <= hist[wptr];            // read-before-write: pos[n - W]
        end
    end

    generate
        if (HOLD_C != 0) begin : g_hold_c
            // Stage C's registers change only with vb and hold to the next sample: with no
            // sample in the clock after this one (s_valid never high two clocks in a row) they
            // still hold at vd the value the copies would hold.
            always @(*) begin
                pos_d         = pos_c;
                pos_homed_d   = pos_homed_c;
                index_pos_d   = index_pos_c;
                index_count_d = index_count_c;
                ovs_count_d   = ovs_count_c;
                homed_d       = homed_q;
                flags_d       = flags;
            end
        end else begin : g_copy_d
            always @(posedge clk_de) begin
                pos_d         <= pos_c;
                pos_homed_d   <= pos_homed_c;
                index_pos_d   <= index_pos_c;
                index_count_d <= index_count_c;
                ovs_count_d   <= ovs_count_c;
                homed_d       <= homed_q;
                flags_d       <= flags;
            end
        end
    endgenerate

    always @(posedge clk) begin
        if (rst) vd <= 1'b0;
        else     vd <= vc;
    end

    always @(posedge clk_de) begin
        if (rst) begin
            wptr   <= {VEL_LOG2W{1'b0}};
            full   <= 1'b0;
            full_d <= 1'b0;
        end else begin
            if (vc) begin
                wptr   <= wptr + 1'b1;
                full_d <= full;
                if (&wptr) full <= 1'b1;           // wrote entry W-1: every entry valid
            end
        end
    end

    // ---------------------------------------------------------------- stage E: outputs
    wire [DW-1:0] vdiff = pos_d[DW-1:0] - old_d;

    always @(posedge clk_de) begin
        if (vd) begin
            m_pos             <= pos_d;
            m_pos_homed       <= pos_homed_d;
            m_vel             <= full_d ? {{(32 - DW){vdiff[DW-1]}}, vdiff} : 32'd0;
            m_vel_obs         <= obs_vel;
            m_index_pos       <= index_pos_d;
            m_index_count     <= index_count_d;
            m_overspeed_count <= ovs_count_d;
            m_homed           <= homed_d;
        end
    end

    always @(posedge clk) begin
        if (rst) m_valid <= 1'b0;
        else     m_valid <= vd;
    end

    always @(posedge clk_de) begin
        if (rst)     m_faults <= 3'b000;
        else if (vd) m_faults <= flags_d;
    end

    assign m_fault = |m_faults;

    // simulation only: the stage clocks' enables (capture with the strobe, each stage with its
    // input valid, D and E until their valids clear; every clock where a stage works without)
    `HG_SIM_EN(((CAL == 0 && HARM == 0 && ANGLE == 0 && ANGLE_REG == 0) ? {rst | vc | vd, rst | vC, rst | ctl_s[2], s_valid} : 4'b1111))
endmodule

`default_nettype wire
