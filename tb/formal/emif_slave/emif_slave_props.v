// SPDX-License-Identifier: Apache-2.0
// Formal property wrapper of rtl/bus/emif_slave.v (SymbiYosys, tb/formal/README.md). The bus
// pins, m_rdata and rst are free inputs that may change at every clock (the synchronisers see
// each value; metastability is not modelled). Proven for ANY pin behaviour: no ready without a
// strobe, output enable only inside a read strobe, never more writes applied than write strobes
// given. Under the documented protocol (`define PROTOCOL: strobe low >= 5 clocks, high >= 3,
// address and data stable during the strobe, never both strobes): every write strobe is applied
// exactly once, with its address and data, before the strobe ends; every read strobe sees
// ready and output enable, with data that do not change while driven.
`timescale 1ns / 1ps
`default_nettype none

module emif_slave_formal (
    input wire        clk,
    input wire        rst,
    input wire        ce_n,
    input wire        re_n,
    input wire        we_n,
    input wire [5:0]  addr,
    input wire [31:0] data_in,
    input wire [31:0] rdata
);
    wire [31:0] data_out;
    wire        oe, ready, m_req, m_we, proto_err;
    wire [5:0]  m_raddr, m_addr;
    wire [31:0] m_wdata;

    emif_slave #(.ADDR_BITS(6)) dut (
        .clk(clk), .rst(rst), .s_bus_ce_n(ce_n), .s_bus_re_n(re_n), .s_bus_we_n(we_n),
        .s_bus_addr(addr), .s_bus_data_in(data_in), .s_bus_data_out(data_out),
        .s_bus_data_oe(oe), .s_bus_ready(ready), .m_raddr(m_raddr), .m_rdata(rdata),
        .m_req(m_req), .m_we(m_we), .m_addr(m_addr), .m_wdata(m_wdata), .m_proto_err(proto_err)
    );

`ifdef FORMAL
    // reset in the first clock; afterwards rst is free (a reset at any time is allowed)
    reg init = 1'b1;
    always @(posedge clk) init <= 1'b0;
    always @(*) if (init) assume(rst);

    wire rd_pin = !ce_n && !re_n;
    wire wr_pin = !ce_n && !we_n;
    reg  rd_pin_q = 1'b0, wr_pin_q = 1'b0;
    always @(posedge clk) begin
        rd_pin_q <= rd_pin;
        wr_pin_q <= wr_pin;
    end
    wire wr_start = wr_pin && !wr_pin_q;
    wire wr_end   = !wr_pin && wr_pin_q;
    wire rd_start = rd_pin && !rd_pin_q;
    wire rd_end   = !rd_pin && rd_pin_q;
    wire commit   = m_req && m_we;

    // ---- for any pin behaviour
    always @(*) begin
        if (!init) begin
            assert (!ready || rd_pin || wr_pin);   // no reply without a strobe
            assert (!oe || rd_pin);                // data driven only inside a read strobe
        end
    end

    // write strobes given minus writes applied (saturating high: can only raise alarms)
    reg [3:0] owed = 4'd0;
    always @(posedge clk) begin
        if (rst) owed <= {3'd0, wr_pin};  // a strobe still low at reset is served as a new one
        else case ({wr_start && owed != 4'd15, commit})
            2'b10:   owed <= owed + 4'd1;
            2'b01:   owed <= owed - 4'd1;
            default: owed <= owed;
        endcase
    end
    // a write applied with no strobe owed would be a doubled (or invented) write. With free pins
    // this is a bounded proof (task free_bmc): dropped strobes leave `owed` high, and k-induction
    // finds the unreachable start states of the counter; under the protocol it is proven below.
`ifdef COUNT
    always @(*) if (!init && commit) assert (owed != 4'd0);
`endif

`ifdef PROTOCOL
    // ---- the documented protocol (rtl/bus/README.md, "Bus timing")
    reg [3:0] low_n = 4'd0, high_n = 4'd15;   // clocks the strobe has been low / high
    wire any_pin = rd_pin || wr_pin;
    always @(posedge clk) begin
        low_n  <= any_pin ? ((low_n == 4'd15) ? low_n : low_n + 4'd1) : 4'd0;
        high_n <= any_pin ? 4'd0 : ((high_n == 4'd15) ? high_n : high_n + 4'd1);
    end
    reg [5:0]  ep_addr;
    reg [31:0] ep_data;
    always @(posedge clk) if (any_pin && !(rd_pin_q || wr_pin_q)) begin
        ep_addr <= addr;
        ep_data <= data_in;
    end
    always @(*) begin
        assume (!(rd_pin && wr_pin));                      // never both strobes
        if (rd_pin_q || wr_pin_q) begin                    // a strobe was low last clock
            if (low_n < 4'd5) assume (any_pin && (rd_pin == rd_pin_q));   // low >= 5 clocks
            if (any_pin) assume (rd_pin == rd_pin_q);      // one kind per strobe
        end
        if (any_pin && !(rd_pin_q || wr_pin_q)) assume (high_n >= 4'd3); // recovery >= 3
        if (any_pin && (rd_pin_q || wr_pin_q)) assume (addr == ep_addr && data_in == ep_data);
        if (init) assume (!any_pin);
    end
    // no reset during the checked stretch (a reset drops an access by design)
    always @(*) if (!init) assume (!rst);

    // every write strobe applied exactly once, with its address and data, before it ends
    // (applied 3 clocks after the strobe falls; low_n counts the clocks it has been low)
    always @(*) begin
        if (!init && wr_end) assert (owed == 4'd0);
        if (!init && commit) assert (owed == 4'd1 && m_addr == ep_addr && m_wdata == ep_data);
        // inductive strengthening (wrapper state only): nothing owed outside a write strobe,
        // at most one inside it, none from its 4th clock on
        if (!init && !wr_pin) assert (owed == 4'd0);
        if (!init && wr_pin) assert (owed <= 4'd1 && (low_n < 4'd4 || owed == 4'd0));
    end
    // every read strobe: ready and output enable before it ends, data stable while driven
    reg rd_ready = 1'b0, rd_oe = 1'b0;
    always @(posedge clk) begin
        if (rd_start) begin
            rd_ready <= ready;
            rd_oe    <= oe;
        end else if (rd_pin) begin
            rd_ready <= rd_ready | ready;
            rd_oe    <= rd_oe | oe;
        end
    end
    reg [31:0] data_q;
    reg        oe_q = 1'b0;
    always @(posedge clk) begin
        data_q <= data_out;
        oe_q   <= oe;
    end
    always @(*) begin
        if (!init && rd_end) assert (rd_ready && rd_oe);
        // ready (and, reading, the data drivers) from the 4th clock of the strobe on (README:
        // ready 3..4 T after the fall; with clock-synchronous pins: exactly 4)
        if (!init && rd_pin && low_n >= 4'd4) assert (ready && oe);
        if (!init && wr_pin && low_n >= 4'd4) assert (ready);
        if (!init && oe && oe_q) assert (data_out == data_q);
        if (!init) assert (!proto_err);                    // the protocol is never reported broken
    end
`endif
`endif
endmodule

`default_nettype wire
