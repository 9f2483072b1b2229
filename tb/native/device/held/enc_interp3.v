// SPDX-License-Identifier: Apache-2.0
// Simulation only (the virtual device, tb/native/device/README.md "Axes that are not built"): the
// interpolator bank with only the axes in `HG_AXIS_MASK built, compiled by the device's build in
// place of rtl/interp/enc_interp3.v when a scene leaves axes out. The built axes are one
// enc_interp3 of fewer axes (enc_interp3_built: rtl/interp/enc_interp3.v with its module renamed,
// generated into build/ by hapgate.device.runner); the slots of the others show a held joint
// (hold_*: constant, at rest in the start pose since reset; homed only if hold_index_count says an
// index was latched; no fault, the calibration's identity). The FPGA's top has all three.
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module enc_interp3 #(   // the parameters and ports of rtl/interp/enc_interp3.v
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
    localparam integer AXIS_MASK = `HG_AXIS_MASK;   // axes built (bit i = axis i)
    localparam integer NAX = ((AXIS_MASK >> 0) & 1) + ((AXIS_MASK >> 1) & 1) + ((AXIS_MASK >> 2) & 1);
    generate
        if (AXES != 3 || AXIS_MASK < 1 || AXIS_MASK > 6) begin : g_bad_mask
            enc_interp3_held_needs_AXES_3_and_HG_AXIS_MASK_1_to_6 u_stop ();
        end
    endgenerate

    // What the interpolator of a held axis would report (position from its home, index latch,
    // index count: 0 unless an index was latched, then homed), written by the harness before
    // the first evaluation (runner.hold_values).
    reg [95:0] hold_pos_homed   /*verilator public_flat_rw*/;
    reg [95:0] hold_index_pos   /*verilator public_flat_rw*/;
    reg [47:0] hold_index_count /*verilator public_flat_rw*/;

    wire [8*NAX-1:0]  c_adc_a, c_adc_b, c_harm_rdata, c_cal_gear;
    wire [NAX-1:0]    c_index, c_fault_clear, c_arm, c_homed, c_fault, c_cal_en, c_cal_freeze,
                      c_obs_type3, c_harm_en, c_harm_we;
    wire [32*NAX-1:0] c_pos, c_pos_homed, c_vel, c_index_pos, c_vel_obs;
    wire [4*NAX-1:0]  c_obs_bw, c_cal_mu;
    wire [16*NAX-1:0] c_index_count, c_overspeed_count, c_cal_ofs_a, c_cal_ofs_b, c_cal_gain_a,
                      c_cal_gain_b, c_cal_phase, c_cal_updates;
    wire [3*NAX-1:0]  c_faults;

    enc_interp3_built #(
        .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .AXES(NAX), .LUT_BITS(LUT_BITS),
        .LUT_FILE(LUT_FILE), .VEL_LOG2W(VEL_LOG2W), .AMP_MIN(AMP_MIN), .AMP_MAX(AMP_MAX),
        .LOSS_SAMPLES(LOSS_SAMPLES), .INVERT_MASK(INVERT_MASK), .CAL(CAL),
        .CAL_LUT_FILE(CAL_LUT_FILE), .CAL_LINES_LOG2(CAL_LINES_LOG2), .CAL_NLOG(CAL_NLOG),
        .COARSE(COARSE), .SQ_RAM(SQ_RAM), .HOLD_C(HOLD_C), .ANGLE(ANGLE),
        .RATIO_BITS(RATIO_BITS), .RATIO_FILE(RATIO_FILE), .ANGLE_REG(ANGLE_REG), .HARM(HARM),
        .HARM_LOG2(HARM_LOG2), .VEL_OBS(VEL_OBS)
    ) u_built (
        .clk(clk), .rst(rst), .adc_strobe(adc_strobe), .adc_a(c_adc_a), .adc_b(c_adc_b),
        .enc_index(c_index), .ctl_fault_clear(c_fault_clear), .ctl_home_arm(c_arm),
        .ctl_cal_en(c_cal_en), .ctl_cal_freeze(c_cal_freeze), .cfg_cal_mu(c_cal_mu),
        .ctl_harm_en(c_harm_en), .cfg_harm_we(c_harm_we), .cfg_harm_addr(cfg_harm_addr),
        .cfg_harm_data(cfg_harm_data), .m_harm_rdata(c_harm_rdata), .cfg_obs_bw(c_obs_bw),
        .cfg_obs_type3(c_obs_type3), .m_valid(m_valid), .m_pos(c_pos),
        .m_pos_homed(c_pos_homed), .m_vel(c_vel), .m_vel_obs(c_vel_obs),
        .m_index_pos(c_index_pos), .m_index_count(c_index_count),
        .m_overspeed_count(c_overspeed_count), .m_homed(c_homed), .m_faults(c_faults),
        .m_fault(c_fault), .m_cal_valid(m_cal_valid), .m_cal_ofs_a(c_cal_ofs_a),
        .m_cal_ofs_b(c_cal_ofs_b), .m_cal_gain_a(c_cal_gain_a), .m_cal_gain_b(c_cal_gain_b),
        .m_cal_phase(c_cal_phase), .m_cal_gear(c_cal_gear), .m_cal_updates(c_cal_updates)
        `HG_SIM_BIND(sim_gclk, sim_gate_en)
    );

    genvar ax;
    generate
        for (ax = 0; ax < 3; ax = ax + 1) begin : g_ax
            // slot of axis ax in the compacted instance
            localparam integer J = ((AXIS_MASK & ((1 << ax) - 1)) & 1) +
                                   (((AXIS_MASK & ((1 << ax) - 1)) >> 1) & 1);
            if (((AXIS_MASK >> ax) & 1) != 0) begin : g_built
                assign c_adc_a[8*J +: 8]             = adc_a[8*ax +: 8];
                assign c_adc_b[8*J +: 8]             = adc_b[8*ax +: 8];
                assign c_index[J]                    = enc_index[ax];
                assign c_fault_clear[J]              = ctl_fault_clear[ax];
                assign c_arm[J]                      = ctl_home_arm[ax];
                assign c_cal_en[J]                   = ctl_cal_en[ax];
                assign c_cal_freeze[J]               = ctl_cal_freeze[ax];
                assign c_cal_mu[4*J +: 4]            = cfg_cal_mu[4*ax +: 4];
                assign c_obs_bw[4*J +: 4]            = cfg_obs_bw[4*ax +: 4];
                assign c_obs_type3[J]                = cfg_obs_type3[ax];
                assign c_harm_en[J]                  = ctl_harm_en[ax];
                assign c_harm_we[J]                  = cfg_harm_we[ax];
                assign m_harm_rdata[8*ax +: 8]       = c_harm_rdata[8*J +: 8];
                assign m_vel_obs[32*ax +: 32]        = c_vel_obs[32*J +: 32];
                assign m_pos[32*ax +: 32]            = c_pos[32*J +: 32];
                assign m_pos_homed[32*ax +: 32]      = c_pos_homed[32*J +: 32];
                assign m_vel[32*ax +: 32]            = c_vel[32*J +: 32];
                assign m_index_pos[32*ax +: 32]      = c_index_pos[32*J +: 32];
                assign m_index_count[16*ax +: 16]    = c_index_count[16*J +: 16];
                assign m_overspeed_count[16*ax +: 16] = c_overspeed_count[16*J +: 16];
                assign m_homed[ax]                   = c_homed[J];
                assign m_faults[3*ax +: 3]           = c_faults[3*J +: 3];
                assign m_fault[ax]                   = c_fault[J];
                assign m_cal_ofs_a[16*ax +: 16]      = c_cal_ofs_a[16*J +: 16];
                assign m_cal_ofs_b[16*ax +: 16]      = c_cal_ofs_b[16*J +: 16];
                assign m_cal_gain_a[16*ax +: 16]     = c_cal_gain_a[16*J +: 16];
                assign m_cal_gain_b[16*ax +: 16]     = c_cal_gain_b[16*J +: 16];
                assign m_cal_phase[16*ax +: 16]      = c_cal_phase[16*J +: 16];
                assign m_cal_gear[8*ax +: 8]         = c_cal_gear[8*J +: 8];
                assign m_cal_updates[16*ax +: 16]    = c_cal_updates[16*J +: 16];
            end else begin : g_held
                wire unused_in = &{1'b0, adc_a[8*ax +: 8], adc_b[8*ax +: 8], enc_index[ax],
                                   ctl_fault_clear[ax], ctl_home_arm[ax], ctl_cal_en[ax],
                                   ctl_cal_freeze[ax], cfg_cal_mu[4*ax +: 4],
                                   cfg_obs_bw[4*ax +: 4], cfg_obs_type3[ax], ctl_harm_en[ax],
                                   cfg_harm_we[ax]};
                assign m_harm_rdata[8*ax +: 8]       = 8'd0;
                assign m_vel_obs[32*ax +: 32]        = 32'd0;
                assign m_pos[32*ax +: 32]            = hold_pos_homed[32*ax +: 32] +
                                                       hold_index_pos[32*ax +: 32];
                assign m_pos_homed[32*ax +: 32]      = hold_pos_homed[32*ax +: 32];
                assign m_vel[32*ax +: 32]            = 32'd0;
                assign m_index_pos[32*ax +: 32]      = hold_index_pos[32*ax +: 32];
                assign m_index_count[16*ax +: 16]    = hold_index_count[16*ax +: 16];
                assign m_overspeed_count[16*ax +: 16] = 16'd0;
                assign m_homed[ax]                   = |hold_index_count[16*ax +: 16];
                assign m_faults[3*ax +: 3]           = 3'd0;
                assign m_fault[ax]                   = 1'b0;
                assign m_cal_ofs_a[16*ax +: 16]      = 16'd0;       // the identity
                assign m_cal_ofs_b[16*ax +: 16]      = 16'd0;
                assign m_cal_gain_a[16*ax +: 16]     = 16'h4000;
                assign m_cal_gain_b[16*ax +: 16]     = 16'h4000;
                assign m_cal_phase[16*ax +: 16]      = 16'd0;
                assign m_cal_gear[8*ax +: 8]         = 8'd0;
                assign m_cal_updates[16*ax +: 16]    = 16'd0;
            end
        end
    endgenerate
endmodule

`default_nettype wire
