// SPDX-License-Identifier: Apache-2.0
// The interpolator as the FPGA has it: AXES (1..3) axes of enc_interp sharing one ADC sample
// strobe derived from CLK_HZ. Per-axis buses are packed, axis 0 in the low bits.
// Latency: 5 clocks from the cycle with adc_strobe high to the cycle with m_valid high (6: CAL = 1).
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module enc_interp3 #(
    parameter integer CLK_HZ       = 48_000_000, // FPGA clock
    parameter integer SAMPLE_HZ    = 1_000_000,  // ADC sample rate (CLK_HZ a multiple of it)
    parameter integer AXES         = 3,          // axes built (a scene builds only what it needs)
    parameter integer LUT_BITS     = 7,          // arcsine LUT codes per 45 deg = 2**LUT_BITS
    parameter         LUT_FILE     = "asin.hex", // arcsine table, shared by the axes
    parameter integer VEL_LOG2W    = 8,          // velocity window 2**VEL_LOG2W samples
    parameter integer AMP_MIN      = 40,         // signal-loss amplitude window, ADC codes
    parameter integer AMP_MAX      = 170,
    parameter integer LOSS_SAMPLES = 16,         // consecutive bad samples -> signal loss
    parameter integer INVERT_MASK  = 0,          // bit i set: axis i counts the other way
    parameter integer CAL          = 0,          // 1: online calibration stage in every axis
    parameter         CAL_LUT_FILE = "asin512.hex", // CAL = 1: 512-entry arcsine table
    parameter integer CAL_LINES_LOG2 = 3,        // CAL = 1: calibration block 2**N lines
    parameter integer CAL_NLOG     = 14,         // CAL = 1: blocks of 2**N samples ignored
    parameter integer COARSE       = 0,          // 1: plain quadrature (fine angle zeroed)
    parameter integer SQ_RAM       = 0,          // 1: signal-loss squares from block RAM (enc_interp)
    parameter integer HOLD_C       = 0,          // 1: no stage-D copies (needs CLK_HZ >= 2 SAMPLE_HZ)
    parameter integer ANGLE        = 0,          // 1: ratio angle stage atan(smaller / larger)
    parameter integer RATIO_BITS   = 10,         // ANGLE = 1: ratio table 2**RATIO_BITS entries
    parameter         RATIO_FILE   = "atan.hex", // ANGLE = 1: the ratio table
    parameter integer ANGLE_REG    = 0,          // 1: register after the angle select (latency + 1)
    parameter integer HARM         = 0,          // 1 (ANGLE = 1): harmonic correction table
    parameter integer HARM_LOG2    = 6,          // HARM = 1: 2**HARM_LOG2 entries per line
    parameter integer VEL_OBS      = 0           // 1: tracking velocity observer in every axis
) (
    input  wire                 clk,
    input  wire                 rst,
    output wire                 adc_strobe,      // ADC words are captured at the end of this cycle
    input  wire [8*AXES-1:0]    adc_a,
    input  wire [8*AXES-1:0]    adc_b,
    input  wire [AXES-1:0]      enc_index,
    input  wire [AXES-1:0]      ctl_fault_clear,
    input  wire [AXES-1:0]      ctl_home_arm,
    input  wire [AXES-1:0]      ctl_cal_en,      // calibration controls (CAL = 1), per axis
    input  wire [AXES-1:0]      ctl_cal_freeze,
    input  wire [4*AXES-1:0]    cfg_cal_mu,
    input  wire [AXES-1:0]      ctl_harm_en,     // harmonic correction (HARM = 1), per axis
    input  wire [AXES-1:0]      cfg_harm_we,     // table write strobe per axis
    input  wire [7:0]           cfg_harm_addr,   // entry (write and read-back), shared
    input  wire [7:0]           cfg_harm_data,   // signed, 1/4 count
    output wire [8*AXES-1:0]    m_harm_rdata,    // read-back of entry cfg_harm_addr per axis
    input  wire [4*AXES-1:0]    cfg_obs_bw,      // observer bandwidth code per axis (VEL_OBS = 1)
    input  wire [AXES-1:0]      cfg_obs_type3,   // observer acceleration state per axis
    output wire                 m_valid,
    output wire [32*AXES-1:0]   m_pos,
    output wire [32*AXES-1:0]   m_pos_homed,
    output wire [32*AXES-1:0]   m_vel,
    output wire [32*AXES-1:0]   m_vel_obs,       // observer velocity (0 with VEL_OBS = 0)
    output wire [32*AXES-1:0]   m_index_pos,
    output wire [16*AXES-1:0]   m_index_count,
    output wire [16*AXES-1:0]   m_overspeed_count,
    output wire [AXES-1:0]      m_homed,
    output wire [3*AXES-1:0]    m_faults,
    output wire [AXES-1:0]      m_fault,
    output wire                 m_cal_valid,     // the state below is after sample k (in order)
    output wire [16*AXES-1:0]   m_cal_ofs_a,     // calibration state (live), see enc_interp
    output wire [16*AXES-1:0]   m_cal_ofs_b,
    output wire [16*AXES-1:0]   m_cal_gain_a,
    output wire [16*AXES-1:0]   m_cal_gain_b,
    output wire [16*AXES-1:0]   m_cal_phase,
    output wire [8*AXES-1:0]    m_cal_gear,
    output wire [16*AXES-1:0]   m_cal_updates
    `HG_SIM_PORTS(4)  // simulation only (rtl/include/hg_sim.vh): enc_interp's stage clocks
);
    generate
        if (AXES < 1 || AXES > 3) begin : g_bad_axes
            enc_interp3_AXES_must_be_1_to_3 u_stop ();
        end
    endgenerate

    sample_strobe #(.CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ)) u_strobe (
        .clk(clk), .rst(rst), .strobe(adc_strobe)
    );

    wire [AXES-1:0] valid;
    assign m_valid = &valid;  // the axes run in lockstep
    wire [AXES-1:0] cal_valid;
    // simulation only: the axes run in lockstep, so axis 0's enables are every axis's
    `HG_SIM_GATE_ONLY(wire [4*AXES-1:0] sim_en;)  // (axes 1.. unread: rtl/lint/waivers.vlt)
    `HG_SIM_EN(sim_en[3:0])
    assign m_cal_valid = &cal_valid;

    genvar i;
    generate
        for (i = 0; i < AXES; i = i + 1) begin : g_axis
            enc_interp #(
                .LUT_BITS(LUT_BITS), .LUT_FILE(LUT_FILE), .VEL_LOG2W(VEL_LOG2W),
                .AMP_MIN(AMP_MIN), .AMP_MAX(AMP_MAX), .LOSS_SAMPLES(LOSS_SAMPLES),
                .INVERT((INVERT_MASK >> i) & 1), .CAL(CAL), .CAL_LUT_FILE(CAL_LUT_FILE),
                .CAL_LINES_LOG2(CAL_LINES_LOG2), .CAL_NLOG(CAL_NLOG), .COARSE(COARSE),
                .SQ_RAM(SQ_RAM), .HOLD_C(HOLD_C),
                .ANGLE(ANGLE), .RATIO_BITS(RATIO_BITS), .RATIO_FILE(RATIO_FILE),
                .ANGLE_REG(ANGLE_REG), .HARM(HARM), .HARM_LOG2(HARM_LOG2),
                .VEL_OBS(VEL_OBS)
            ) u_axis (
                .clk(clk), .rst(rst),
                .s_valid(adc_strobe),
                .s_a(adc_a[8*i +: 8]), .s_b(adc_b[8*i +: 8]), .s_index(enc_index[i]),
                .ctl_fault_clear(ctl_fault_clear[i]), .ctl_home_arm(ctl_home_arm[i]),
                .m_valid(valid[i]),
                .m_pos(m_pos[32*i +: 32]), .m_pos_homed(m_pos_homed[32*i +: 32]),
                .m_vel(m_vel[32*i +: 32]), .m_index_pos(m_index_pos[32*i +: 32]),
                .m_vel_obs(m_vel_obs[32*i +: 32]), .cfg_obs_bw(cfg_obs_bw[4*i +: 4]),
                .cfg_obs_type3(cfg_obs_type3[i]),
                .m_index_count(m_index_count[16*i +: 16]),
                .m_overspeed_count(m_overspeed_count[16*i +: 16]),
                .m_homed(m_homed[i]), .m_faults(m_faults[3*i +: 3]), .m_fault(m_fault[i]),
                .ctl_cal_en(ctl_cal_en[i]), .ctl_cal_freeze(ctl_cal_freeze[i]),
                .cfg_cal_mu(cfg_cal_mu[4*i +: 4]), .m_cal_valid(cal_valid[i]),
                .m_cal_ofs_a(m_cal_ofs_a[16*i +: 16]), .m_cal_ofs_b(m_cal_ofs_b[16*i +: 16]),
                .m_cal_gain_a(m_cal_gain_a[16*i +: 16]), .m_cal_gain_b(m_cal_gain_b[16*i +: 16]),
                .m_cal_phase(m_cal_phase[16*i +: 16]), .m_cal_gear(m_cal_gear[8*i +: 8]),
                .m_cal_updates(m_cal_updates[16*i +: 16]),
                .ctl_harm_en(ctl_harm_en[i]), .cfg_harm_we(cfg_harm_we[i]),
                .cfg_harm_addr(cfg_harm_addr), .cfg_harm_data(cfg_harm_data),
                .m_harm_rdata(m_harm_rdata[8*i +: 8])
                `HG_SIM_BIND(sim_gclk, sim_en[4*i +: 4])
            );
        end
    endgenerate
endmodule

`default_nettype wire
