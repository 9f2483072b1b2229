// SPDX-License-Identifier: Apache-2.0
// The bridge from the SoC's data bus to the FPGA register file: it drives hapgate_top's DSP bus
// pins (rtl/bus/emif_slave.v) from inside the FPGA, on the same clock, as the DSP would: chip
// select and a strobe held until the slave's ready, then all high for RECOVER clocks. One
// access at a time; a request during the recovery waits. Timing: rtl/soc/README.md.
`timescale 1ns / 1ps
`default_nettype none

module hg_emif_master #(
    parameter integer ADDR_BITS = 8,   // word-address lines of the DSP bus
    parameter integer TIMEOUT   = 31   // clocks without ready before an access fails (s_err)
) (
    input  wire                 clk,
    input  wire                 rst,
    // SoC side: s_req for one clock starts an access; s_ack or s_err for one clock ends it
    input  wire                 s_req,
    input  wire                 s_we,
    input  wire [ADDR_BITS-1:0] s_addr,
    input  wire [31:0]          s_wdata,
    output reg  [31:0]          s_rdata,   // read data, valid with s_ack
    output reg                  s_ack,
    output reg                  s_err,
    // the DSP bus pins of hapgate_top
    output reg                  bus_ce_n,
    output reg                  bus_re_n,
    output reg                  bus_we_n,
    output reg  [ADDR_BITS-1:0] bus_addr,
    output reg  [31:0]          bus_wdata,
    input  wire [31:0]          bus_rdata,  // hapgate_top's bus_data_out
    input  wire                 bus_ready
);
    // Recovery: emif_slave's served flag falls two synchroniser clocks plus one after the
    // strobes rise, and ready would show it on a strobe that falls earlier (rtl/bus/README.md:
    // recovery >= 3 clocks).
    localparam integer RECOVER = 3;
    localparam integer TW      = $clog2(TIMEOUT + 1);
    localparam [1:0] S_IDLE = 2'd0, S_STROBE = 2'd1, S_RECOVER = 2'd2;
    localparam integer REC_LAST_I = RECOVER - 1;
    localparam integer TO_I       = TIMEOUT;
    localparam [TW-1:0] REC_LAST  = REC_LAST_I[TW-1:0];
    localparam [TW-1:0] TO_LAST   = TO_I[TW-1:0];

    generate
        if (TIMEOUT < 8 || TIMEOUT > 1023) begin : g_bad_timeout
            hg_emif_master_TIMEOUT_must_be_8_to_1023 u_stop ();
        end
    endgenerate

    reg [1:0]           state;
    reg [TW-1:0]        cnt;
    reg                 pend;       // a request taken while not idle
    reg                 pend_we;
    reg [ADDR_BITS-1:0] pend_addr;
    reg [31:0]          pend_wdata;

    wire go = (state == S_IDLE) && (s_req || pend);

    always @(posedge clk) begin
        if (s_req) begin            // datapath: not reset
            pend_we    <= s_we;
            pend_addr  <= s_addr;
            pend_wdata <= s_wdata;
        end
        if (go) begin
            bus_addr  <= s_req ? s_addr : pend_addr;
            bus_wdata <= s_req ? s_wdata : pend_wdata;
        end
        if (state == S_STROBE && bus_ready)
            s_rdata <= bus_rdata;
    end

    always @(posedge clk) begin
        if (rst) begin
            state    <= S_IDLE;
            cnt      <= {TW{1'b0}};
            pend     <= 1'b0;
            bus_ce_n <= 1'b1;
            bus_re_n <= 1'b1;
            bus_we_n <= 1'b1;
            s_ack    <= 1'b0;
            s_err    <= 1'b0;
        end else begin
            s_ack <= 1'b0;
            s_err <= 1'b0;
            if (s_req && !go)
                pend <= 1'b1;
            case (state)
                S_IDLE: begin
                    if (go) begin
                        pend     <= 1'b0;
                        bus_ce_n <= 1'b0;
                        bus_re_n <= s_req ? s_we : pend_we;
                        bus_we_n <= s_req ? ~s_we : ~pend_we;
                        cnt      <= TO_LAST;
                        state    <= S_STROBE;
                    end
                end
                S_STROBE: begin
                    if (bus_ready || cnt == {TW{1'b0}}) begin
                        s_ack    <= bus_ready;
                        s_err    <= ~bus_ready;
                        bus_ce_n <= 1'b1;
                        bus_re_n <= 1'b1;
                        bus_we_n <= 1'b1;
                        cnt      <= REC_LAST;
                        state    <= S_RECOVER;
                    end else begin
                        cnt <= cnt - 1'b1;
                    end
                end
                default: begin      // S_RECOVER
                    if (cnt == {TW{1'b0}})
                        state <= S_IDLE;
                    else
                        cnt <= cnt - 1'b1;
                end
            endcase
        end
    end
endmodule

`default_nettype wire
