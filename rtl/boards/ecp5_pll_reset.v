// SPDX-License-Identifier: Apache-2.0
// The ECP5 boards' clock and reset: the 12 MHz board clock multiplied to CLK_HZ by an EHXPLLL
// (USE_PLL=0 bypasses it for simulation: CLK_HZ is then the input clock), and the core's reset,
// asserted asynchronously by the active-low button or a PLL out of lock and released
// synchronously after 4 core clocks. Shared by hapgate_ecp5_evn and hapgate_ecp5_soc.
`timescale 1ns / 1ps
`default_nettype none

module ecp5_pll_reset #(
    parameter integer CLK_HZ  = 48_000_000, // core clock: the PLL output (a multiple of 12 MHz)
    parameter integer USE_PLL = 1           // 0: simulation bypass, the core runs on clk_in
) (
    input  wire clk_in,   // 12 MHz board clock
    input  wire rst_n,    // push button, active low, asynchronous
    output wire clk,      // the core clock
    output wire rst       // the core's reset, synchronous to clk, active high
);
    // 12 MHz * CLKFB_DIV / CLKI_DIV = CLK_HZ; VCO = CLK_HZ * CLKOP_DIV in 400..800 MHz.
    localparam integer IN_HZ  = 12_000_000;
    localparam integer FB_DIV = CLK_HZ / IN_HZ;
    localparam integer OP_DIV = 600_000_000 / CLK_HZ;
    localparam integer VCO_HZ = CLK_HZ * OP_DIV;

    wire locked;
    generate
        if (USE_PLL != 0) begin : g_pll
            if (FB_DIV * IN_HZ != CLK_HZ || VCO_HZ < 400_000_000 || VCO_HZ > 800_000_000) begin : g_bad_pll
                ecp5_pll_reset_CLK_HZ_must_be_a_multiple_of_12_MHz_from_36_to_200_MHz u_stop ();
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
                .RST(1'b0), .STDBY(1'b0), .CLKI(clk_in), .CLKOP(clk), .CLKFB(clk),
                .PHASESEL0(1'b0), .PHASESEL1(1'b0), .PHASEDIR(1'b1),
                .PHASESTEP(1'b1), .PHASELOADREG(1'b1), .PLLWAKESYNC(1'b0), .ENCLKOP(1'b0),
                .LOCK(locked)
            );
        end else begin : g_no_pll
            assign clk    = clk_in;
            assign locked = 1'b1;
        end
    endgenerate

    // Reset: asserted asynchronously by the button or a PLL out of lock, released synchronously
    // after 4 core clocks.
    wire      arst_n = rst_n & locked;
    reg [3:0] rst_pipe;
    always @(posedge clk or negedge arst_n) begin
        if (!arst_n) rst_pipe <= 4'hf;
        else         rst_pipe <= {rst_pipe[2:0], 1'b0};
    end
    assign rst = rst_pipe[3];
endmodule

`default_nettype wire
