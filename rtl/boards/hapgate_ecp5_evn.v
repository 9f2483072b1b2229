// SPDX-License-Identifier: Apache-2.0
// Board top for Lattice's ECP5-5G evaluation board (LFE5UM5G-85F): the 12 MHz board clock
// multiplied to CLK_HZ by an EHXPLLL (USE_PLL=0 bypasses it for simulation: CLK_HZ is then the
// input clock), reset from the active-low button and the PLL lock, synchronised (held >= 4
// clocks), the DSP data bus as real bidirectional pins. The headers carry the paper's parallel
// buses directly (no adapter). Pins: ecp5_evn.lpf.
`timescale 1ns / 1ps
`default_nettype none

module hapgate_ecp5_evn #(
    parameter integer CLK_HZ    = 48_000_000, // core clock: the PLL output (a multiple of 1 MHz)
    parameter integer USE_PLL   = 1,          // 0: simulation bypass, the core runs on clk
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
    // 12 MHz * CLKFB_DIV / CLKI_DIV = CLK_HZ; VCO = CLK_HZ * CLKOP_DIV in 400..800 MHz.
    localparam integer IN_HZ     = 12_000_000;
    localparam integer FB_DIV    = CLK_HZ / IN_HZ;
    localparam integer OP_DIV    = 600_000_000 / CLK_HZ;
    localparam integer VCO_HZ    = CLK_HZ * OP_DIV;

    wire core_clk, locked;
    generate
        if (USE_PLL != 0) begin : g_pll
            if (FB_DIV * IN_HZ != CLK_HZ || VCO_HZ < 400_000_000 || VCO_HZ > 800_000_000) begin : g_bad_pll
                hapgate_ecp5_evn_CLK_HZ_must_be_a_multiple_of_12_MHz_from_36_to_200_MHz u_stop ();
            end
            (* FREQUENCY_PIN_CLKI = "12", ICP_CURRENT = "12", LPF_RESISTOR = "8", MFG_ENABLE_FILTEROPAMP = "1", MFG_GMCREF_SEL = "2" *)
            EHXPLLL #(
                .PLLRST_ENA("DISABLED"), .INTFB_WAKE("DISABLED"), .STDBY_ENABLE("DISABLED"),
                .DPHASE_SOURCE("DISABLED"), .OUTDIVIDER_MUXA("DIVA"), .OUTDIVIDER_MUXB("DIVB"),
                .OUTDIVIDER_MUXC("DIVC"), .OUTDIVIDER_MUXD("DIVD"),
                .CLKI_DIV(1), .CLKOP_ENABLE("ENABLED"), .CLKOP_DIV(OP_DIV),
                .CLKOP_CPHASE(OP_DIV - 1), .CLKOP_FPHASE(0), .FEEDBK_PATH("CLKOP"),
                .CLKFB_DIV(FB_DIV)
            ) u_pll (
                .RST(1'b0), .STDBY(1'b0), .CLKI(clk), .CLKOP(core_clk), .CLKFB(core_clk),
                .PHASESEL0(1'b0), .PHASESEL1(1'b0), .PHASEDIR(1'b1),
                .PHASESTEP(1'b1), .PHASELOADREG(1'b1), .PLLWAKESYNC(1'b0), .ENCLKOP(1'b0),
                .LOCK(locked)
            );
        end else begin : g_no_pll
            assign core_clk = clk;
            assign locked   = 1'b1;
        end
    endgenerate

    // Reset: asserted asynchronously by the button or a PLL out of lock, released synchronously
    // after 4 core clocks.
    wire      arst_n = rst_n & locked;
    reg [3:0] rst_pipe;
    always @(posedge core_clk or negedge arst_n) begin
        if (!arst_n) rst_pipe <= 4'hf;
        else         rst_pipe <= {rst_pipe[2:0], 1'b0};
    end
    wire rst = rst_pipe[3];

    wire [31:0] data_out;
    wire        data_oe;
    assign bus_data = data_oe ? data_out : 32'bz;

    hapgate_top #(
        .CLK_HZ(CLK_HZ), .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE)
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
