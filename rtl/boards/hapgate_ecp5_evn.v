// SPDX-License-Identifier: Apache-2.0
// Board top for Lattice's ECP5-5G evaluation board (LFE5UM5G-85F): the 12 MHz board clock
// multiplied to CLK_HZ by an EHXPLLL and the reset from the active-low button and the PLL lock
// (ecp5_pll_reset; USE_PLL=0 bypasses the PLL for simulation), the DSP data bus as real
// bidirectional pins. The headers carry the paper's parallel buses directly (no adapter).
// Pins: ecp5_evn.lpf.
`timescale 1ns / 1ps
`default_nettype none

module hapgate_ecp5_evn #(
    parameter integer CLK_HZ    = 48_000_000, // core clock: the PLL output (a multiple of 1 MHz)
    parameter integer USE_PLL   = 1,          // 0: simulation bypass, the core runs on clk
    // the integrity countermeasures (hapgate_top; issue 38, `hapgate pnr --harden all`)
    parameter integer SEC_REGS  = 0,
    parameter integer SEC_COMM  = 0,
    parameter integer SEC_DAC   = 0,
    parameter integer SEC_TICK  = 0,
    parameter integer SEC_POS   = 0,
    parameter         ASIN_FILE = "asin.hex", // arcsine table (hapgate.golden.interp.write_lut)
    parameter         SINE_FILE = "sine.hex"  // sine ROM (hapgate.golden.sine.write_rom)
) (
    input  wire        clk,            // 12 MHz board clock
    input  wire        rst_n,          // push button, active low, asynchronous
    output wire        adc_strobe,
    output wire        adc_clk,        // the converters' sample clock (CLK pins)
    input  wire [23:0] adc_a,
    input  wire [23:0] adc_b,
    input  wire [2:0]  enc_index,
    output wire [13:0] dac_data,
    output wire [2:0]  dac_addr,
    output wire        dac_wr_n,
    input  wire        bus_ce_n,
    input  wire        bus_re_n,
    input  wire        bus_we_n,
    input  wire [7:0]  bus_addr,
    inout  wire [31:0] bus_data,
    output wire        bus_ready,
    output wire        irq
);
    // the PLL and the reset (shared with hapgate_ecp5_soc)
    wire core_clk, rst;
    ecp5_pll_reset #(.CLK_HZ(CLK_HZ), .USE_PLL(USE_PLL)) u_clkrst (
        .clk_in(clk), .rst_n(rst_n), .clk(core_clk), .rst(rst)
    );

    wire [31:0] data_out;
    wire        data_oe;
    assign bus_data = data_oe ? data_out : 32'bz;

    hapgate_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE),
        .SEC_REGS(SEC_REGS), .SEC_COMM(SEC_COMM), .SEC_DAC(SEC_DAC), .SEC_TICK(SEC_TICK),
        .SEC_POS(SEC_POS)
    ) u_top (
        .clk(core_clk), .rst(rst),
        .adc_strobe(adc_strobe), .adc_clk(adc_clk), .adc_a(adc_a), .adc_b(adc_b), .enc_index(enc_index),
        .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_data), .bus_data_out(data_out), .bus_data_oe(data_oe),
        .bus_ready(bus_ready), .irq(irq)
    );
endmodule

`default_nettype wire
