// SPDX-License-Identifier: Apache-2.0
// Sinusoidal commutation of three motors through ONE shared quarter-wave sine ROM, time-multiplexed
// over six DAC channels (m0a, m0b, m1a, m1b, m2a, m2b) by dac_sched. Every per-motor input is
// latched at the frame start, so a change takes effect at the next frame, never mid-frame.
// Bit-exact model and full description: models/hapgate/golden/commutation.py.
// Latency: channel k loads (dac_wr_n rises) k*SKEW + 8 clocks after the frame start (WR_CYCLES=1),
// + 16 clocks with SERIAL_MUL=1 (one shift-add multiplier, 16 clocks per product: the LUT-only
// iCE40-HX8K build; the codes are bit-identical, the load times shift by MUL_EXTRA clocks).
// LIMITS = 3: a torque limit per motor (the top's TQ_LIMIT registers), clamped in the shared
// per-channel stage C; LATCH_RAM = 1: the latched torques and limits held in block RAM (fewer
// logic cells on the HX8K; the same codes and times). rtl/boards/README.md, "Fit".
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module commutator #(
    parameter integer CLK_HZ        = 48_000_000, // FPGA clock (a multiple of 1 kHz)
    parameter integer SKEW_NS       = 2000,       // time between successive DAC channel loads
    parameter integer FRAME_NS      = 16000,      // commutation frame (62.5 kHz)
    parameter integer SETTLE_NS     = 16000,      // DAC settling time (FRAME_NS >= SETTLE_NS)
    parameter integer WR_CYCLES     = 1,          // clocks the DAC write strobe is held low
    parameter integer COUNT_BITS    = 20,         // position counts per revolution = 2**COUNT_BITS
    parameter integer POLE_PAIRS    = 2,          // electrical cycles per revolution (1..7)
    parameter integer ADDR_BITS     = 8,          // sine ROM: 2**ADDR_BITS quarter-wave entries
    parameter integer MAG_BITS      = 13,         // sine ROM entry width (FS < 2**MAG_BITS)
    parameter integer FS            = 8191,       // sine ROM full scale (six-step level)
    parameter         LUT_FILE      = "sine.hex", // sine ROM contents (models/hapgate/golden/sine.py)
    parameter integer DAC_BITS      = 14,         // DAC width; codes saturate to +-(2**(DAC_BITS-1)-1)
    parameter integer OFFSET_BINARY = 0,          // DAC coding: 0 two's complement, 1 offset binary
    parameter integer SERIAL_MUL    = 0,          // 1: shift-add multiplier, 16 clocks (no DSP/LUT array)
    parameter integer LIMITS        = 1,          // torque limits: 1 for all motors, 3 one per motor
                                                  // (the top's TQ_LIMIT registers: one shared clamp)
    parameter integer LATCH_RAM     = 0           // 1: the frame-latched torques and limits in block
                                                  // RAM (one per motor; LUT-only boards: fewer cells)
) (
    input  wire                           clk,
    input  wire                           rst,
    // per-motor inputs, motor 0 in the low bits; sampled at the end of the clock with m_frame high
    input  wire [3*COUNT_BITS-1:0]        s_pos,            // per-revolution reading, counts
    input  wire [47:0]                    s_torque,         // signed torque commands
    input  wire [3*(ADDR_BITS+2)-1:0]     ctl_offset,       // index-to-winding offset, 1/2**(ADDR_BITS+2) cycle
    input  wire [5:0]                     ctl_mode,         // 0 SINE, 1 SIX_STEP, 2 ALIGN, 3 OFF
    input  wire                           ctl_enable,       // 0: every channel at zero torque
    input  wire [16*LIMITS-1:0]           ctl_torque_limit, // |torque| clamp (motor 0 low); >= 32768: none
    input  wire [2:0]                     axis_fault,       // 1: that motor at zero torque
    output wire                           m_frame,          // the inputs are latched at the end of this clock
    // DAC port
    output wire [DAC_BITS-1:0]            dac_data,
    output wire [2:0]                     dac_addr,
    output wire                           dac_wr_n
    `HG_SIM_PORTS(1)  // simulation only (rtl/include/hg_sim.vh): the datapath's clock
);
    localparam integer AB    = ADDR_BITS + 2;          // electrical angle bits (the ROM's cycle)
    localparam integer CB    = COUNT_BITS;
    localparam integer VB    = MAG_BITS + 1;           // signed sine sample width
    localparam integer PB    = VB + 16;                // product width
    localparam integer SH    = 15 + VB - DAC_BITS;     // code = round(product / 2**SH)
    localparam integer QB    = PB - SH;                // = DAC_BITS + 1: code before saturation
    localparam integer MUL_EXTRA = (SERIAL_MUL != 0) ? 16 : 0;  // extra clocks of the serial multiply
    localparam integer PIPE  = 5 + MUL_EXTRA;          // m_req clock to s_valid clock
    localparam integer SKEW_CYCLES_I = CLK_HZ / 1000 * SKEW_NS / 1_000_000;

    localparam integer PHASE_B_I = ((1 << AB) + 1) / 3;         // round(2**AB / 3): 341 of 1024
    localparam integer MAXC_I    = (1 << (DAC_BITS - 1)) - 1;   // +-8191
    localparam integer HALF_I    = 1 << (SH - 1);
    localparam [AB-1:0]       PHASE_B = PHASE_B_I[AB-1:0];
    localparam [CB-1:0]       PP      = POLE_PAIRS[CB-1:0];
    localparam signed [VB-1:0] FS_P   = FS[VB-1:0];
    localparam signed [VB-1:0] FS_N   = -FS_P;
    localparam signed [QB-1:0] MAXC   = MAXC_I[QB-1:0];
    localparam signed [QB-1:0] MINC   = -MAXC;
    localparam signed [PB-1:0] HALF   = HALF_I[PB-1:0];
    localparam signed [PB-1:0] HALF_M = HALF - 1;

    // Six-step sector edges on the fine electrical angle: D_j = ceil(j * 2**CB / 12), j odd, i.e.
    // 30, 90, 150, 210, 270, 330 deg, exact to one count (like Hall sensors, not on the ROM grid).
    localparam integer D1_I  = ((1 << CB) *  1 + 11) / 12;
    localparam integer D3_I  = ((1 << CB) *  3 + 11) / 12;
    localparam integer D5_I  = ((1 << CB) *  5 + 11) / 12;
    localparam integer D7_I  = ((1 << CB) *  7 + 11) / 12;
    localparam integer D9_I  = ((1 << CB) *  9 + 11) / 12;
    localparam integer D11_I = ((1 << CB) * 11 + 11) / 12;
    localparam [CB-1:0] D1 = D1_I[CB-1:0], D3 = D3_I[CB-1:0], D5 = D5_I[CB-1:0];
    localparam [CB-1:0] D7 = D7_I[CB-1:0], D9 = D9_I[CB-1:0], D11 = D11_I[CB-1:0];

    localparam [1:0] MODE_SIX = 2'd1, MODE_ALIGN = 2'd2, MODE_OFF = 2'd3;

    generate
        if (COUNT_BITS < AB + 1 || COUNT_BITS > 26) begin : g_bad_count_bits
            commutator_COUNT_BITS_must_exceed_ADDR_BITS_plus_2_and_be_at_most_26 u_stop ();
        end
        if (POLE_PAIRS < 1 || POLE_PAIRS > 7) begin : g_bad_pole_pairs
            commutator_POLE_PAIRS_must_be_1_to_7 u_stop ();
        end
        if (FS < 1 || FS >= (1 << MAG_BITS) || SH < 1) begin : g_bad_fs
            commutator_needs_FS_below_2_pow_MAG_BITS_and_DAC_BITS_le_MAG_BITS_plus_15 u_stop ();
        end
        if (DAC_BITS < 4 || DAC_BITS > 16) begin : g_bad_dac_bits
            commutator_DAC_BITS_must_be_4_to_16 u_stop ();
        end
        if (SERIAL_MUL != 0 && SERIAL_MUL != 1) begin : g_bad_serial_mul
            commutator_SERIAL_MUL_must_be_0_or_1 u_stop ();
        end
        if (LATCH_RAM != 0 && LATCH_RAM != 1) begin : g_bad_latch_ram
            commutator_LATCH_RAM_must_be_0_or_1 u_stop ();
        end
        if (LIMITS != 1 && LIMITS != 3) begin : g_bad_limits
            commutator_LIMITS_must_be_1_or_3 u_stop ();
        end
        if (SERIAL_MUL != 0 && SKEW_CYCLES_I < MUL_EXTRA + 2) begin : g_serial_mul_too_slow
            commutator_SERIAL_MUL_needs_SKEW_of_at_least_18_clocks u_stop ();
        end
    endgenerate

    // The datapath's clock: clk (rtl/include/hg_sim.vh: the virtual device's stage clock). The
    // valid pipeline and the scheduler are on clk.
    wire clk_d = `HG_SIM_CLK(clk, 0);

    // ---------------------------------------------------------------- scheduler
    wire       req;
    wire [2:0] req_ch;
    wire       s_valid;
    wire [2:0] s_ch;
    wire [DAC_BITS-1:0] s_data;

    dac_sched #(
        .CLK_HZ(CLK_HZ), .SKEW_NS(SKEW_NS), .FRAME_NS(FRAME_NS), .SETTLE_NS(SETTLE_NS),
        .CHANNELS(6), .ADDR_BITS(3), .DAC_BITS(DAC_BITS), .WR_CYCLES(WR_CYCLES),
        .PIPE_CYCLES(PIPE)
    ) u_sched (
        .clk(clk), .rst(rst), .m_frame(m_frame), .m_req(req), .m_req_ch(req_ch),
        .s_valid(s_valid), .s_ch(s_ch), .s_data(s_data),
        .dac_data(dac_data), .dac_addr(dac_addr), .dac_wr_n(dac_wr_n)
    );

    // ---------------------------------------------------------------- frame latch
    // Control state is reset (all motors disabled until the first latch: the frame that starts at
    // reset writes zero to every channel); data registers are not.
    reg [3*CB-1:0] u_q;         // electrical angle, fine: (pos * POLE_PAIRS) mod 2**CB
    reg [3*AB-1:0] off_q;
    wire [47:0]    tq_q;           // torques and limits as latched: first read at stage C
    wire [16*LIMITS-1:0] lim_q;
    reg [5:0]      mode_q;
    reg [2:0]    fault_q;
    reg          en_q;

    integer m;
    always @(posedge clk_d) begin
        if (m_frame) begin
            for (m = 0; m < 3; m = m + 1)
                u_q[m*CB +: CB] <= s_pos[m*CB +: CB] * PP;
            off_q <= ctl_offset;
        end
    end

    genvar gm;
    generate
        if (LATCH_RAM != 0) begin : g_latch_ram
            // A block RAM per motor, written at the frame start and read every clock: the
            // latched word is on its output from the second clock of the frame on, and the first
            // reader (channel 0's stage C) comes three clocks after the frame start. The write
            // address alternates between two words (so synthesis keeps a memory: a constant
            // address would be folded back into flip-flops); the read takes the last written.
            reg wp;
            always @(posedge clk_d) begin
                if (rst)
                    wp <= 1'b0;
                else if (m_frame)
                    wp <= ~wp;
            end
            for (gm = 0; gm < 3; gm = gm + 1) begin : g_m
                localparam integer LW = (LIMITS == 3 || gm == 0) ? 32 : 16;
                wire [LW-1:0] wd;
                if (LW == 32) begin : g_tl
                    assign wd = {ctl_torque_limit[16*gm +: 16], s_torque[16*gm +: 16]};
                end else begin : g_t
                    assign wd = s_torque[16*gm +: 16];
                end
                (* ram_style = "block" *) reg [LW-1:0] mem [0:1];
                reg [LW-1:0] rd;
                always @(posedge clk_d) begin
                    if (m_frame) mem[wp] <= wd;
                    rd <= mem[~wp];
                end
                assign tq_q[16*gm +: 16] = rd[15:0];
                if (LW == 32) begin : g_lim
                    assign lim_q[16*gm +: 16] = rd[31:16];
                end
            end
        end else begin : g_latch_ff
            reg [47:0]          tq_r;
            reg [16*LIMITS-1:0] lim_r;
            always @(posedge clk_d) begin
                if (m_frame) begin
                    tq_r  <= s_torque;
                    lim_r <= ctl_torque_limit;
                end
            end
            assign tq_q  = tq_r;
            assign lim_q = lim_r;
        end
    endgenerate

    always @(posedge clk_d) begin
        if (rst) begin
            mode_q  <= {3{MODE_OFF}};
            fault_q <= 3'b111;
            en_q    <= 1'b0;
        end else if (m_frame) begin
            mode_q  <= ctl_mode;
            fault_q <= axis_fault;
            en_q    <= ctl_enable;
        end
    end

    // ---------------------------------------------------------------- stage A: angle, level
    // A function called in stage A's clocked block rather than continuous logic: its inputs are
    // the scheduler's channel (on clk) and the frame's latched state, so in a simulation on
    // stage clocks (docs/design/SIMULATION.md) continuous logic would be re-evaluated at every clock although
    // only stage A reads it. Synthesis builds the same logic either way.
    function [AB+3:0] stage_a;   // {code, six-step, level +, level -, zero}
        input [2:0]      ch;     // the channel asked for (motor = ch / 2, phase b = ch[0])
        input [3*CB-1:0] u;
        input [3*AB-1:0] off;
        input [5:0]      mode;
        input [2:0]      fault;
        input            en;
        reg [CB-1:0] u_m, u_a;
        reg [AB-1:0] off_m, code_ch;
        reg [1:0]    mode_m;
        reg          fault_m, lvl_pos, lvl_neg;
        reg [2:0]    n_edges;
        begin
            case (ch[2:1])
                2'd0:    begin
                    u_m = u[0*CB +: CB]; off_m = off[0*AB +: AB];
                    mode_m = mode[0*2 +: 2]; fault_m = fault[0];
                end
                2'd1:    begin
                    u_m = u[1*CB +: CB]; off_m = off[1*AB +: AB];
                    mode_m = mode[1*2 +: 2]; fault_m = fault[1];
                end
                default: begin
                    u_m = u[2*CB +: CB]; off_m = off[2*AB +: AB];
                    mode_m = mode[2*2 +: 2]; fault_m = fault[2];
                end
            endcase
            // channel a's angle: theta + offset (ALIGN: the offset alone), fine and on the ROM
            // grid; channel b: 120 deg later = round(2**AB / 3) codes (341 of 1024: 1/3 code
            // short of 120 deg)
            u_a     = ((mode_m == MODE_ALIGN) ? {CB{1'b0}} : u_m) + {off_m, {(CB - AB){1'b0}}};
            code_ch = u_a[CB-1 -: AB] - (ch[0] ? PHASE_B : {AB{1'b0}});
            // Six-step (Hall-sector) level from the number of sector edges passed, n = 0..6:
            // a: + for n = 1, 2; - for n = 4, 5.   b: + for n = 3, 4; - for n = 0, 1, 6.
            n_edges = {2'b00, u_a >= D1} + {2'b00, u_a >= D3} + {2'b00, u_a >= D5}
                    + {2'b00, u_a >= D7} + {2'b00, u_a >= D9} + {2'b00, u_a >= D11};
            lvl_pos = ch[0] ? (n_edges == 3'd3 || n_edges == 3'd4)
                            : (n_edges == 3'd1 || n_edges == 3'd2);
            lvl_neg = ch[0] ? (n_edges == 3'd0 || n_edges == 3'd1 || n_edges == 3'd6)
                            : (n_edges == 3'd4 || n_edges == 3'd5);
            stage_a = {code_ch, mode_m == MODE_SIX, lvl_pos, lvl_neg,
                       !en || fault_m || (mode_m == MODE_OFF)};
        end
    endfunction

    reg          va;
    reg [AB-1:0] ang_a;
    reg [2:0]    ch_a;
    reg          six_a, pos_a, neg_a, zero_a;

    always @(posedge clk_d) begin
        {ang_a, six_a, pos_a, neg_a, zero_a} <= stage_a(req_ch, u_q, off_q, mode_q, fault_q, en_q);
        ch_a <= req_ch;
    end

    // ---------------------------------------------------------------- stages B, C: the sine ROM
    wire                 lut_valid;
    wire signed [VB-1:0] lut_value;

    sine_lut #(.ADDR_BITS(ADDR_BITS), .MAG_BITS(MAG_BITS), .LUT_FILE(LUT_FILE)) u_lut (
        .clk(clk_d), .rst(rst), .in_valid(va), .in_angle(ang_a),
        .out_valid(lut_valid), .out_value(lut_value)
    );

    reg [2:0]  ch_b, ch_c;
    reg        six_b, pos_b, neg_b, zero_b, six_c, pos_c, neg_c, zero_c;
    always @(posedge clk_d) begin
        {ch_b, six_b, pos_b, neg_b, zero_b} <= {ch_a, six_a, pos_a, neg_a, zero_a};
        {ch_c, six_c, pos_c, neg_c, zero_c} <= {ch_b, six_b, pos_b, neg_b, zero_b};
    end

    // Torque clamp to +-limit (limit >= 32768: no clamp, -32768 passes), for stage C's channel:
    // the torques and limits are latched at the frame start and every channel's pipeline ends
    // inside the frame (dac_sched checks it), so they are the ones of the channel's request.
    wire [1:0]  m_c = (ch_c[2:1] == 2'd3) ? 2'd2 : ch_c[2:1];
    wire [15:0] tq_m = tq_q[16*m_c +: 16];
    wire [15:0] lim_m;
    generate
        if (LIMITS == 3) begin : g_lim3
            assign lim_m = lim_q[16*m_c +: 16];
        end else begin : g_lim1
            assign lim_m = lim_q[15:0];
        end
    endgenerate
    wire        [16:0] lim17 = lim_m[15] ? 17'h08000 : {1'b0, lim_m};
    wire signed [16:0] t17   = {tq_m[15], tq_m};
    wire               t_hi  = t17 > $signed(lim17);
    wire               t_lo  = t17 < -$signed(lim17);
    wire        [15:0] t_cl  = t_hi ? lim17[15:0] : (t_lo ? (~lim17[15:0] + 16'd1) : tq_m);

    wire [15:0]        tq_c = t_cl;

    // ---------------------------------------------------------------- stage M: multiply
    wire signed [VB-1:0] six_value = pos_c ? FS_P : (neg_c ? FS_N : {VB{1'b0}});
    wire signed [VB-1:0] mul_a     = six_c ? six_value : lut_value;

    reg                  vm;
    wire signed [PB-1:0] prod;     // the product, from the clock after mul_done to the next one
    reg [2:0]            ch_m;
    reg                  zero_mq;
    wire                 mul_done;

    generate
        if (SERIAL_MUL == 0) begin : g_mul_array
            // one clock, one multiplier (a DSP block where the device has one)
            reg signed [PB-1:0] prod_q;
            always @(posedge clk_d) begin
                prod_q  <= mul_a * $signed(tq_c);
                ch_m    <= ch_c;
                zero_mq <= zero_c;
            end
            assign prod     = prod_q;
            assign mul_done = lut_valid;
        end else begin : g_mul_serial
            // Shift-add over the 16 torque bits, LSB first; bit 15 has weight -2**15 (two's
            // complement), so the last step subtracts. The product is exact (PB bits hold it);
            // one product per 16 clocks (SKEW >= 18 clocks is checked above).
            reg signed [PB-1:0] acc, mcand;
            reg [15:0]          mplier;
            reg [4:0]           step;      // 0..15 working, 16 idle
            wire                last = (step == 5'd15);
            wire signed [PB-1:0] addend = mplier[0] ? (last ? -mcand : mcand) : {PB{1'b0}};
            always @(posedge clk_d) begin
                if (lut_valid) begin
                    acc     <= {PB{1'b0}};
                    mcand   <= {{(PB - VB){mul_a[VB-1]}}, mul_a};
                    mplier  <= tq_c;
                    ch_m    <= ch_c;
                    zero_mq <= zero_c;
                end else if (!step[4]) begin
                    acc    <= acc + addend;
                    mcand  <= mcand <<< 1;
                    mplier <= mplier >> 1;
                end
            end
            // acc holds the product from the clock after the last step until the next product
            // starts (>= SKEW clocks later), through stage R's clock
            assign prod = acc;
            always @(posedge clk_d) begin
                if (rst) begin
                    step <= 5'd16;
                end else begin
                    if (lut_valid)
                        step <= 5'd0;
                    else if (!step[4])
                        step <= step + 5'd1;
                end
            end
            assign mul_done = last;
        end
    endgenerate

    // ---------------------------------------------------------------- stage R: round, saturate, code
    // Round half away from zero: (p + 2**(SH-1) - [p < 0]) >> SH, then clamp to +-MAXC.
    wire signed [PB-1:0] biased  = prod + (prod[PB-1] ? HALF_M : HALF);
    wire signed [QB-1:0] q       = biased[PB-1:SH];
    wire [DAC_BITS-1:0]  q_sat   = (q > MAXC) ? MAXC[DAC_BITS-1:0]
                                 : ((q < MINC) ? MINC[DAC_BITS-1:0] : q[DAC_BITS-1:0]);
    wire [DAC_BITS-1:0]  code    = zero_mq ? {DAC_BITS{1'b0}} : q_sat;
    wire                 unused_round = &{1'b0, biased[SH-1:0]};  // rounded away by design

    reg                  vr;
    reg [DAC_BITS-1:0]   word;
    reg [2:0]            ch_r;
    always @(posedge clk_d) begin
        word <= (OFFSET_BINARY != 0) ? {~code[DAC_BITS-1], code[DAC_BITS-2:0]} : code;
        ch_r <= ch_m;
    end

    // valid pipeline (control: reset)
    always @(posedge clk) begin
        if (rst) begin
            va <= 1'b0;
            vm <= 1'b0;
            vr <= 1'b0;
        end else begin
            va <= req;
            vm <= mul_done;
            vr <= vm;
        end
    end

    assign s_valid = vr;
    assign s_ch    = ch_r;
    assign s_data  = word;

    // simulation only: the datapath clock's enable (reset, the frame latch, a request, each
    // pipeline stage while its valid is high: va, the ROM's read vb_sim, lut_valid, vm)
    `HG_SIM_GATE_ONLY(reg vb_sim; always @(posedge clk) vb_sim <= rst ? 1'b0 : va;)
    `HG_SIM_EN(((SERIAL_MUL == 0) ? (rst | m_frame | req | va | vb_sim | lut_valid | vm) : 1'b1))
endmodule

`default_nettype wire
