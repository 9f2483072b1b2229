// SPDX-License-Identifier: Apache-2.0
// The SoC's UART: 8N1 at BAUD from CLK_HZ (one divisor for both directions), a receive FIFO of
// 2**RX_FIFO_LOG2 bytes and a one-byte transmit holding register. Three registers (word
// addresses): 0 data (read: pops the oldest received byte; write: queue a byte), 1 status,
// 2 BAUD (read-only). Layout and timing: rtl/soc/README.md.
`timescale 1ns / 1ps
`default_nettype none

module hg_uart #(
    parameter integer CLK_HZ       = 48_000_000, // clock
    parameter integer BAUD         = 1_000_000,  // bits per second (within 2 % of CLK_HZ / divisor)
    parameter integer RX_FIFO_LOG2 = 7           // receive FIFO 2**RX_FIFO_LOG2 bytes (2..8)
) (
    input  wire        clk,
    input  wire        rst,
    // register access: s_req for one clock, s_rdata valid the clock after
    input  wire        s_req,
    input  wire        s_we,
    input  wire [1:0]  s_addr,
    input  wire [31:0] s_wdata,
    output reg  [31:0] s_rdata,
    // the line (idle high)
    input  wire        rx,
    output reg         tx
);
    localparam integer DIV    = (CLK_HZ + BAUD / 2) / BAUD;  // clocks per bit, rounded
    localparam integer DW     = $clog2(DIV + 1);
    localparam integer DEPTH  = 1 << RX_FIFO_LOG2;
    localparam integer ERR_HZ = (CLK_HZ > DIV * BAUD) ? CLK_HZ - DIV * BAUD : DIV * BAUD - CLK_HZ;
    localparam integer DIV_LAST_I = DIV - 1;
    localparam integer DIV_HALF_I = DIV / 2 - 1;
    localparam [DW-1:0] DIV_LAST = DIV_LAST_I[DW-1:0];
    localparam [DW-1:0] DIV_HALF = DIV_HALF_I[DW-1:0];
    localparam [31:0]   BAUD_W   = BAUD;
    localparam [1:0] A_DATA = 2'd0, A_STATUS = 2'd1, A_BAUD = 2'd2;

    generate
        if (BAUD < 1 || DIV < 8 || ERR_HZ > CLK_HZ / 50) begin : g_bad_baud
            hg_uart_BAUD_needs_8_clocks_per_bit_and_a_divisor_within_2_percent u_stop ();
        end
        if (RX_FIFO_LOG2 < 2 || RX_FIFO_LOG2 > 8) begin : g_bad_fifo
            hg_uart_RX_FIFO_LOG2_must_be_2_to_8 u_stop ();
        end
    endgenerate

    wire wr_data   = s_req & s_we & (s_addr == A_DATA);
    wire rd_data   = s_req & ~s_we & (s_addr == A_DATA);
    wire wr_status = s_req & s_we & (s_addr == A_STATUS);
    wire unused_wdata = &{1'b0, s_wdata[31:8]};   // bytes are 8 bits, status flags 2

    // ---------------------------------------------------------------- transmitter
    // hold: the byte written, waiting for the shift register; shift: start, 8 data bits (LSB
    // first), stop, one bit every DIV clocks
    reg [7:0]    hold;
    reg          hold_full;
    reg [8:0]    sh;           // the bits still to send after the one on the line
    reg [3:0]    tx_bits;      // bits left on the line including the current one (0: idle)
    reg [DW-1:0] tx_cnt;

    always @(posedge clk) begin
        if (rst) begin
            hold_full <= 1'b0;
            tx_bits   <= 4'd0;
            tx_cnt    <= {DW{1'b0}};
            tx        <= 1'b1;
        end else begin
            if (tx_bits == 4'd0) begin
                if (hold_full) begin          // start bit now
                    tx        <= 1'b0;
                    sh        <= {1'b1, hold};
                    tx_bits   <= 4'd10;
                    tx_cnt    <= DIV_LAST;
                    hold_full <= 1'b0;
                end
            end else if (tx_cnt != {DW{1'b0}}) begin
                tx_cnt <= tx_cnt - 1'b1;
            end else begin                    // the bit's time is over
                tx_bits <= tx_bits - 1'b1;
                tx_cnt  <= DIV_LAST;
                tx      <= (tx_bits == 4'd1) ? 1'b1 : sh[0];
                sh      <= {1'b1, sh[8:1]};
                if (tx_bits == 4'd1)
                    tx_cnt <= {DW{1'b0}};
            end
            if (wr_data && !hold_full) begin  // a write while full is lost (the driver waits)
                hold      <= s_wdata[7:0];
                hold_full <= 1'b1;
            end
        end
    end

    // ---------------------------------------------------------------- receiver
    // The line through two flip-flops; a low level while idle starts a byte, sampled in the
    // middle of each bit. A byte whose stop bit is low is dropped (framing error).
    reg [1:0]    rx_s;
    wire         rx_in = rx_s[1];
    reg          rx_busy;
    reg [3:0]    rx_bits;      // bits sampled so far (start = 1 .. stop = 10)
    reg [DW-1:0] rx_cnt;
    reg [7:0]    rx_sh;
    reg          rx_push;      // a complete byte this clock
    reg          frame_err, overrun;

    always @(posedge clk) begin
        if (rst) begin
            rx_s      <= 2'b11;
            rx_busy   <= 1'b0;
            rx_bits   <= 4'd0;
            rx_cnt    <= {DW{1'b0}};
            rx_push   <= 1'b0;
            frame_err <= 1'b0;
        end else begin
            rx_s    <= {rx_s[0], rx};
            rx_push <= 1'b0;
            if (!rx_busy) begin
                if (!rx_in) begin             // start bit: its middle in DIV/2 clocks
                    rx_busy <= 1'b1;
                    rx_bits <= 4'd0;
                    rx_cnt  <= DIV_HALF;
                end
            end else if (rx_cnt != {DW{1'b0}}) begin
                rx_cnt <= rx_cnt - 1'b1;
            end else begin                    // the middle of a bit
                rx_cnt  <= DIV_LAST;
                rx_bits <= rx_bits + 1'b1;
                if (rx_bits == 4'd0) begin
                    if (rx_in)
                        rx_busy <= 1'b0;      // a glitch, not a start bit
                end else if (rx_bits <= 4'd8) begin
                    rx_sh <= {rx_in, rx_sh[7:1]};
                end else begin                // the stop bit
                    rx_busy <= 1'b0;
                    if (rx_in)
                        rx_push <= 1'b1;
                    else
                        frame_err <= 1'b1;
                end
            end
            if (wr_status && s_wdata[3])
                frame_err <= 1'b0;
        end
    end

    // receive FIFO: pointers one bit wider than the address
    reg [7:0]            fifo [0:DEPTH-1];
    reg [RX_FIFO_LOG2:0] wp, rp;
    wire                 empty = (wp == rp);
    wire                 full  = (wp[RX_FIFO_LOG2-1:0] == rp[RX_FIFO_LOG2-1:0]) &&
                                 (wp[RX_FIFO_LOG2] != rp[RX_FIFO_LOG2]);

    always @(posedge clk) begin
        if (rx_push && !full)
            fifo[wp[RX_FIFO_LOG2-1:0]] <= rx_sh;
    end

    always @(posedge clk) begin
        if (rst) begin
            wp      <= {(RX_FIFO_LOG2 + 1){1'b0}};
            rp      <= {(RX_FIFO_LOG2 + 1){1'b0}};
            overrun <= 1'b0;
        end else begin
            if (rx_push) begin
                if (full)
                    overrun <= 1'b1;
                else
                    wp <= wp + 1'b1;
            end
            if (rd_data && !empty)
                rp <= rp + 1'b1;
            if (wr_status && s_wdata[2])
                overrun <= 1'b0;
        end
    end

    // ---------------------------------------------------------------- registers
    // status: [0] a byte received, [1] the holding register free, [2] overrun (sticky: a byte
    // lost to a full FIFO), [3] framing error (sticky); writing 1 to bit 2 or 3 clears it
    wire [31:0] status = {28'd0, frame_err, overrun, ~hold_full, ~empty};

    always @(posedge clk) begin
        if (s_req) begin
            case (s_addr)
                A_DATA:   s_rdata <= empty ? 32'd0 : {24'd0, fifo[rp[RX_FIFO_LOG2-1:0]]};
                A_STATUS: s_rdata <= status;
                A_BAUD:   s_rdata <= BAUD_W;
                default:  s_rdata <= 32'd0;
            endcase
        end
    end
endmodule

`default_nettype wire
