// SPDX-License-Identifier: Apache-2.0
// The hapgate register file (map: rtl/regs/hapgate.rdl, the one source; this hand-written block
// is checked against it by tb/bus/test_hg_bus.py: rdl_conformance and random accesses against
// hapgate.golden.regmodel): control, status, the three-axis snapshot
// latched together on the servo tick or on demand, the servo-tick interrupt and the watchdog.
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module hg_regfile #(
    parameter integer CLK_HZ       = 48_000_000, // FPGA clock: a multiple of 1 MHz
    parameter integer SAMPLE_HZ    = 1_000_000,  // encoder sample rate (velocity unit conversion)
    parameter integer VEL_LOG2W    = 8,          // velocity window 2**VEL_LOG2W samples
    parameter integer VEL_BITS     = 32,         // in_vel is the sign extension of its low
                                                 // VEL_BITS bits (the interpolator's: 19)
    parameter integer SKEW_CLOCKS  = 96,         // DAC channel skew in clocks (read-only info)
    parameter integer FRAME_CLOCKS = 768,        // DAC frame in clocks (read-only info)
    parameter integer ADDR_BITS    = 8,          // decoded word-address bits (7..30; the map spans 64)
    parameter integer VEL_OBS      = 0,          // 1: the interpolator has the velocity observer
    parameter integer VEL_SEL_RST  = 0,          // 1: VEL_CTRL.SEL resets to 7 (every axis the observer's)
    parameter integer HARM         = 0,          // 1: the interpolator has the harmonic table (HARM_*)
    parameter integer HARM_LOG2    = 6,          // HARM = 1: its entries per line, log2 (4..8)
    parameter integer SEC          = 0           // countermeasures built, HW_FAULT's bits
                                                 // (rtl/top/README.md, "Integrity alarms"): bit 0
                                                 // parity of the command and snapshot words, 3 the
                                                 // tick range check (here); 1, 2, 4 the top's
) (
    input  wire                 clk,
    input  wire                 rst,
    // register access (from emif_slave)
    input  wire [ADDR_BITS-1:0] s_raddr,
    output reg  [31:0]          s_rdata,
    input  wire                 s_req,
    input  wire                 s_we,
    input  wire [ADDR_BITS-1:0] s_addr,
    input  wire [31:0]          s_wdata,
    input  wire                 s_proto_err,
    // live interpolator outputs (axis 0 in the low bits)
    input  wire [95:0]          in_pos,
    input  wire [95:0]          in_pos_homed,
    input  wire [95:0]          in_vel,          // counts per 2**VEL_LOG2W samples
    input  wire [95:0]          in_vel_obs,      // the observer's, same unit (VEL_OBS = 1)
    input  wire [95:0]          in_index_pos,
    input  wire [47:0]          in_index_count,
    input  wire [47:0]          in_overspeed_count,
    input  wire [2:0]           in_homed,
    input  wire [8:0]           in_faults,
    input  wire [2:0]           in_fault,
    // live calibration state (rtl/interp/enc_calib.v), 32 bits per axis in the register layout
    input  wire [95:0]          in_cal_ofs,      // {OFS_B, OFS_A}
    input  wire [95:0]          in_cal_gain,     // {GAIN_B, GAIN_A}
    input  wire [47:0]          in_cal_phase,
    input  wire [95:0]          in_cal_stat,     // {UPDATES, 8'd0, GEAR}
    // control outputs
    output wire                 ctl_global_en,
    output wire [2:0]           ctl_axis_en,
    output reg                  ctl_fault_clear, // one clock
    output reg  [2:0]           ctl_home_arm,    // one clock each
    output wire [47:0]          ctl_torque,
    output wire [29:0]          ctl_offset,
    output wire [5:0]           ctl_mode,
    output wire [47:0]          ctl_tq_limit,
    output wire [2:0]           ctl_cal_en,      // AXIS[i].CAL_CTRL.EN
    output wire [2:0]           ctl_cal_freeze,  // AXIS[i].CAL_CTRL.FREEZE
    output wire [11:0]          cfg_cal_mu,      // AXIS[i].CAL_CTRL.MU, 4 bits per axis
    output wire [11:0]          cfg_obs_bw,      // VEL_CTRL.BW0..2, 4 bits per axis
    output wire [2:0]           cfg_obs_type3,   // VEL_CTRL.TYPE3, bit per axis
    output wire [2:0]           ctl_harm_en,     // HARM_CTRL.EN, bit per axis (HARM = 1)
    output wire [2:0]           cfg_harm_we,     // HARM_DATA written: store into axis i's table
    output wire [7:0]           cfg_harm_addr,   // HARM_ADDR.ADDR (write entry and read-back)
    output wire [7:0]           cfg_harm_data,   // the written HARM_DATA (with cfg_harm_we)
    input  wire [23:0]          in_harm_rdata,   // each axis's entry cfg_harm_addr (read-back)
    input  wire [127:0]         in_cap,          // read values of CAP_CTRL..CAP_DATA (words
                                                 // 0x40..0x43; rtl/capture/hg_capture.v, which
                                                 // decodes their writes itself; 0: not built)
    output wire                 wdog_expired,    // sticky: all torque to zero
    input  wire [4:0]           in_sec_err,      // the top's integrity alarms this clock
                                                 // (HW_FAULT bits 1, 2, 4; 0 and 3 unused)
    output wire                 sec_fault,       // HW_FAULT latched (sticky): all torque to zero
    output wire                 irq,             // servo tick pending (level)
    output reg                  tick             // one clock after each servo tick (observation)
    `HG_SIM_PORTS(1)  // simulation only (rtl/include/hg_sim.vh): the bus clock
);
    // ---------------------------------------------------------------- constants
    localparam integer CLK_PER_US = CLK_HZ / 1_000_000;
    localparam integer TICK_MIN_I = CLK_HZ / 10_000;  // 10 kHz
    localparam integer TICK_MAX_I = CLK_HZ / 100;     // 100 Hz
    localparam integer TICK_RST_I = CLK_HZ / 1_000;   // 1 kHz
    localparam integer WD_MIN_I   = 100;              // us
    localparam integer WD_MAX_I   = 1_000_000;        // us
    localparam integer WD_RST_I   = 10_000;           // us
    localparam integer PW         = (CLK_PER_US > 1) ? $clog2(CLK_PER_US) : 1;
    localparam integer PLAST_I    = CLK_PER_US - 1;
    localparam [PW-1:0] PLAST     = PLAST_I[PW-1:0];
    localparam [23:0] TICK_MIN = TICK_MIN_I[23:0];
    localparam [23:0] TICK_MAX = TICK_MAX_I[23:0];
    localparam [23:0] TICK_RST = TICK_RST_I[23:0];
    localparam [19:0] WD_MIN   = WD_MIN_I[19:0];
    localparam [19:0] WD_MAX   = WD_MAX_I[19:0];
    localparam [19:0] WD_RST   = WD_RST_I[19:0];
    localparam [31:0] ID_VALUE = 32'h4847_0104;      // magic "HG", map version 1.4
    localparam [31:0] WD_KEY   = 32'h5AFE_C0DE;
    localparam [31:0] UNMAPPED = 32'hDEAD_BEEF;
    localparam integer CLK_KHZ_I = CLK_HZ / 1000;
    localparam [31:0] CLK_KHZ  = CLK_KHZ_I;
    localparam [15:0] SKEW_C   = SKEW_CLOCKS[15:0];
    localparam [15:0] FRAME_C  = FRAME_CLOCKS[15:0];

    // word addresses (rtl/regs/hapgate.rdl byte offsets / 4)
    localparam [5:0] A_ID = 6'h00, A_CTRL = 6'h01, A_STATUS = 6'h02, A_SEQ = 6'h03,
                     A_TICK_DIV = 6'h04, A_IRQ = 6'h05, A_WDOG = 6'h06, A_SCRATCH = 6'h07,
                     A_WDOG_TO = 6'h08, A_SKEW = 6'h09, A_FRAME = 6'h0A, A_CLK = 6'h0B;
    localparam [3:0] R_POS = 4'h0, R_VEL = 4'h1, R_IDX_POS = 4'h2, R_COUNTS = 4'h3,
                     R_POS_HOMED = 4'h4, R_FLAGS = 4'h5, R_CAL_CTRL = 4'h6, R_CAL_STAT = 4'h7,
                     R_TORQUE = 4'h8, R_OFFSET = 4'h9, R_MODE = 4'hA, R_TQ_LIMIT = 4'hB,
                     R_CAL_OFS = 4'hC, R_CAL_GAIN = 4'hD, R_CAL_PHASE = 4'hE;
    localparam [5:0] A_VEL_CTRL = 6'h0C;
    localparam [5:0] A_HARM_CTRL = 6'h0D, A_HARM_ADDR = 6'h0E, A_HARM_DATA = 6'h0F;
    localparam integer A_CAP_W = 16;                 // CAP_CTRL..CAP_DATA: words 0x40..0x43
    localparam integer A_HWF_I = 68;                 // HW_FAULT: word 0x44
    localparam [ADDR_BITS-1:0] A_HWF = A_HWF_I[ADDR_BITS-1:0];
    localparam [4:0] SEC_B = SEC[4:0];
    localparam [2:0] VEL_SEL_R  = (VEL_SEL_RST != 0) ? 3'b111 : 3'b000;
    // VEL_CTRL {BW2, BW1, BW0, 1'b0, TYPE3, 1'b0, SEL}: BW = 6, TYPE3 = 1 on every axis
    localparam [19:0] VEL_CTRL_RST = {4'd6, 4'd6, 4'd6, 1'b0, 3'b111, 1'b0, VEL_SEL_R};

    generate
        if (CLK_HZ < 1_000_000 || CLK_HZ % 1_000_000 != 0 || CLK_HZ / 100 > 16_777_215)
        begin : g_bad_clk
            hg_regfile_CLK_HZ_must_be_a_multiple_of_1MHz_below_1677MHz u_stop ();
        end
        if (SKEW_CLOCKS < 1 || SKEW_CLOCKS > 65535 || FRAME_CLOCKS < 1 || FRAME_CLOCKS > 65535)
        begin : g_bad_dac
            hg_regfile_SKEW_and_FRAME_CLOCKS_must_fit_16_bits u_stop ();
        end
        if (ADDR_BITS < 7 || ADDR_BITS > 30) begin : g_bad_addr_bits
            hg_regfile_ADDR_BITS_must_be_7_to_30 u_stop ();
        end
        if (VEL_LOG2W < 1 || VEL_LOG2W > 16 || SAMPLE_HZ < 1 || SAMPLE_HZ > CLK_HZ)
        begin : g_bad_vel
            hg_regfile_needs_1_le_VEL_LOG2W_le_16_and_SAMPLE_HZ_le_CLK_HZ u_stop ();
        end
        if (VEL_BITS < 2 || VEL_BITS > 32) begin : g_bad_vel_bits
            hg_regfile_VEL_BITS_must_be_2_to_32 u_stop ();
        end
        if ((VEL_OBS != 0 && VEL_OBS != 1) || (VEL_SEL_RST != 0 && VEL_SEL_RST != 1))
        begin : g_bad_vel_obs
            hg_regfile_VEL_OBS_and_VEL_SEL_RST_must_be_0_or_1 u_stop ();
        end
        if ((HARM != 0 && HARM != 1) || (HARM != 0 && (HARM_LOG2 < 4 || HARM_LOG2 > 8)))
        begin : g_bad_harm
            hg_regfile_HARM_must_be_0_or_1_and_HARM_LOG2_4_to_8 u_stop ();
        end
        if (SEC < 0 || SEC > 31) begin : g_bad_sec
            hg_regfile_SEC_must_be_a_5_bit_mask u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- decode
    // The registers written only by an access (configuration, harmonic table address, error
    // flags) are on clk_g: clk, or the simulation's bus clock. The counters, the snapshot and
    // the watchdog are on clk.
    wire clk_g = `HG_SIM_CLK(clk, 0);

    wire [ADDR_BITS-1:0] wa = s_addr;
    wire hi_zero_w = (wa[ADDR_BITS-1:6] == {(ADDR_BITS - 6){1'b0}});
    wire glob_w    = hi_zero_w && (wa[5:4] == 2'b00);
    wire axis_w    = hi_zero_w && (wa[5:4] != 2'b00);
    wire [1:0] ax_w = wa[5:4] - 2'd1;
    wire wr        = s_req & s_we;

    function is_cap;   // one of the capture buffer's four words (the address without [1:0])
        input [ADDR_BITS-3:0] a_hi;
        begin
            is_cap = (a_hi == A_CAP_W[ADDR_BITS-3:0]);
        end
    endfunction

    function mapped;
        input [ADDR_BITS-1:0] a;
        begin
            if (is_cap(a[ADDR_BITS-1:2]) || a == A_HWF)
                mapped = 1'b1;
            else if (a[ADDR_BITS-1:6] != {(ADDR_BITS - 6){1'b0}})
                mapped = 1'b0;
            else if (a[5:4] == 2'b00)
                mapped = 1'b1;                      // 0x0..0xF: every global word
            else
                mapped = (a[3:0] <= R_CAL_PHASE);  // 0x0..0xE: all but word 0xF
        end
    endfunction

    // ---------------------------------------------------------------- control registers
    reg        global_en_q;
    reg [2:0]  axis_en_q;
    reg [23:0] tick_div_q;
    reg [19:0] wd_timeout_q;
    reg [31:0] scratch_q;
    reg [47:0] torque_q;            // per axis, axis 0 in the low bits
    reg [29:0] offset_q;
    reg [5:0]  mode_q;
    reg [47:0] tq_lim_q;
    reg [23:0] cal_ctrl_q;          // per axis {MU, 2'b00, FREEZE, EN}
    reg [19:0] vel_ctrl_q;          // VEL_CTRL[19:0] (bits 3 and 7 read 0)
    reg        snap_req;            // CTRL.SNAP written this clock
    reg        cfg_err_set;

    wire fault_clr_w = wr && glob_w && wa[3:0] == A_CTRL[3:0] && s_wdata[4];
    wire pet_w       = wr && glob_w && wa[3:0] == A_WDOG[3:0] && s_wdata == WD_KEY;
    wire tick_div_w  = wr && glob_w && wa[3:0] == A_TICK_DIV[3:0];
    wire tick_ok     = s_wdata[31:24] == 8'd0 && s_wdata[23:0] >= TICK_MIN && s_wdata[23:0] <= TICK_MAX;
    wire wd_to_w     = wr && glob_w && wa[3:0] == A_WDOG_TO[3:0];
    wire wd_ok       = s_wdata[31:20] == 12'd0 && s_wdata[19:0] >= WD_MIN && s_wdata[19:0] <= WD_MAX;

    integer i;
    always @(posedge clk_g) begin
        if (rst) begin
            global_en_q     <= 1'b0;
            axis_en_q       <= 3'b000;
            tick_div_q      <= TICK_RST;
            wd_timeout_q    <= WD_RST;
            scratch_q       <= 32'd0;
            ctl_fault_clear <= 1'b0;
            ctl_home_arm    <= 3'b000;
            snap_req        <= 1'b0;
            cfg_err_set     <= 1'b0;
            torque_q        <= 48'd0;
            offset_q        <= 30'd0;
            mode_q          <= 6'b11_11_11;  // OFF
            tq_lim_q        <= 48'd0;
            cal_ctrl_q      <= 24'h60_60_60;  // MU = 6
            vel_ctrl_q      <= VEL_CTRL_RST;
        end else begin
            ctl_fault_clear <= fault_clr_w;
            ctl_home_arm    <= (wr && glob_w && wa[3:0] == A_CTRL[3:0]) ? s_wdata[7:5] : 3'b000;
            snap_req        <= wr && glob_w && wa[3:0] == A_CTRL[3:0] && s_wdata[8];
            cfg_err_set     <= (tick_div_w && !tick_ok) || (wd_to_w && !wd_ok);
            if (wr && glob_w) begin
                case (wa[3:0])
                    A_CTRL[3:0]: begin
                        global_en_q <= s_wdata[0];
                        axis_en_q   <= s_wdata[3:1];
                    end
                    A_TICK_DIV[3:0]: if (tick_ok) tick_div_q <= s_wdata[23:0];
                    A_SCRATCH[3:0]:  scratch_q <= s_wdata;
                    A_WDOG_TO[3:0]:  if (wd_ok) wd_timeout_q <= s_wdata[19:0];
                    A_VEL_CTRL[3:0]: vel_ctrl_q <= s_wdata[19:0] & 20'hFFF77;
                    default: ;
                endcase
            end
            if (wr && axis_w && ax_w != 2'd3) begin
                case (wa[3:0])
                    R_TORQUE:   torque_q[16*ax_w +: 16] <= s_wdata[15:0];
                    R_OFFSET:   offset_q[10*ax_w +: 10] <= s_wdata[9:0];
                    R_MODE:     mode_q[2*ax_w +: 2]     <= s_wdata[1:0];
                    R_TQ_LIMIT: tq_lim_q[16*ax_w +: 16] <= s_wdata[15:0];
                    R_CAL_CTRL: cal_ctrl_q[8*ax_w +: 8] <= {s_wdata[7:4], 2'b00, s_wdata[1:0]};
                    default: ;
                endcase
            end
        end
    end

    assign ctl_global_en = global_en_q;
    assign ctl_axis_en   = axis_en_q;
    assign ctl_torque    = torque_q;
    assign ctl_offset    = offset_q;
    assign ctl_mode      = mode_q;
    assign ctl_tq_limit  = tq_lim_q;
    assign ctl_cal_en     = {cal_ctrl_q[16], cal_ctrl_q[8], cal_ctrl_q[0]};
    assign ctl_cal_freeze = {cal_ctrl_q[17], cal_ctrl_q[9], cal_ctrl_q[1]};
    assign cfg_cal_mu     = {cal_ctrl_q[23:20], cal_ctrl_q[15:12], cal_ctrl_q[7:4]};
    assign cfg_obs_bw     = vel_ctrl_q[19:8];
    assign cfg_obs_type3  = vel_ctrl_q[6:4];

    // ---------------------------------------------------------------- harmonic table (HARM_*)
    // HARM_CTRL {LOG2[11:8], EN[2:0]}, HARM_ADDR {AXIS[9:8], ADDR[7:0]}, HARM_DATA [7:0].
    // A HARM_DATA write stores its low byte into entry ADDR of axis AXIS's table (cfg_harm_we
    // in the clock of the write); every HARM_DATA access (read or write) then increments ADDR
    // (wrapping at 256). AXIS = 3 selects no table. HARM = 0: all read 0, writes ignored.
    wire [31:0] harm_ctrl_rd, harm_addr_rd, harm_data_rd;
    generate
        if (HARM != 0) begin : g_harm
            localparam [3:0] HL2 = HARM_LOG2[3:0];
            reg [2:0] harm_en_q;
            reg [7:0] harm_addr_q;
            reg [1:0] harm_axis_q;
            wire      data_acc = s_req && glob_w && wa[3:0] == A_HARM_DATA[3:0];
            always @(posedge clk_g) begin
                if (rst) begin
                    harm_en_q   <= 3'b000;
                    harm_addr_q <= 8'd0;
                    harm_axis_q <= 2'd0;
                end else begin
                    if (wr && glob_w && wa[3:0] == A_HARM_CTRL[3:0])
                        harm_en_q <= s_wdata[2:0];
                    if (wr && glob_w && wa[3:0] == A_HARM_ADDR[3:0]) begin
                        harm_addr_q <= s_wdata[7:0];
                        harm_axis_q <= s_wdata[9:8];
                    end else if (data_acc) begin
                        harm_addr_q <= harm_addr_q + 8'd1;
                    end
                end
            end
            assign ctl_harm_en   = harm_en_q;
            assign cfg_harm_we   = (data_acc && s_we && harm_axis_q != 2'd3) ?
                                   (3'b001 << harm_axis_q) : 3'b000;
            assign cfg_harm_addr = harm_addr_q;
            assign cfg_harm_data = s_wdata[7:0];
            assign harm_ctrl_rd  = {20'd0, HL2, 5'd0, harm_en_q};
            assign harm_addr_rd  = {22'd0, harm_axis_q, harm_addr_q};
            assign harm_data_rd  = {24'd0, (harm_axis_q == 2'd0) ? in_harm_rdata[7:0] :
                                           (harm_axis_q == 2'd1) ? in_harm_rdata[15:8] :
                                           (harm_axis_q == 2'd2) ? in_harm_rdata[23:16] : 8'd0};
        end else begin : g_noharm
            assign ctl_harm_en   = 3'b000;
            assign cfg_harm_we   = 3'b000;
            assign cfg_harm_addr = 8'd0;
            assign cfg_harm_data = 8'd0;
            assign harm_ctrl_rd  = 32'd0;
            assign harm_addr_rd  = 32'd0;
            assign harm_data_rd  = 32'd0;
            wire unused_harm = &{1'b0, in_harm_rdata};
        end
    endgenerate

    // ---------------------------------------------------------------- servo tick and snapshot
    // A tick every tick_div_q clocks, exactly; a TICK_DIV write restarts the period (the first
    // tick comes tick_div_q clocks after the write's edge).
    reg [23:0] tick_cnt;
    wire       tick_bad;            // SEC bit 3: above TICK_DIV - 1 (an upset): restart the period
    wire       tick_now = (tick_cnt == tick_div_q - 24'd1);
    wire       snap_now = tick_now | snap_req;
    reg [31:0] seq_q;
    reg        irq_tick_q, irq_missed_q;
    wire       irq_w = wr && glob_w && wa[3:0] == A_IRQ[3:0];

    always @(posedge clk) begin
        if (rst) begin
            tick_cnt     <= 24'd0;
            tick         <= 1'b0;
            seq_q        <= 32'd0;
            irq_tick_q   <= 1'b0;
            irq_missed_q <= 1'b0;
        end else begin
            tick_cnt <= (tick_now || (tick_div_w && tick_ok) || tick_bad) ? 24'd0
                                                                         : tick_cnt + 24'd1;
            tick     <= tick_now;
            if (snap_now)
                seq_q <= seq_q + 32'd1;
            // a tick in the same clock as an acknowledge wins
            irq_tick_q   <= tick_now | (irq_tick_q & ~(irq_w & s_wdata[0]));
            irq_missed_q <= (tick_now & irq_tick_q) | (irq_missed_q & ~(irq_w & s_wdata[1]));
        end
    end
    assign irq = irq_tick_q;

    // the velocity each axis reports: the window FIR's, or the observer's (VEL_CTRL.SEL)
    wire [95:0] vel_src;
    generate
        if (VEL_OBS != 0) begin : g_vel_sel
            genvar va;
            for (va = 0; va < 3; va = va + 1) begin : g_ax
                assign vel_src[32*va +: 32] = vel_ctrl_q[va] ? in_vel_obs[32*va +: 32]
                                                             : in_vel[32*va +: 32];
            end
        end else begin : g_vel_fir
            assign vel_src = in_vel;
            wire unused_vel_obs = &{1'b0, in_vel_obs, vel_ctrl_q[2:0]};
        end
    endgenerate

    // the snapshot: all axes, all words, in one clock
    reg [95:0] sn_pos, sn_homed, sn_idx;           // axis 0 in the low bits
    reg [3*VEL_BITS-1:0] sn_vel;                   // (the bits above VEL_BITS are its sign)
    wire [3*VEL_BITS-1:0] in_vel_n;
    genvar gv;
    generate
        for (gv = 0; gv < 3; gv = gv + 1) begin : g_vel_n
            assign in_vel_n[VEL_BITS*gv +: VEL_BITS] = vel_src[32*gv +: VEL_BITS];
            if (VEL_BITS < 32) begin : g_unused_hi
                wire unused_vel_sign = &{1'b0, vel_src[32*gv + VEL_BITS +: 32 - VEL_BITS]};
            end
        end
    endgenerate
    reg [47:0] sn_icnt, sn_ovs;
    reg [8:0]  sn_faults;
    reg [2:0]  sn_homed_f;

    always @(posedge clk) begin
        if (rst) begin
            sn_pos     <= 96'd0;
            sn_homed   <= 96'd0;
            sn_vel     <= {(3*VEL_BITS){1'b0}};
            sn_idx     <= 96'd0;
            sn_icnt    <= 48'd0;
            sn_ovs     <= 48'd0;
            sn_faults  <= 9'd0;
            sn_homed_f <= 3'b000;
        end else if (snap_now) begin
            sn_pos     <= in_pos;
            sn_homed   <= in_pos_homed;
            sn_vel     <= in_vel_n;
            sn_idx     <= in_index_pos;
            sn_icnt    <= in_index_count;
            sn_ovs     <= in_overspeed_count;
            sn_faults  <= in_faults;
            sn_homed_f <= in_homed;
        end
    end

    // ---------------------------------------------------------------- watchdog
    // Restarted by the key (or CTRL.FAULT_CLR): expires exactly wd_timeout_q * CLK_PER_US clocks
    // after the restarting edge, then stays expired (sticky) until CTRL.FAULT_CLR.
    reg [PW-1:0] wd_pre;
    reg [19:0]   wd_cnt;
    reg          wd_exp_q;
    wire         wd_restart = pet_w | fault_clr_w;

    always @(posedge clk) begin
        if (rst) begin
            wd_pre   <= {PW{1'b0}};
            wd_cnt   <= WD_RST;
            wd_exp_q <= 1'b0;
        end else if (wd_restart) begin  // a key restarts the count; only FAULT_CLR clears
            wd_pre   <= {PW{1'b0}};
            wd_cnt   <= wd_timeout_q;
            wd_exp_q <= wd_exp_q & ~fault_clr_w;
        end else if (wd_cnt != 20'd0) begin
            if (wd_pre == PLAST) begin
                wd_pre <= {PW{1'b0}};
                wd_cnt <= wd_cnt - 20'd1;
                if (wd_cnt == 20'd1)
                    wd_exp_q <= 1'b1;
            end else begin
                wd_pre <= wd_pre + 1'b1;
            end
        end
    end
    assign wdog_expired = wd_exp_q;

    // ---------------------------------------------------------------- integrity alarms
    // HW_FAULT (rtl/top/README.md, "Integrity alarms"): a cause bit latches on the clock after
    // its alarm, forces zero torque through the top's kill path (sec_fault, as the watchdog's
    // expiry does) and stays until CTRL.FAULT_CLR (a cause still present latches again at once).
    // SEC bit 0: an even-parity bit beside each command word (written with it, on clk_g) and
    // each snapshot word the servo reads (POS, VEL), compared on every clock. SEC bit 3: the
    // servo-tick counter never exceeds TICK_DIV - 1, nor the watchdog's prescaler CLK_PER_US - 1
    // (an upset above would count through the whole counter: no tick for seconds, a slow
    // watchdog); the tick counter then restarts its period (one tick late).
    wire [4:0] sec_now;
    wire [4:0] hw_fault;       // HW_FAULT's cause bits, latched
    generate
        if (SEC_B[0]) begin : g_sec_regs
            reg [2:0] p_tq, p_ofs, p_mode, p_lim, p_pos, p_vel;
            reg       p_ctrl, p_tick, p_wd;
            always @(posedge clk_g) begin
                if (rst) begin
                    p_ctrl <= 1'b0;
                    p_tick <= ^TICK_RST;
                    p_wd   <= ^WD_RST;
                    p_tq   <= 3'b000;
                    p_ofs  <= 3'b000;
                    p_mode <= 3'b000;                 // ^2'b11 (OFF)
                    p_lim  <= 3'b000;
                end else begin
                    if (wr && glob_w && wa[3:0] == A_CTRL[3:0]) p_ctrl <= ^s_wdata[3:0];
                    if (tick_div_w && tick_ok) p_tick <= ^s_wdata[23:0];
                    if (wd_to_w && wd_ok) p_wd <= ^s_wdata[19:0];
                    if (wr && axis_w && ax_w != 2'd3) begin
                        case (wa[3:0])
                            R_TORQUE:   p_tq[ax_w]   <= ^s_wdata[15:0];
                            R_OFFSET:   p_ofs[ax_w]  <= ^s_wdata[9:0];
                            R_MODE:     p_mode[ax_w] <= ^s_wdata[1:0];
                            R_TQ_LIMIT: p_lim[ax_w]  <= ^s_wdata[15:0];
                            default: ;
                        endcase
                    end
                end
            end
            integer pa;
            always @(posedge clk) begin
                if (rst) begin
                    p_pos <= 3'b000;
                    p_vel <= 3'b000;
                end else if (snap_now) begin
                    for (pa = 0; pa < 3; pa = pa + 1) begin
                        p_pos[pa] <= ^in_pos[32*pa +: 32];
                        p_vel[pa] <= ^in_vel_n[VEL_BITS*pa +: VEL_BITS];
                    end
                end
            end
            wire [2:0] e_tq, e_ofs, e_mode, e_lim, e_pos, e_vel;
            genvar pg;
            for (pg = 0; pg < 3; pg = pg + 1) begin : g_ax
                assign e_tq[pg]   = ^torque_q[16*pg +: 16] ^ p_tq[pg];
                assign e_ofs[pg]  = ^offset_q[10*pg +: 10] ^ p_ofs[pg];
                assign e_mode[pg] = ^mode_q[2*pg +: 2] ^ p_mode[pg];
                assign e_lim[pg]  = ^tq_lim_q[16*pg +: 16] ^ p_lim[pg];
                assign e_pos[pg]  = ^sn_pos[32*pg +: 32] ^ p_pos[pg];
                assign e_vel[pg]  = ^sn_vel[VEL_BITS*pg +: VEL_BITS] ^ p_vel[pg];
            end
            assign sec_now[0] = |{e_tq, e_ofs, e_mode, e_lim, e_pos, e_vel,
                                  ^{axis_en_q, global_en_q} ^ p_ctrl,
                                  ^tick_div_q ^ p_tick, ^wd_timeout_q ^ p_wd};
        end else begin : g_no_sec_regs
            assign sec_now[0] = 1'b0;
        end
        if (SEC_B[3]) begin : g_sec_tick
            assign tick_bad   = tick_cnt >= tick_div_q;
            assign sec_now[3] = tick_bad || (wd_pre > PLAST);
        end else begin : g_no_sec_tick
            assign tick_bad   = 1'b0;
            assign sec_now[3] = 1'b0;
        end
    endgenerate
    assign sec_now[1] = SEC_B[1] & in_sec_err[1];
    assign sec_now[2] = SEC_B[2] & in_sec_err[2];
    assign sec_now[4] = SEC_B[4] & in_sec_err[4];
    wire unused_sec_in = &{1'b0, in_sec_err[0], in_sec_err[3]};

    generate
        if (SEC != 0) begin : g_hw_fault
            reg [4:0] hw_fault_q;
            always @(posedge clk) begin
                if (rst)
                    hw_fault_q <= 5'd0;
                else
                    hw_fault_q <= sec_now | (hw_fault_q & ~{5{fault_clr_w}});
            end
            assign hw_fault = hw_fault_q;
        end else begin : g_no_hw_fault                 // (nothing built: no latch)
            assign hw_fault = 5'd0;
            wire unused_sec_now = &{1'b0, sec_now};
        end
    endgenerate
    assign sec_fault = |hw_fault;

    // ---------------------------------------------------------------- status
    reg [2:0] index_seen;
    reg       cfg_err_q, bus_err_q, proto_err_q;

    always @(posedge clk) begin
        if (rst) begin
            index_seen <= 3'b000;
        end else begin
            for (i = 0; i < 3; i = i + 1)
                if (in_index_count[16*i +: 16] != 16'd0) index_seen[i] <= 1'b1;
        end
    end

    always @(posedge clk_g) begin
        if (rst) begin
            cfg_err_q   <= 1'b0;
            bus_err_q   <= 1'b0;
            proto_err_q <= 1'b0;
        end else begin
            cfg_err_q   <= cfg_err_set | (cfg_err_q & ~fault_clr_w);
            bus_err_q   <= (s_req && !mapped(s_addr)) | (bus_err_q & ~fault_clr_w);
            proto_err_q <= s_proto_err | (proto_err_q & ~fault_clr_w);
        end
    end

    wire [31:0] status = {15'd0, sec_fault, proto_err_q, bus_err_q, cfg_err_q, wd_exp_q, 1'b0, in_homed,
                          1'b0, index_seen, 1'b0, in_fault};

    // ---------------------------------------------------------------- read mux
    wire [ADDR_BITS-1:0] ra = s_raddr;
    wire [1:0]  ax_d = ra[5:4] - 2'd1;
    wire [1:0]  ax_r = (ax_d == 2'd3) ? 2'd0 : ax_d;  // (address block 0 is the globals)
    wire [VEL_BITS-1:0] vel_sel = sn_vel[VEL_BITS*ax_r +: VEL_BITS];
    // counts per second = floor(v * SAMPLE_HZ / 2**VEL_LOG2W), bits [VEL_LOG2W +: 32] of the
    // product (|v| < 2**31 / SAMPLE_HZ * 2**VEL_LOG2W). The constant product as shift-adds of
    // the canonical signed digits of SAMPLE_HZ (1 MHz: 2^20 + 2^14 - 2^16 + 2^9 + 2^6), in the
    // low PRW bits only (two's complement: the low bits of a sum need only the low bits).
    localparam integer PRW = VEL_LOG2W + 32;
    localparam integer NCD = 33;                        // digits of a 32-bit constant
    wire [PRW-1:0] vel_x = {{(PRW - VEL_BITS){vel_sel[VEL_BITS-1]}}, vel_sel};
    genvar gd;
    generate
        for (gd = 0; gd < NCD; gd = gd + 1) begin : g_csd
            wire [PRW-1:0] prev, acc;                   // sum of the terms below / to digit gd
            if (gd == 0) begin : g_first
                assign prev = {PRW{1'b0}};
            end else begin : g_next
                assign prev = g_csd[gd - 1].acc;
            end
            if (gd >= PRW || csd_digit(SAMPLE_HZ, gd) == 0) begin : g_0
                assign acc = prev;
            end else if (gd == 0) begin : g_lsb
                assign acc = (csd_digit(SAMPLE_HZ, 0) > 0) ? vel_x : ~vel_x + 1'b1;
                wire unused_prev = &{1'b0, prev};   // (zero)
            end else if (csd_digit(SAMPLE_HZ, gd) > 0) begin : g_add
                assign acc = {prev[PRW-1:gd] + vel_x[PRW-1-gd:0], prev[gd-1:0]};
            end else begin : g_sub
                assign acc = {prev[PRW-1:gd] - vel_x[PRW-1-gd:0], prev[gd-1:0]};
            end
        end
    endgenerate
    wire [PRW-1:0] vel_prod = g_csd[NCD - 1].acc;
    wire [31:0] vel_cps = vel_prod[PRW-1:VEL_LOG2W];
    wire [VEL_LOG2W-1:0] unused_vel_lo = vel_prod[VEL_LOG2W-1:0];
    wire unused_vel_x = &{1'b0, vel_x};  // (the top bits of the shifted terms fall off)

    // digit di (-1, 0, +1) of the canonical signed-digit form of cv > 0 (no two adjacent nonzero)
    function integer csd_digit;
        input integer cv;
        input integer di;
        integer x, j, d;
        begin
            x = cv;
            d = 0;
            for (j = 0; j <= di; j = j + 1) begin
                d = (x % 2 == 0) ? 0 : 2 - (x % 4);
                x = (x - d) / 2;
            end
            csd_digit = d;
        end
    endfunction

    always @(*) begin
        s_rdata = UNMAPPED;
        if (is_cap(ra[ADDR_BITS-1:2])) begin
            s_rdata = in_cap[32*ra[1:0] +: 32];
        end else if (ra == A_HWF) begin
            s_rdata = {19'd0, SEC_B, 3'd0, hw_fault};
        end else if (mapped(ra)) begin
            if (ra[5:4] == 2'b00) begin
                case (ra[3:0])
                    A_ID[3:0]:       s_rdata = ID_VALUE;
                    A_CTRL[3:0]:     s_rdata = {28'd0, axis_en_q, global_en_q};
                    A_STATUS[3:0]:   s_rdata = status;
                    A_SEQ[3:0]:      s_rdata = seq_q;
                    A_TICK_DIV[3:0]: s_rdata = {8'd0, tick_div_q};
                    A_IRQ[3:0]:      s_rdata = {30'd0, irq_missed_q, irq_tick_q};
                    A_WDOG[3:0]:     s_rdata = 32'd0;
                    A_SCRATCH[3:0]:  s_rdata = scratch_q;
                    A_WDOG_TO[3:0]:  s_rdata = {12'd0, wd_timeout_q};
                    A_SKEW[3:0]:     s_rdata = {16'd0, SKEW_C};
                    A_FRAME[3:0]:    s_rdata = {16'd0, FRAME_C};
                    A_CLK[3:0]:      s_rdata = CLK_KHZ;
                    A_VEL_CTRL[3:0]: s_rdata = {12'd0, vel_ctrl_q};
                    A_HARM_CTRL[3:0]: s_rdata = harm_ctrl_rd;
                    A_HARM_ADDR[3:0]: s_rdata = harm_addr_rd;
                    default:         s_rdata = harm_data_rd;     // A_HARM_DATA
                endcase
            end else begin
                case (ra[3:0])
                    R_POS:       s_rdata = sn_pos[32*ax_r +: 32];
                    R_VEL:       s_rdata = vel_cps;
                    R_IDX_POS:   s_rdata = sn_idx[32*ax_r +: 32];
                    R_COUNTS:    s_rdata = {sn_icnt[16*ax_r +: 16], sn_ovs[16*ax_r +: 16]};
                    R_POS_HOMED: s_rdata = sn_homed[32*ax_r +: 32];
                    R_FLAGS:     s_rdata = {27'd0, sn_homed_f[ax_r], 1'b0, sn_faults[3*ax_r +: 3]};
                    R_TORQUE:    s_rdata = {16'd0, torque_q[16*ax_r +: 16]};
                    R_OFFSET:    s_rdata = {22'd0, offset_q[10*ax_r +: 10]};
                    R_MODE:      s_rdata = {30'd0, mode_q[2*ax_r +: 2]};
                    R_TQ_LIMIT:  s_rdata = {16'd0, tq_lim_q[16*ax_r +: 16]};
                    R_CAL_CTRL:  s_rdata = {24'd0, cal_ctrl_q[8*ax_r +: 8]};
                    R_CAL_STAT:  s_rdata = in_cal_stat[32*ax_r +: 32];
                    R_CAL_OFS:   s_rdata = in_cal_ofs[32*ax_r +: 32];
                    R_CAL_GAIN:  s_rdata = in_cal_gain[32*ax_r +: 32];
                    default:     s_rdata = {16'd0, in_cal_phase[16*ax_r +: 16]};
                endcase
            end
        end
    end
    // simulation only: the bus clock's enable (reset, an access, a pulse to clear)
    `HG_SIM_EN((rst | s_req | s_proto_err | ctl_fault_clear | (|ctl_home_arm) | snap_req | cfg_err_set))
endmodule

`default_nettype wire
