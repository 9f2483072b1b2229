// SPDX-License-Identifier: Apache-2.0
// The RISC-V machine timer of the SoC: mtime counts microseconds from reset (CLK_HZ / 10**6
// clocks each), and the timer interrupt is pending while mtime >= mtimecmp (reset: all ones,
// never). Four registers (word addresses): 0/1 mtime low/high, 2/3 mtimecmp low/high, all
// read/write.
`timescale 1ns / 1ps
`default_nettype none

module hg_mtimer #(
    parameter integer CLK_HZ = 48_000_000  // clock: a multiple of 1 MHz
) (
    input  wire        clk,
    input  wire        rst,
    // register access: s_req for one clock, s_rdata valid the clock after
    input  wire        s_req,
    input  wire        s_we,
    input  wire [1:0]  s_addr,
    input  wire [31:0] s_wdata,
    output reg  [31:0] s_rdata,
    output wire        irq             // machine timer interrupt (level)
);
    localparam integer PER_US = CLK_HZ / 1_000_000;
    localparam integer PW     = (PER_US > 1) ? $clog2(PER_US) : 1;
    localparam integer PLAST_I = PER_US - 1;
    localparam [PW-1:0] PLAST = PLAST_I[PW-1:0];

    generate
        if (CLK_HZ < 1_000_000 || CLK_HZ % 1_000_000 != 0) begin : g_bad_clk
            hg_mtimer_CLK_HZ_must_be_a_multiple_of_1MHz u_stop ();
        end
    endgenerate

    reg [PW-1:0] pre;
    reg [63:0]   mtime, mtimecmp;
    wire         wr = s_req & s_we;

    always @(posedge clk) begin
        if (rst) begin
            pre      <= {PW{1'b0}};
            mtime    <= 64'd0;
            mtimecmp <= {64{1'b1}};
        end else begin
            pre <= (pre == PLAST) ? {PW{1'b0}} : pre + 1'b1;
            if (pre == PLAST)
                mtime <= mtime + 64'd1;
            if (wr) begin
                case (s_addr)
                    2'd0: mtime[31:0]     <= s_wdata;
                    2'd1: mtime[63:32]    <= s_wdata;
                    2'd2: mtimecmp[31:0]  <= s_wdata;
                    default: mtimecmp[63:32] <= s_wdata;
                endcase
            end
        end
    end

    always @(posedge clk) begin
        if (s_req) begin
            case (s_addr)
                2'd0:    s_rdata <= mtime[31:0];
                2'd1:    s_rdata <= mtime[63:32];
                2'd2:    s_rdata <= mtimecmp[31:0];
                default: s_rdata <= mtimecmp[63:32];
            endcase
        end
    end

    assign irq = (mtime >= mtimecmp);
endmodule

`default_nettype wire
