// SPDX-License-Identifier: Apache-2.0
// The SoC's block RAM: code, data and stack in one array of 32-bit words, loaded with the
// firmware image at configuration ($readmemh). Two ports on the same clock: A reads for the
// instruction fetch, B reads and writes (byte enables) for the data bus. Both registered: the
// word is there the clock after the address.
`timescale 1ns / 1ps
`default_nettype none

module hg_soc_ram #(
    parameter integer ADDR_BITS = 15,              // 2**ADDR_BITS words (15: 128 KiB)
    parameter         INIT_FILE = "hapgate-fw.hex" // image: one 32-bit word per line, word 0
                                                   // first ("": none, the RAM starts unknown)
) (
    input  wire                 clk,
    input  wire                 a_en,       // port A: read word a_addr
    input  wire [ADDR_BITS-1:0] a_addr,
    output reg  [31:0]          a_rdata,
    input  wire                 b_en,       // port B: read word b_addr, and write its bytes
    input  wire [3:0]           b_we,       // ... whose enable is set (bit i: bits 8i+7..8i)
    input  wire [ADDR_BITS-1:0] b_addr,
    input  wire [31:0]          b_wdata,
    output reg  [31:0]          b_rdata     // the word before this clock's write
);
    generate
        if (ADDR_BITS < 8 || ADDR_BITS > 20) begin : g_bad_addr_bits
            hg_soc_ram_ADDR_BITS_must_be_8_to_20 u_stop ();
        end
    endgenerate

    // no_rw_check: the two ports' collision (A reading the word B writes in the same clock)
    // is left to the block RAM. Without it Yosys keeps A's "old word" by building the RAM
    // twice (128 DP16KD for 128 KiB instead of 64). The firmware never executes a word it
    // writes (no self-modifying code), so such a fetch is never used. B's own read-before-write
    // is kept: the block RAM's READBEFOREWRITE mode.
    (* no_rw_check *)
    reg [31:0] mem [0:(1 << ADDR_BITS) - 1];

    initial begin
        if (INIT_FILE != "")
            $readmemh(INIT_FILE, mem);
    end

    always @(posedge clk) begin
        if (a_en)
            a_rdata <= mem[a_addr];
    end

    always @(posedge clk) begin
        if (b_en) begin
            b_rdata <= mem[b_addr];
            if (b_we[0]) mem[b_addr][7:0]   <= b_wdata[7:0];
            if (b_we[1]) mem[b_addr][15:8]  <= b_wdata[15:8];
            if (b_we[2]) mem[b_addr][23:16] <= b_wdata[23:16];
            if (b_we[3]) mem[b_addr][31:24] <= b_wdata[31:24];
        end
    end
endmodule

`default_nettype wire
