// SPDX-License-Identifier: Apache-2.0
// Board top for Lattice's iCE40-HX8K breakout board (iCE40HX8K-CT256): the 12 MHz oscillator as
// the FPGA clock (no PLL), a power-on reset plus an active-low reset input synchronised into it
// (reset held >= 4 clocks after both), the DSP data bus as real bidirectional pins, the shift-add
// commutation multiplier (the HX8K has no DSP blocks) and the ADC pair adapter (adc_pair_mux):
// the four headers carry 108 usable pins, the paper's buses need 116. Pins: hx8k_breakout.pcf.
`timescale 1ns / 1ps
`default_nettype none

module hapgate_ice40_hx8k #(
    parameter integer CLK_HZ     = 12_000_000, // the board oscillator
    parameter integer SERIAL_MUL = 1,          // shift-add commutation multiplier (fit: no DSPs)
    parameter integer SQ_RAM     = 1,          // signal-loss squares from block RAM (fit)
    parameter integer HOLD_C     = 1,          // interpolators without stage-D copies (fit)
    parameter integer LATCH_RAM  = 1,          // frame-latched torques/limits in block RAM (fit)
    parameter integer CAPTURE    = 0,          // ADC capture buffer: off (fit: with it the logic
                                               // cells exceed the 75 % limit, 78.9 %)
    // the integrity countermeasures (hapgate_top; issue 38, `hapgate pnr --harden all`)
    parameter integer SEC_REGS   = 0,
    parameter integer SEC_COMM   = 0,
    parameter integer SEC_DAC    = 0,
    parameter integer SEC_TICK   = 0,
    parameter integer SEC_POS    = 0,
    parameter         ASIN_FILE  = "asin.hex", // arcsine table (hapgate.golden.interp.write_lut)
    parameter         SINE_FILE  = "sine.hex"  // sine ROM (hapgate.golden.sine.write_rom)
) (
    input  wire        clk,
    input  wire        rst_n,          // header pin with pull-up, active low, asynchronous
    output wire        adc_strobe,     // sample marker (one clock high per sample; test point)
    output wire        adc_clk,        // the converters' sample clock (CLK pins)
    input  wire [23:0] adc_d,          // A and B converters of each axis share 8 lines
    output wire        adc_oe_a_n,
    output wire        adc_oe_b_n,
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
    // Reset: the power-on counter (iCE40 registers start at their initial value after
    // configuration) and the pin assert it asynchronously; released synchronously 4 clocks later.
    reg [3:0] por;
    initial por = 4'h0;
    wire      por_done = &por;
    always @(posedge clk) begin
        if (!por_done) por <= por + 4'd1;
    end
    wire arst_n = rst_n & por_done;
    reg [3:0] rst_pipe;
    always @(posedge clk or negedge arst_n) begin
        if (!arst_n) rst_pipe <= 4'hf;
        else         rst_pipe <= {rst_pipe[2:0], 1'b0};
    end
    wire rst = rst_pipe[3];

    wire [31:0] data_out;
    wire        data_oe;
    assign bus_data = data_oe ? data_out : 32'bz;

    wire [23:0] adc_a, adc_b;
    wire [2:0]  index;
    adc_pair_mux #(.CLK_HZ(CLK_HZ), .SAMPLE_HZ(1_000_000)) u_adc (
        .clk(clk), .rst(rst), .strobe(adc_strobe), .pin_d(adc_d), .pin_index(enc_index),
        .pin_oe_a_n(adc_oe_a_n), .pin_oe_b_n(adc_oe_b_n), .core_a(adc_a), .core_b(adc_b),
        .core_index(index)
    );

    hapgate_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE), .SERIAL_MUL(SERIAL_MUL),
        .SQ_RAM(SQ_RAM), .HOLD_C(HOLD_C), .LATCH_RAM(LATCH_RAM), .CAPTURE(CAPTURE),
        .SEC_REGS(SEC_REGS), .SEC_COMM(SEC_COMM), .SEC_DAC(SEC_DAC), .SEC_TICK(SEC_TICK),
        .SEC_POS(SEC_POS),
        .ADC_CAPTURE_LEAD(1)   // adc_pair_mux takes the B words one clock before the core
    ) u_top (
        .clk(clk), .rst(rst),
        .adc_strobe(adc_strobe), .adc_clk(adc_clk), .adc_a(adc_a), .adc_b(adc_b), .enc_index(index),
        .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_data), .bus_data_out(data_out), .bus_data_oe(data_oe),
        .bus_ready(bus_ready), .irq(irq)
    );
endmodule

`default_nettype wire
