// SPDX-License-Identifier: Apache-2.0
// The whole controller in one FPGA: hapgate_top (interpolators, commutation, DAC scheduler,
// register file; unchanged) with its DSP bus driven by hg_soc, whose soft CPU runs the firmware,
// and the PC link on the SoC's UART. The ADC and DAC pins are hapgate_top's; the bus is internal.
// Why hapgate_top is reused whole: rtl/soc/README.md.
`timescale 1ns / 1ps
`default_nettype none

module hapgate_soc_top #(
    parameter integer CLK_HZ    = 48_000_000,       // clock: a multiple of 1 MHz and of 1 MSPS
    parameter         ASIN_FILE = "asin.hex",       // arcsine table (hapgate.golden.interp.write_lut)
    parameter         SINE_FILE = "sine.hex",       // sine ROM (hapgate.golden.sine.write_rom)
    parameter integer BAUD      = 1_000_000,        // the UART's rate
    parameter integer RAM_LOG2  = 17,               // the SoC's RAM, log2 bytes
    parameter         FW_FILE   = "hapgate-fw.hex"  // the firmware image (make -C dsp-fw riscv)
) (
    input  wire        clk,
    input  wire        rst,
    // ADCs and encoders, DACs: hapgate_top's
    output wire        adc_strobe,
    output wire        adc_clk,
    input  wire [23:0] adc_a,
    input  wire [23:0] adc_b,
    input  wire [2:0]  enc_index,
    output wire [13:0] dac_data,
    output wire [2:0]  dac_addr,
    output wire        dac_wr_n,
    // the PC link (8N1, idle high)
    input  wire        uart_rx,
    output wire        uart_tx
);
    wire        bus_ce_n, bus_re_n, bus_we_n, bus_ready, bus_oe, irq;
    wire [7:0]  bus_addr;
    wire [31:0] bus_wdata, bus_rdata;

    hg_soc #(
        .CLK_HZ(CLK_HZ), .BAUD(BAUD), .RAM_LOG2(RAM_LOG2), .FW_FILE(FW_FILE), .BUS_ADDR_BITS(8)
    ) u_soc (
        .clk(clk), .rst(rst), .uart_rx(uart_rx), .uart_tx(uart_tx), .irq_tick(irq),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_wdata(bus_wdata), .bus_rdata(bus_rdata), .bus_ready(bus_ready)
    );

    hapgate_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE), .BUS_ADDR_BITS(8)
    ) u_top (
        .clk(clk), .rst(rst),
        .adc_strobe(adc_strobe), .adc_clk(adc_clk), .adc_a(adc_a), .adc_b(adc_b),
        .enc_index(enc_index), .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_wdata), .bus_data_out(bus_rdata), .bus_data_oe(bus_oe),
        .bus_ready(bus_ready), .irq(irq)
    );
    // the data pins' enable: the bridge reads only with ready, when the slave drives them
    wire unused_oe = bus_oe;
endmodule

`default_nettype wire
