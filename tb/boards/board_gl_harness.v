// SPDX-License-Identifier: Apache-2.0
// Gate-level simulation harness: board_harness (the board's RTL, driven through its pins by the
// whole-FPGA test) plus the board top's post-synthesis netlist (<top>_gl, Yosys synth_ice40 /
// synth_ecp5, simulated with Yosys's cell models) on the same pins. At every rising clock edge
// after the power-on reset every output pin of the netlist, and the data pins it resolves,
// must equal the RTL's wherever the RTL's is known (an unreset RTL register is X until its
// first load; the device's flip-flops power up at 0): the first difference stops the
// simulation ($fatal), so the test's model checks of the RTL hold for the netlist on the same
// run. Every input reaches both 1 ps after the test drives it: a change in the same time step
// as a clock edge (the test's asynchronous bus strobes, its ADC words written on the strobe's
// edge) would otherwise race the two models' flip-flops (the netlist's clock goes through more
// zero-delay cells). `define GL_HX8K or GL_ECP5.
`timescale 1ns / 1ps
`default_nettype none

module board_gl_harness #(
    parameter integer BOARD      = 0,
    parameter integer CLK_HZ     = 16_000_000,
    parameter integer SERIAL_MUL = 1,
    parameter integer USE_PLL    = 0,
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
    output wire        irq,
    output reg  [31:0] gl_checked      // clock edges compared (the test reads it at the end)
);
    wire #(0.001) rst_d      = rst;
    wire #(0.001) ce_d       = bus_ce_n;
    wire #(0.001) re_d       = bus_re_n;
    wire #(0.001) we_d       = bus_we_n;
    wire [7:0]  #(0.001) addr_d  = bus_addr;
    wire [31:0] #(0.001) wdata_d = bus_data_in;
    wire [23:0] #(0.001) a_d     = adc_a;
    wire [23:0] #(0.001) b_d     = adc_b;
    wire [2:0]  #(0.001) idx_d   = enc_index;

    board_harness #(
        .BOARD(BOARD), .CLK_HZ(CLK_HZ), .SERIAL_MUL(SERIAL_MUL), .USE_PLL(USE_PLL),
        .ASIN_FILE(ASIN_FILE), .SINE_FILE(SINE_FILE)
    ) u_rtl (
        .clk(clk), .rst(rst_d), .adc_strobe(adc_strobe), .adc_a(a_d), .adc_b(b_d),
        .enc_index(idx_d), .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(ce_d), .bus_re_n(re_d), .bus_we_n(we_d), .bus_addr(addr_d),
        .bus_data_in(wdata_d), .bus_data_out(bus_data_out), .bus_data_oe(bus_data_oe),
        .bus_ready(bus_ready), .irq(irq)
    );

    // the netlist on the same inputs; its data pins see the DSP whenever the RTL does not drive
    wire        g_strobe, g_wr_n, g_ready, g_irq;
    wire [13:0] g_data;
    wire [2:0]  g_addr;
    wire [31:0] g_bus;
    assign g_bus = bus_data_oe ? 32'bz : wdata_d;
    wire        rst_n = ~rst_d;
`ifdef GL_HX8K
    wire        g_oe_a_n, g_oe_b_n;
    wire [23:0] g_adc_d = !g_oe_a_n ? a_d : (!g_oe_b_n ? b_d : 24'bz);
    hapgate_ice40_hx8k_gl u_gate (
        .clk(clk), .rst_n(rst_n), .adc_strobe(g_strobe), .adc_d(g_adc_d),
        .adc_oe_a_n(g_oe_a_n), .adc_oe_b_n(g_oe_b_n), .enc_index(idx_d),
        .dac_data(g_data), .dac_addr(g_addr), .dac_wr_n(g_wr_n),
        .bus_ce_n(ce_d), .bus_re_n(re_d), .bus_we_n(we_d), .bus_addr(addr_d),
        .bus_data(g_bus), .bus_ready(g_ready), .irq(g_irq)
    );
    wire [1:0] g_extra = {g_oe_a_n, g_oe_b_n};
    wire [1:0] r_extra = {u_rtl.g_hx8k.oe_a_n, u_rtl.g_hx8k.oe_b_n};
`else
    hapgate_ecp5_evn_gl u_gate (
        .clk(clk), .rst_n(rst_n), .adc_strobe(g_strobe), .adc_a(a_d), .adc_b(b_d),
        .enc_index(idx_d), .dac_data(g_data), .dac_addr(g_addr), .dac_wr_n(g_wr_n),
        .bus_ce_n(ce_d), .bus_re_n(re_d), .bus_we_n(we_d), .bus_addr(addr_d),
        .bus_data(g_bus), .bus_ready(g_ready), .irq(g_irq)
    );
    wire [1:0] g_extra = 2'b00;
    wire [1:0] r_extra = 2'b00;
`endif

    wire [86:0] r_pins = {adc_strobe, dac_data, dac_addr, dac_wr_n, bus_ready, irq, r_extra,
                          bus_data_out, bus_data_oe ? bus_data_out : 32'd0};
    wire [86:0] g_pins = {g_strobe, g_data, g_addr, g_wr_n, g_ready, g_irq, g_extra,
                          g_bus, bus_data_oe ? g_bus : 32'd0};
    reg         armed;   // compare once both have left reset (the power-on reset is in both)
    reg         differ;
    integer     i;
    always @(*) begin
        differ = 1'b0;
        for (i = 0; i < 87; i = i + 1)
            if ((r_pins[i] === 1'b0 || r_pins[i] === 1'b1) && g_pins[i] !== r_pins[i])
                differ = 1'b1;
    end
    initial begin
        armed      = 1'b0;
        gl_checked = 32'd0;
    end
    always @(posedge clk) begin
        if (!rst_d) armed <= 1'b1;
        if (armed) begin
            if (differ) begin
                $display("netlist differs from the RTL at %0t: rtl %h gate %h", $time, r_pins,
                         g_pins);
                $fatal(1, "gate-level mismatch");
            end
            gl_checked <= gl_checked + 32'd1;
        end
    end
endmodule

`default_nettype wire
