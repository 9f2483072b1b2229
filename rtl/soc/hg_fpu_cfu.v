// SPDX-License-Identifier: Apache-2.0
// A single-precision float unit on VexRiscv's custom-function port (VexRiscv_FullCfu's CfuPlugin):
// add, subtract, multiply and divide of IEEE-754 binary32 words, rounded to nearest even, with
// subnormal inputs and results, signed zeros, overflow to infinity and the RISC-V canonical NaN
// (0x7FC0_0000) for every NaN result, which is what libgcc's soft float returns on RV32: the
// firmware's __addsf3, __subsf3, __mulsf3 and __divsf3 (dsp-fw/board/riscv/fpu.c) run here and
// give the same bits. One operation at a time, multi-cycle. Port and timing: rtl/soc/README.md.
`timescale 1ns / 1ps
`default_nettype none

module hg_fpu_cfu (
    input  wire        clk,
    input  wire        rst,
    // command: {funct7, funct3} of the CUSTOM_0 R-type instruction, rs1, rs2; taken when both
    // valid and ready are high (ready only while idle)
    input  wire        cmd_valid,
    output wire        cmd_ready,
    input  wire [9:0]  cmd_function_id,
    input  wire [31:0] cmd_inputs_0,
    input  wire [31:0] cmd_inputs_1,
    // response: rd, held with valid until ready; one per command, in order
    output reg         rsp_valid,
    input  wire        rsp_ready,
    output reg  [31:0] rsp_outputs_0
);
    // function ids (funct7 = 0): rd = rs1 op rs2; any other id answers 0
    localparam [9:0] F_ADD = 10'd0, F_SUB = 10'd1, F_MUL = 10'd2, F_DIV = 10'd3;
    localparam [31:0] QNAN = 32'h7FC0_0000;   // libgcc's NaN on RISC-V (_FP_NANFRAC_S, sign 0)

    localparam [2:0] S_IDLE = 3'd0, S_PREP = 3'd1, S_EXEC = 3'd2, S_PACK = 3'd3, S_NORM = 3'd4,
                     S_ROUND = 3'd5, S_RSP = 3'd6;
    // The significand M of every result before rounding: 28 bits, its value M / 2**27 *
    // 2**(E - 127) with the leading one at bit 27 after normalisation; bits 27..4 are the 24
    // kept, bit 3 the guard bit, bits 2..0 sticky. Each datapath "jams" what it drops below
    // bit 0 into bit 0 (an odd M then stands for a value strictly between M - 1 and M + 1),
    // which rounds exactly as the true value while the guard bit stays at bit 2 or above.
    localparam integer EW = 12;               // signed exponent width (-197 .. 403 occur)

    function [4:0] lzc24;                     // leading zeros of a non-zero 24-bit word
        input [23:0] x;
        integer i;
        reg done;
        begin
            lzc24 = 5'd0;
            done  = 1'b0;
            for (i = 23; i >= 0; i = i - 1) begin
                if (!done && x[i])
                    done = 1'b1;
                else if (!done)
                    lzc24 = lzc24 + 5'd1;
            end
        end
    endfunction

    function [4:0] lzc28;                     // leading zeros of a 28-bit word (28: zero)
        input [27:0] x;
        integer i;
        reg done;
        begin
            lzc28 = 5'd0;
            done  = 1'b0;
            for (i = 27; i >= 0; i = i - 1) begin
                if (!done && x[i])
                    done = 1'b1;
                else if (!done)
                    lzc28 = lzc28 + 5'd1;
            end
        end
    endfunction

    reg [2:0]  state;
    reg [9:0]  fid;
    reg [31:0] a, b;

    assign cmd_ready = (state == S_IDLE);

    // ---------------------------------------------------------------- unpack (from a, b)
    wire       sa = a[31];
    wire       sb = b[31] ^ (fid == F_SUB);       // subtract: add the negated operand
    wire [7:0] ea = a[30:23], eb = b[30:23];
    wire       a_zero = (a[30:0] == 31'd0), b_zero = (b[30:0] == 31'd0);
    wire       a_inf = (ea == 8'hFF) && (a[22:0] == 23'd0);
    wire       b_inf = (eb == 8'hFF) && (b[22:0] == 23'd0);
    wire       a_nan = (ea == 8'hFF) && (a[22:0] != 23'd0);
    wire       b_nan = (eb == 8'hFF) && (b[22:0] != 23'd0);
    wire [23:0] ma = {ea != 8'd0, a[22:0]};       // significands (subnormal: no hidden one)
    wire [23:0] mb = {eb != 8'd0, b[22:0]};
    wire [7:0]  xa = (ea == 8'd0) ? 8'd1 : ea;    // effective biased exponents
    wire [7:0]  xb = (eb == 8'd0) ? 8'd1 : eb;
    wire        sp = sa ^ b[31];                  // the sign of a product or quotient

    // add: the larger magnitude first (the encoding orders magnitudes as integers)
    wire        a_big  = (a[30:0] >= b[30:0]);
    wire [23:0] m_big  = a_big ? ma : mb;
    wire [23:0] m_sml  = a_big ? mb : ma;
    wire [7:0]  x_big  = a_big ? xa : xb;
    wire [7:0]  x_diff = a_big ? xa - xb : xb - xa;
    // multiply, divide: both significands normalised (a zero operand is a special case)
    wire [4:0]  la = lzc24(ma), lb = lzc24(mb);
    wire [23:0] na = ma << la, nb = mb << lb;
    wire signed [EW-1:0] xa_n = $signed({{(EW - 8){1'b0}}, xa}) - $signed({{(EW - 5){1'b0}}, la});
    wire signed [EW-1:0] xb_n = $signed({{(EW - 8){1'b0}}, xb}) - $signed({{(EW - 5){1'b0}}, lb});

    // special operands: the result without the datapath
    reg        special;
    reg [31:0] special_r;
    always @(*) begin
        special   = 1'b1;
        special_r = QNAN;
        case (fid)
            F_ADD, F_SUB: begin
                if (a_nan || b_nan || (a_inf && b_inf && (sa != sb)))
                    special_r = QNAN;
                else if (a_inf)
                    special_r = {sa, 8'hFF, 23'd0};
                else if (b_inf)
                    special_r = {sb, 8'hFF, 23'd0};
                else
                    special = 1'b0;
            end
            F_MUL: begin
                if (a_nan || b_nan || (a_inf && b_zero) || (a_zero && b_inf))
                    special_r = QNAN;
                else if (a_inf || b_inf)
                    special_r = {sp, 8'hFF, 23'd0};
                else if (a_zero || b_zero)
                    special_r = {sp, 31'd0};
                else
                    special = 1'b0;
            end
            F_DIV: begin
                if (a_nan || b_nan || (a_inf && b_inf) || (a_zero && b_zero))
                    special_r = QNAN;
                else if (a_inf || b_zero)
                    special_r = {sp, 8'hFF, 23'd0};
                else if (b_inf || a_zero)
                    special_r = {sp, 31'd0};
                else
                    special = 1'b0;
            end
            default: special_r = 32'd0;          // not a function of this unit
        endcase
    end

    // ---------------------------------------------------------------- datapath registers
    reg                  op_add, op_mul, sub_eff, sign, zsign;
    reg [23:0]           mx, my;        // add: larger, smaller significand; mul, div: a, b
                                        // normalised
    reg [7:0]            dexp;          // add: exponent difference
    reg signed [EW-1:0]  ex;            // the result's exponent E (M's convention above)
    reg [27:0]           m;             // M
    reg [47:0]           prod;          // multiply: the exact product
    reg [25:0]           rem;           // divide: partial remainder (< 2 * divisor)
    reg [26:0]           quo;           // divide: quotient bits
    reg [4:0]            cnt;           // divide: quotient bits still to find, less one
    reg [27:0]           mn;            // M normalised (leading one at bit 27; 0: a zero sum)
    reg signed [EW-1:0]  exn;           // ... and its exponent

    // add: the smaller significand aligned (3 extra bits, the rest jammed into bit 0)
    wire [26:0] my_x     = {my, 3'b000};
    wire [53:0] my_shift = {my_x, 27'd0} >> dexp[4:0];
    wire        my_jam   = my_shift[27] | (my_shift[26:0] != 27'd0);
    wire [26:0] aligned  = (dexp >= 8'd27) ? {26'd0, my != 24'd0} : {my_shift[53:28], my_jam};
    wire [27:0] sum      = sub_eff ? {1'b0, mx, 3'b000} - {1'b0, aligned}
                                   : {1'b0, mx, 3'b000} + {1'b0, aligned};
    // divide: one quotient bit per clock (restoring)
    wire        q_bit    = (rem >= {2'b00, my});
    wire [25:0] rem_sub  = q_bit ? rem - {2'b00, my} : rem;

    // normalise
    wire [4:0]  lz   = lzc28(m);
    wire [27:0] m_n  = m << lz;
    wire signed [EW-1:0] ex_n = ex - $signed({{(EW - 5){1'b0}}, lz});

    // round: below the smallest normal exponent the significand is shifted right (jammed) and
    // packed with exponent field 0; the increment carries into the exponent field (a subnormal
    // that rounds up to 2**-126, a largest finite that rounds up to infinity)
    wire signed [EW-1:0] sh_s = $signed({{(EW - 1){1'b0}}, 1'b1}) - exn;   // 1 - E
    wire        tiny   = (exn <= $signed({EW{1'b0}}));
    wire        huge   = (exn >= $signed(12'sd255));
    wire [4:0]  sh     = (sh_s >= $signed(12'sd28)) ? 5'd28 : sh_s[4:0];
    wire [55:0] m_sh   = {mn, 28'd0} >> sh;
    wire [27:0] m_d    = tiny ? {m_sh[55:29], m_sh[28] | (m_sh[27:0] != 28'd0)} : mn;
    wire [7:0]  e_fld  = tiny ? 8'd0 : exn[7:0];
    wire        inc    = m_d[3] & ((m_d[2:0] != 3'd0) | m_d[4]);
    wire [30:0] rounded = {e_fld, m_d[26:4]} + {30'd0, inc};
    // the remainder stays below the divisor (< 2**24) after a subtraction; the hidden one is
    // not stored
    wire unused_bits = &{1'b0, rem_sub[25], m_d[27]};

    always @(posedge clk) begin
        if (rst) begin
            state     <= S_IDLE;
            rsp_valid <= 1'b0;
        end else begin
            case (state)
                S_IDLE: if (cmd_valid) state <= S_PREP;
                S_PREP: begin
                    if (special) begin
                        rsp_outputs_0 <= special_r;
                        rsp_valid     <= 1'b1;
                        state         <= S_RSP;
                    end else begin
                        state <= S_EXEC;
                    end
                end
                S_EXEC: begin
                    if (op_add) state <= S_NORM;
                    else if (op_mul || cnt == 5'd0) state <= S_PACK;
                end
                S_PACK:  state <= S_NORM;
                S_NORM:  state <= S_ROUND;
                S_ROUND: begin
                    // an exact zero sum: +0, or -0 when both addends are -0 (round to nearest)
                    rsp_outputs_0 <= (mn == 28'd0) ? {zsign, 31'd0}
                                   : huge ? {sign, 8'hFF, 23'd0} : {sign, rounded};
                    rsp_valid     <= 1'b1;
                    state         <= S_RSP;
                end
                S_RSP: begin
                    if (rsp_ready) begin
                        rsp_valid <= 1'b0;
                        state     <= S_IDLE;
                    end
                end
                default: state <= S_IDLE;
            endcase
        end
    end

    // datapath: no reset
    always @(posedge clk) begin
        case (state)
            S_IDLE: begin
                fid <= cmd_function_id;
                a   <= cmd_inputs_0;
                b   <= cmd_inputs_1;
            end
            S_PREP: begin
                op_add  <= (fid == F_ADD) || (fid == F_SUB);
                op_mul  <= (fid == F_MUL);
                sub_eff <= sa ^ sb;
                zsign   <= sa & sb;
                if ((fid == F_ADD) || (fid == F_SUB)) begin
                    sign <= a_big ? sa : sb;
                    mx   <= m_big;
                    my   <= m_sml;
                    dexp <= x_diff;
                    ex   <= $signed({{(EW - 8){1'b0}}, x_big}) + $signed(12'sd1);
                end else begin
                    sign <= sp;
                    mx   <= na;
                    my   <= nb;
                    ex   <= (fid == F_MUL) ? xa_n + xb_n - $signed(12'sd126)
                                           : xa_n - xb_n + $signed(12'sd127);
                    rem  <= {2'b00, na};
                    cnt  <= 5'd26;
                end
            end
            S_EXEC: begin
                if (op_add) begin
                    m <= sum;
                end else if (op_mul) begin
                    prod <= mx * my;
                end else begin                      // divide: quotient bits 26 .. 0
                    quo <= {quo[25:0], q_bit};
                    rem <= {rem_sub[24:0], 1'b0};
                    cnt <= cnt - 5'd1;
                end
            end
            // M of a product (value prod / 2**47) or of a quotient (quo / 2**26, the remainder
            // jammed): the dropped bits are the sticky bit
            S_PACK: m <= op_mul ? {prod[47:21], prod[20:0] != 21'd0} : {quo, rem != 26'd0};
            S_NORM: begin
                mn  <= m_n;
                exn <= ex_n;
            end
            default: ;
        endcase
    end
endmodule

`default_nettype wire
