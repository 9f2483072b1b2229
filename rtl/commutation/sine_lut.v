// SPDX-License-Identifier: Apache-2.0
// Quarter-wave sine ROM unfolded over a full cycle: angle code k of 2**(ADDR_BITS+2) codes gives
// round(FS*sin) of the angle (k + 1/2) * 360deg / 2**(ADDR_BITS+2). Contents come from
// models/hapgate/golden/sine.py (build/gen/*.hex); the path arrives in LUT_FILE.
// Latency: 2 clocks from in_valid to out_valid (synchronous ROM read, then sign).
`timescale 1ns / 1ps
`default_nettype none

module sine_lut #(
    parameter integer ADDR_BITS = 8,          // quarter-wave entries = 2**ADDR_BITS (256)
    parameter integer MAG_BITS  = 13,         // unsigned width of one entry (FS < 2**MAG_BITS)
    parameter         LUT_FILE  = "sine.hex"  // $readmemh file written by the model's generator
) (
    input  wire                       clk,
    input  wire                       rst,
    input  wire                       in_valid,
    input  wire [ADDR_BITS+1:0]       in_angle,   // quadrant in the two MSBs
    output reg                        out_valid,
    output reg  signed [MAG_BITS:0]   out_value   // two's complement, +-FS
);
    localparam integer ENTRIES = 1 << ADDR_BITS;

    // Elaboration-time check: a bad configuration instantiates a module that does not exist,
    // whose name is the message (works in Verilator, Icarus and Yosys alike).
    generate
        if (ADDR_BITS < 2 || ADDR_BITS > 12) begin : g_bad_addr_bits
            sine_lut_ADDR_BITS_must_be_2_to_12 u_stop ();
        end
    endgenerate

    reg [MAG_BITS-1:0] rom [0:ENTRIES-1];
    initial $readmemh(LUT_FILE, rom);

    wire                 mirror = in_angle[ADDR_BITS];     // odd quadrant: read T[N-1-i]
    wire [ADDR_BITS-1:0] index  = in_angle[ADDR_BITS-1:0];
    wire [ADDR_BITS-1:0] addr   = mirror ? ~index : index; // ~i = N-1-i

    reg [MAG_BITS-1:0] rom_q;
    reg                neg_q;
    reg                valid_q;

    always @(posedge clk) begin
        rom_q <= rom[addr];
        neg_q <= in_angle[ADDR_BITS+1];                    // quadrants 2 and 3 are negated
        out_value <= neg_q ? -$signed({1'b0, rom_q}) : $signed({1'b0, rom_q});
    end

    always @(posedge clk) begin
        if (rst) begin
            valid_q   <= 1'b0;
            out_valid <= 1'b0;
        end else begin
            valid_q   <= in_valid;
            out_valid <= valid_q;
        end
    end
endmodule

`default_nettype wire
