// SPDX-License-Identifier: Apache-2.0
// Board wrapper for an iCE40-HX8K (CT256) lab board, e.g. Lattice's iCE40-HX8K breakout: the
// 12 MHz oscillator as the FPGA clock, an active-low reset button synchronised into it (reset is
// held for at least 4 clocks after release), and the DSP data bus as real bidirectional pins.
// Everything else passes straight to hapgate_top. Place and route: `make synth` (hapgate pnr).
`timescale 1ns / 1ps
`default_nettype none

module hapgate_ice40_hx8k #(
    parameter integer CLK_HZ    = 12_000_000, // the board oscillator
    parameter         ASIN_FILE = "asin.hex", // arcsine table (hapgate.interp.write_lut)
    parameter         SINE_FILE = "sine.hex"  // sine ROM (hapgate.sine.write_rom)
) (
    input  wire        clk,
    input  wire        rst_n,          // push button, active low, asynchronous
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
    inout  wire [31:0] bus_data,
    output wire        bus_ready,
    output wire        irq
);
    // Reset: asserted asynchronously by the button, released synchronously after 4 clocks.
    reg [3:0] rst_pipe;
    always @(posedge clk or negedge rst_n) begin
        if (!rst_n) rst_pipe <= 4'hf;
        else        rst_pipe <= {rst_pipe[2:0], 1'b0};
    end
    wire rst = rst_pipe[3];

    wire [31:0] data_out;
    wire        data_oe;
    assign bus_data = data_oe ? data_out : 32'bz;

    hapgate_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE)
    ) u_top (
        .clk(clk), .rst(rst),
        .adc_strobe(adc_strobe), .adc_a(adc_a), .adc_b(adc_b), .enc_index(enc_index),
        .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_data), .bus_data_out(data_out), .bus_data_oe(data_oe),
        .bus_ready(bus_ready), .irq(irq)
    );
endmodule

`default_nettype wire
