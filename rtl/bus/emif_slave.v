// SPDX-License-Identifier: Apache-2.0
// Asynchronous SRAM-like bus slave modelled on the TI C6000 EMIF asynchronous mode: chip select,
// read and write strobes (active low), word address, 32-bit data, ready. The three control lines
// are synchronised (2 FF) into clk; an access is served only if its strobe is still low at the
// capture edge, else it is dropped and reported (m_proto_err). Timing: rtl/bus/README.md.
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module emif_slave #(
    parameter integer ADDR_BITS = 8   // word-address lines decoded (the register map spans 64)
) (
    input  wire                 clk,
    input  wire                 rst,
    // DSP side (asynchronous to clk)
    input  wire                 s_bus_ce_n,      // chip select
    input  wire                 s_bus_re_n,      // read strobe (ARE)
    input  wire                 s_bus_we_n,      // write strobe (AWE)
    input  wire [ADDR_BITS-1:0] s_bus_addr,      // word address
    input  wire [31:0]          s_bus_data_in,
    output reg  [31:0]          s_bus_data_out,
    output wire                 s_bus_data_oe,   // drive the data pins (only while CE and RE are low)
    output wire                 s_bus_ready,     // the access has been served (while its strobe is low)
    // register side (clk domain)
    output wire [ADDR_BITS-1:0] m_raddr,         // read address for m_rdata (the pins, stable by rule)
    input  wire [31:0]          m_rdata,         // combinational read data of m_raddr
    output wire                 m_req,           // one clock: a served access (write: apply it)
    output reg                  m_we,
    output reg  [ADDR_BITS-1:0] m_addr,
    output reg  [31:0]          m_wdata,
    output wire                 m_proto_err      // one clock: an access was dropped
    `HG_SIM_PORTS(1)  // simulation only (rtl/include/hg_sim.vh): the bus clock
);
    generate
        if (ADDR_BITS < 6 || ADDR_BITS > 30) begin : g_bad_addr_bits
            emif_slave_ADDR_BITS_must_be_6_to_30 u_stop ();
        end
    endgenerate

    wire clk_g = `HG_SIM_CLK(clk, 0);   // every register here

    // ---------------------------------------------------------------- synchronisers
    // stage 0 and 1 are the synchroniser; stage 2 remembers the previous synchronised value.
    reg [2:0] ce_s, re_s, we_s;  // active-high "asserted" samples (inverted pins)

    always @(posedge clk_g) begin
        if (rst) begin
            ce_s <= 3'b000;
            re_s <= 3'b000;
            we_s <= 3'b000;
        end else begin
            ce_s <= {ce_s[1:0], ~s_bus_ce_n};
            re_s <= {re_s[1:0], ~s_bus_re_n};
            we_s <= {we_s[1:0], ~s_bus_we_n};
        end
    end

    wire rd1 = ce_s[1] & re_s[1];
    wire wr1 = ce_s[1] & we_s[1];
    wire rd2 = ce_s[2] & re_s[2];
    wire wr2 = ce_s[2] & we_s[2];
    wire start_rd = rd1 & ~rd2 & ~wr1;  // a strobe just seen asserted (synchronised)
    wire start_wr = wr1 & ~wr2 & ~rd1;
    wire start_both = (rd1 & ~rd2 & wr1) | (wr1 & ~wr2 & rd1);

    // ---------------------------------------------------------------- capture and check
    // Capture edge: the clock after the synchronised strobe is first seen. The access is served
    // if stage 0 (the strobe sampled AT the capture edge) still shows the strobe asserted.
    reg pend;        // captured, waiting for the check
    reg pend_we;
    reg both_q;      // read and write strobes asserted together: a protocol violation
    reg served_q;    // for s_bus_ready and the read-data output enable

    assign m_raddr = s_bus_addr;

    always @(posedge clk_g) begin
        if (start_rd | start_wr) begin  // datapath: not reset
            m_addr  <= s_bus_addr;
            m_wdata <= s_bus_data_in;
        end
        if (start_rd)
            s_bus_data_out <= m_rdata;
    end

    wire still = pend_we ? (ce_s[0] & we_s[0]) : (ce_s[0] & re_s[0]);
    assign m_req       = pend & still;
    assign m_proto_err = (pend & ~still) | both_q;

    always @(posedge clk_g) begin
        if (rst) begin
            pend     <= 1'b0;
            pend_we  <= 1'b0;
            m_we     <= 1'b0;
            both_q   <= 1'b0;
            served_q <= 1'b0;
        end else begin
            pend    <= start_rd | start_wr;
            both_q  <= start_both;
            if (start_rd | start_wr) begin
                pend_we <= start_wr;
                m_we    <= start_wr;
            end
            if (m_req)
                served_q <= 1'b1;
            else if (!(rd1 | wr1))
                served_q <= 1'b0;
        end
    end

    // Output enable and ready follow the pins combinationally, like an SRAM's OE#: the data
    // drivers turn off as soon as CE or RE rises.
    wire rd_pin = ~s_bus_ce_n & ~s_bus_re_n;
    wire wr_pin = ~s_bus_ce_n & ~s_bus_we_n;
    assign s_bus_data_oe = rd_pin & (served_q | (pend & ~pend_we));
    assign s_bus_ready   = (rd_pin | wr_pin) & served_q;

    // simulation only: the bus clock's enable (reset, a synchroniser stage unlike its pin, a
    // captured access, a protocol error, a ready to drop; tb/native/device/README.md)
    `HG_SIM_EN((rst | ce_s != {3{~s_bus_ce_n}} | re_s != {3{~s_bus_re_n}} | we_s != {3{~s_bus_we_n}} | pend | both_q | (served_q & ~(rd1 | wr1))))
endmodule

`default_nettype wire
