// SPDX-License-Identifier: Apache-2.0
// The DSP-facing half of the FPGA: the EMIF-like bus slave and the register file, joined. The top
// level (rtl/top/hapgate_top.v) instantiates this; tb/bus tests it alone with the interpolator
// outputs driven by the testbench.
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module hg_bus #(
    parameter integer CLK_HZ       = 48_000_000, // FPGA clock: a multiple of 1 MHz
    parameter integer SAMPLE_HZ    = 1_000_000,  // encoder sample rate (velocity unit conversion)
    parameter integer VEL_LOG2W    = 8,          // velocity window 2**VEL_LOG2W samples
    parameter integer VEL_BITS     = 32,         // in_vel: sign extension of its low VEL_BITS bits
    parameter integer SKEW_CLOCKS  = 96,         // DAC channel skew in clocks (read-only info)
    parameter integer FRAME_CLOCKS = 768,        // DAC frame in clocks (read-only info)
    parameter integer ADDR_BITS    = 8,          // word-address lines decoded
    parameter integer VEL_OBS      = 0,          // 1: the interpolator has the velocity observer
    parameter integer VEL_SEL_RST  = 0,          // 1: VEL_CTRL.SEL resets to 7
    parameter integer HARM         = 0,          // 1: the interpolator has the harmonic table
    parameter integer HARM_LOG2    = 6,          // HARM = 1: its entries per line, log2
    parameter integer SEC          = 0           // integrity countermeasures built (hg_regfile)
) (
    input  wire                 clk,
    input  wire                 rst,
    input  wire                 bus_ce_n,
    input  wire                 bus_re_n,
    input  wire                 bus_we_n,
    input  wire [ADDR_BITS-1:0] bus_addr,
    input  wire [31:0]          bus_data_in,
    output wire [31:0]          bus_data_out,
    output wire                 bus_data_oe,
    output wire                 bus_ready,
    input  wire [95:0]          in_pos,
    input  wire [95:0]          in_pos_homed,
    input  wire [95:0]          in_vel,
    input  wire [95:0]          in_index_pos,
    input  wire [47:0]          in_index_count,
    input  wire [47:0]          in_overspeed_count,
    input  wire [2:0]           in_homed,
    input  wire [8:0]           in_faults,
    input  wire [2:0]           in_fault,
    input  wire [95:0]          in_cal_ofs,      // live calibration state (see hg_regfile)
    input  wire [95:0]          in_cal_gain,
    input  wire [47:0]          in_cal_phase,
    input  wire [95:0]          in_cal_stat,
    output wire                 ctl_global_en,
    output wire [2:0]           ctl_axis_en,
    output wire                 ctl_fault_clear,
    output wire [2:0]           ctl_home_arm,
    output wire [47:0]          ctl_torque,
    output wire [29:0]          ctl_offset,
    output wire [5:0]           ctl_mode,
    output wire [47:0]          ctl_tq_limit,
    output wire [2:0]           ctl_cal_en,
    output wire [2:0]           ctl_cal_freeze,
    output wire [11:0]          cfg_cal_mu,
    input  wire [95:0]          in_vel_obs,      // observer velocity (see hg_regfile)
    output wire [11:0]          cfg_obs_bw,
    output wire [2:0]           cfg_obs_type3,
    output wire [2:0]           ctl_harm_en,     // harmonic table (see hg_regfile)
    output wire [2:0]           cfg_harm_we,
    output wire [7:0]           cfg_harm_addr,
    output wire [7:0]           cfg_harm_data,
    input  wire [23:0]          in_harm_rdata,
    input  wire [127:0]         in_cap,          // capture buffer's registers (see hg_regfile)
    output wire                 wdog_expired,
    input  wire [4:0]           in_sec_err,      // the top's integrity alarms (see hg_regfile)
    output wire                 sec_fault,       // HW_FAULT latched: all torque to zero
    output wire                 irq,
    output wire                 tick,
    output wire                 dbg_req,         // observation: a served access (one clock)
    output wire                 dbg_we,          // ... its direction, word address and write data
    output wire [ADDR_BITS-1:0] dbg_addr,
    output wire [31:0]          dbg_wdata,
    output wire                 dbg_proto_err    // observation: a dropped access (one clock)
    `HG_SIM_PORTS(1)  // simulation only (rtl/include/hg_sim.vh): the bus clock
);
    wire [ADDR_BITS-1:0] raddr, addr;
    wire [31:0]          rdata, wdata;
    wire                 req, we, perr;
    `HG_SIM_GATE_ONLY(wire [1:0] sim_en;)  // the slave's and the register file's enables

    emif_slave #(.ADDR_BITS(ADDR_BITS)) u_slave (
        .clk(clk), .rst(rst),
        .s_bus_ce_n(bus_ce_n), .s_bus_re_n(bus_re_n), .s_bus_we_n(bus_we_n),
        .s_bus_addr(bus_addr), .s_bus_data_in(bus_data_in), .s_bus_data_out(bus_data_out),
        .s_bus_data_oe(bus_data_oe), .s_bus_ready(bus_ready),
        .m_raddr(raddr), .m_rdata(rdata), .m_req(req), .m_we(we), .m_addr(addr),
        .m_wdata(wdata), .m_proto_err(perr)
        `HG_SIM_BIND(sim_gclk, sim_en[0])
    );

    hg_regfile #(
        .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .VEL_LOG2W(VEL_LOG2W), .VEL_BITS(VEL_BITS),
        .SKEW_CLOCKS(SKEW_CLOCKS), .FRAME_CLOCKS(FRAME_CLOCKS), .ADDR_BITS(ADDR_BITS),
        .VEL_OBS(VEL_OBS), .VEL_SEL_RST(VEL_SEL_RST), .HARM(HARM), .HARM_LOG2(HARM_LOG2),
        .SEC(SEC)
    ) u_regs (
        .clk(clk), .rst(rst),
        .s_raddr(raddr), .s_rdata(rdata), .s_req(req), .s_we(we), .s_addr(addr),
        .s_wdata(wdata), .s_proto_err(perr),
        .in_pos(in_pos), .in_pos_homed(in_pos_homed), .in_vel(in_vel),
        .in_index_pos(in_index_pos), .in_index_count(in_index_count),
        .in_overspeed_count(in_overspeed_count), .in_homed(in_homed), .in_faults(in_faults),
        .in_fault(in_fault),
        .in_cal_ofs(in_cal_ofs), .in_cal_gain(in_cal_gain), .in_cal_phase(in_cal_phase),
        .in_cal_stat(in_cal_stat), .ctl_cal_en(ctl_cal_en), .ctl_cal_freeze(ctl_cal_freeze),
        .cfg_cal_mu(cfg_cal_mu),
        .in_vel_obs(in_vel_obs), .cfg_obs_bw(cfg_obs_bw), .cfg_obs_type3(cfg_obs_type3),
        .ctl_harm_en(ctl_harm_en), .cfg_harm_we(cfg_harm_we), .cfg_harm_addr(cfg_harm_addr),
        .cfg_harm_data(cfg_harm_data), .in_harm_rdata(in_harm_rdata),
        .in_cap(in_cap),
        .ctl_global_en(ctl_global_en), .ctl_axis_en(ctl_axis_en),
        .ctl_fault_clear(ctl_fault_clear), .ctl_home_arm(ctl_home_arm),
        .ctl_torque(ctl_torque), .ctl_offset(ctl_offset), .ctl_mode(ctl_mode),
        .ctl_tq_limit(ctl_tq_limit), .wdog_expired(wdog_expired), .irq(irq), .tick(tick),
        .in_sec_err(in_sec_err), .sec_fault(sec_fault)
        `HG_SIM_BIND(sim_gclk, sim_en[1])
    );
    `HG_SIM_EN((|sim_en))

    assign dbg_req       = req;
    assign dbg_we        = we;
    assign dbg_addr      = addr;
    assign dbg_wdata     = wdata;
    assign dbg_proto_err = perr;
endmodule

`default_nettype wire
