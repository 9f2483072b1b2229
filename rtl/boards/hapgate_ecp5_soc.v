// SPDX-License-Identifier: Apache-2.0
// Board top for the whole controller on Lattice's ECP5-5G evaluation board (LFE5UM5G-85F):
// hapgate_soc_top (the soft CPU running the firmware, and hapgate_top) on the PLL's clock with
// the board's reset (ecp5_pll_reset), the ADC and DAC buses on hapgate_ecp5_evn's pins, no DSP
// bus. The PC link (the SoC's UART) is on two pairs of pins at once: the FT2232H's port B
// (after the board change in rtl/boards/README.md) and two header pins for a 3.3 V USB-UART
// adapter. Pins: ecp5_soc.lpf.
`timescale 1ns / 1ps
`default_nettype none

module hapgate_ecp5_soc #(
    parameter integer CLK_HZ    = 48_000_000,      // core clock: the PLL output (a multiple of 12 MHz)
    parameter integer USE_PLL   = 1,               // 0: simulation bypass, the core runs on clk
    parameter         ASIN_FILE = "asin.hex",      // arcsine table (hapgate.golden.interp.write_lut)
    parameter         SINE_FILE = "sine.hex",      // sine ROM (hapgate.golden.sine.write_rom)
    parameter integer BAUD      = 1_000_000,       // the PC link's rate
    parameter         FW_FILE   = "hapgate-fw.hex" // the firmware image (make -C dsp-fw riscv)
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
    input  wire        uart_rx,        // FT2232H port B TXD -> FPGA (idle high, pulled up)
    output wire        uart_tx,        // FPGA -> FT2232H port B RXD
    input  wire        uart_rx_hdr,    // header pin: the adapter's TXD (idle high, pulled up)
    output wire        uart_tx_hdr     // header pin: to the adapter's RXD
);
    // the PLL and the reset (shared with hapgate_ecp5_evn)
    wire core_clk, rst;
    ecp5_pll_reset #(.CLK_HZ(CLK_HZ), .USE_PLL(USE_PLL)) u_clkrst (
        .clk_in(clk), .rst_n(rst_n), .clk(core_clk), .rst(rst)
    );

    // Both UART connections at once: a line that is not connected idles high (its pull-up), so
    // the receiver sees the one in use; the reply goes out on both.
    wire rx = uart_rx & uart_rx_hdr;
    wire tx;
    assign uart_tx     = tx;
    assign uart_tx_hdr = tx;

    hapgate_soc_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE), .BAUD(BAUD),
        .FW_FILE(FW_FILE)
    ) u_soc (
        .clk(core_clk), .rst(rst),
        .adc_strobe(adc_strobe), .adc_clk(adc_clk), .adc_a(adc_a), .adc_b(adc_b),
        .enc_index(enc_index), .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .uart_rx(rx), .uart_tx(tx)
    );
endmodule

`default_nettype wire
