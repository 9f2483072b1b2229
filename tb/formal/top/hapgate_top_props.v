// SPDX-License-Identifier: Apache-2.0
// Formal property wrapper of the safety path of rtl/top/hapgate_top.v (SymbiYosys,
// tb/formal/README.md): the commutator, its DAC scheduler and the DAC output stage, with the
// register file's and the interpolators' outputs cut (the .sby script drives them from $anyseq:
// ANY behaviour of watchdog, enables, faults, torques, modes and positions, changing at any
// clock). Proven for every motor m and its channels 2m, 2m+1:
//  - within the bound: once the watchdog has expired, drive is disabled (globally or for that
//    axis) or the axis has a fault, continuously for FRAME_CLOCKS + 3 clocks, the DAC holds
//    zero torque on that motor's two channels (the last word loaded into each is ZERO);
//  - never a non-zero code without enable: a DAC load with a non-zero word was decided in a
//    clock in which that motor was enabled (global and axis enable, no watchdog, no fault).
// The decision clock is the one before the commutator's own strobe falls (rtl/top/README.md:
// a load in progress completes unchanged).
`timescale 1ns / 1ps
`default_nettype none

module hapgate_top_formal #(
    parameter integer CLK_HZ = 2_000_000
) (
    input wire        clk,
    input wire        rst,
    input wire [23:0] adc_a,
    input wire [23:0] adc_b,
    input wire [2:0]  enc_index,
    input wire        bus_ce_n,
    input wire        bus_re_n,
    input wire        bus_we_n,
    input wire [7:0]  bus_addr,
    input wire [31:0] bus_data_in
);
    localparam integer DAC_BITS     = 14;
    localparam integer FRAME_CLOCKS = CLK_HZ / 1000 * 16000 / 1_000_000;
    localparam integer BOUND        = FRAME_CLOCKS + 3;
    localparam [DAC_BITS-1:0] ZERO  = {DAC_BITS{1'b0}};

    wire [DAC_BITS-1:0] dac_data;
    wire [2:0]          dac_addr;
    wire                dac_wr_n, adc_strobe, bus_data_oe, bus_ready, irq;
    wire [31:0]         bus_data_out;

    // CAPTURE 0: the raw-ADC capture buffer reads the ADC and answers the bus only, with no
    // path to the torque, mode or DAC (rtl/capture/, its own tests); left out, its RAM does not
    // enter the BMC state
    hapgate_top #(.CLK_HZ(CLK_HZ), .ASIN_FILE("asin.hex"), .SINE_FILE("sine.hex"),
                  .ADC_CLK(0), .CAPTURE(0)) dut (  // 2 clocks per sample: no ADC clock (rtl/top)
        .clk(clk), .rst(rst), .adc_strobe(adc_strobe), .adc_a(adc_a), .adc_b(adc_b),
        .enc_index(enc_index), .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_data_in), .bus_data_out(bus_data_out), .bus_data_oe(bus_data_oe),
        .bus_ready(bus_ready), .irq(irq)
    );

`ifdef FORMAL
    // the cut nets (free after `cutpoint`), seen through connect -set in the .sby script
    (* keep *) wire       peek_wdog, peek_global_en, peek_c_wr_n;
    (* keep *) wire [2:0] peek_axis_en, peek_fault, peek_c_addr;

    reg init = 1'b1, init_q = 1'b1;
    always @(posedge clk) begin
        init   <= 1'b0;
        init_q <= init;
    end
    always @(*) assume (rst == init);        // one reset, then run

    wire [2:0] kill = {3{peek_wdog | ~peek_global_en}} | peek_fault | ~peek_axis_en;

    // clocks each motor has been killed without a break (saturating)
    reg [7:0] killed [0:2];
    integer m;
    initial for (m = 0; m < 3; m = m + 1) killed[m] = 8'd0;
    always @(posedge clk)
        for (m = 0; m < 3; m = m + 1)
            killed[m] <= !kill[m] ? 8'd0 : (killed[m] == 8'hff ? killed[m] : killed[m] + 8'd1);

    // the DAC: the word last loaded into each channel (zero from reset)
    reg                wr_q = 1'b1, c_wr_q = 1'b1;
    reg [DAC_BITS-1:0] shadow [0:7];
    integer c;
    initial for (c = 0; c < 8; c = c + 1) shadow[c] = ZERO;
    wire load = dac_wr_n && !wr_q;
    always @(posedge clk) begin
        wr_q   <= dac_wr_n;
        c_wr_q <= peek_c_wr_n;
        if (rst) begin
            for (c = 0; c < 8; c = c + 1) shadow[c] <= ZERO;
        end else if (load) begin
            shadow[dac_addr] <= dac_data;
        end
    end

    // the decision for the load in progress: the motor's kill in the clock before the
    // commutator's strobe fell
    reg  [2:0] kill_q = 3'b111;
    reg        held_kill = 1'b1;
    wire [1:0] motor = (peek_c_addr[2:1] == 2'd3) ? 2'd0 : peek_c_addr[2:1];
    always @(posedge clk) begin
        kill_q <= kill;
        if (!peek_c_wr_n && c_wr_q) held_kill <= kill_q[motor];
    end

    always @(*) begin
        if (!init) begin
            for (m = 0; m < 3; m = m + 1)
                if (killed[m] >= BOUND)
                    assert (shadow[2*m] == ZERO && shadow[2*m+1] == ZERO);
            // (not the strobe the reset edge ends: at power-up its word is whatever the pins held)
            if (load && !init_q && dac_data != ZERO) assert (!held_kill);
        end
    end
    // non-vacuity (task cover): a driven load, and a motor killed for the whole bound while
    // its channels had been driven non-zero before
    reg [2:0] drove = 3'b000;
    always @(posedge clk) if (load && dac_data != ZERO && !init_q) drove[dac_addr[2:1]] <= 1'b1;
    always @(*) begin
        if (!init) begin
            cover (load && !init_q && dac_data != ZERO);
            cover (drove[0] && killed[0] == BOUND);
        end
    end
`endif
endmodule

`default_nettype wire
