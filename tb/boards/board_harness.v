// SPDX-License-Identifier: Apache-2.0
// Simulation harness: a board top seen through the core's port list (hapgate_top), so the
// whole-FPGA test (tb/top/cocotb_top.py) drives the board's real pins: the active-low reset
// through the board's synchroniser (and power-on reset), the DSP bus through the bidirectional
// data pins (the DSP side drives them whenever the board does not: no floating lines, like a bus
// keeper; the board drives only during the reads it serves), and, for the HX8K, the ADC
// pair adapter with behavioural three-state converters (A or B on the shared lines while its
// output enable is low). BOARD selects the board top: 0 iCE40-HX8K, 1 ECP5-EVN (PLL bypassed).
`timescale 1ns / 1ps
`default_nettype none

module board_harness #(
    parameter integer BOARD      = 0,          // 0 hapgate_ice40_hx8k, 1 hapgate_ecp5_evn
    parameter integer CLK_HZ     = 16_000_000, // the simulated clock
    parameter integer SERIAL_MUL = 1,          // (HX8K) shift-add commutation multiplier
    parameter integer USE_PLL    = 0,          // (ECP5) must be 0 in simulation
    parameter         ASIN_FILE  = "asin.hex",
    parameter         SINE_FILE  = "sine.hex"
) (
    input  wire        clk,
    input  wire        rst,
    output wire        adc_strobe,
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
    input  wire [31:0] bus_data_in,
    output wire [31:0] bus_data_out,
    output wire        bus_data_oe,
    output wire        bus_ready,
    output wire        irq
);
    wire [31:0] bus_data;                              // the board's data pins
    assign bus_data     = bus_data_oe ? 32'bz : bus_data_in;
    assign bus_data_out = bus_data;
    wire        rst_n = ~rst;

    generate
        if (BOARD == 0) begin : g_hx8k
            wire        oe_a_n, oe_b_n;
            wire [23:0] adc_d = !oe_a_n ? adc_a : (!oe_b_n ? adc_b : 24'bz);
            hapgate_ice40_hx8k #(
                .CLK_HZ(CLK_HZ), .SERIAL_MUL(SERIAL_MUL), .ASIN_FILE(ASIN_FILE),
                .SINE_FILE(SINE_FILE)
            ) u_board (
                .clk(clk), .rst_n(rst_n), .adc_strobe(adc_strobe), .adc_d(adc_d),
                .adc_oe_a_n(oe_a_n), .adc_oe_b_n(oe_b_n), .enc_index(enc_index),
                .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
                .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n),
                .bus_addr(bus_addr), .bus_data(bus_data), .bus_ready(bus_ready), .irq(irq)
            );
            assign bus_data_oe = u_board.data_oe;
        end else begin : g_ecp5
            hapgate_ecp5_evn #(
                .CLK_HZ(CLK_HZ), .USE_PLL(USE_PLL), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE)
            ) u_board (
                .clk(clk), .rst_n(rst_n), .adc_strobe(adc_strobe), .adc_a(adc_a),
                .adc_b(adc_b), .enc_index(enc_index),
                .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
                .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n),
                .bus_addr(bus_addr), .bus_data(bus_data), .bus_ready(bus_ready), .irq(irq)
            );
            assign bus_data_oe = u_board.data_oe;
        end
    endgenerate
endmodule

`default_nettype wire
