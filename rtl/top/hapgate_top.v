// SPDX-License-Identifier: Apache-2.0
// The hapgate FPGA: three encoder interpolators, sinusoidal commutation of three motors through
// the six-channel DAC scheduler, and the DSP bus with the register file (snapshot, servo-tick
// interrupt, watchdog). A DAC output stage forces zero torque on a watchdog timeout, global or
// axis disable, or axis fault. Signals, timing and that bound: rtl/top/README.md.
`timescale 1ns / 1ps
`default_nettype none
`include "hg_sim.vh"

module hapgate_top #(
    parameter integer CLK_HZ        = 48_000_000, // FPGA clock: a multiple of 1 MHz and of SAMPLE_HZ
    parameter integer SAMPLE_HZ     = 1_000_000,  // ADC sample rate
    parameter integer LUT_BITS      = 7,          // arcsine LUT codes per 45 deg (1024 counts/line)
    parameter         ASIN_FILE     = "asin.hex", // arcsine table (hapgate.golden.interp.write_lut)
    parameter integer VEL_LOG2W     = 8,          // velocity window 2**VEL_LOG2W samples
    parameter integer AMP_MIN       = 40,         // signal-loss amplitude window, ADC codes
    parameter integer AMP_MAX       = 170,        // (upper bound of that window)
    parameter integer LOSS_SAMPLES  = 16,         // consecutive bad samples -> signal loss
    parameter integer CAL           = 0,          // 1: online encoder calibration in every axis
    parameter         CAL_LUT_FILE  = "asin512.hex", // CAL = 1: its arcsine table (enccal.cal_table)
    parameter integer CAL_LINES_LOG2 = 3,         // CAL = 1: calibration block 2**N lines
    parameter integer CAL_NLOG      = 14,         // CAL = 1: blocks of 2**N samples ignored
    parameter integer COARSE        = 0,          // 1: plain quadrature, fine angle zeroed (Z-width)
    parameter integer VEL_OBS       = 0,          // 1: tracking velocity observer beside the FIR
    parameter integer VEL_OBS_SEL   = 0,          // 1: VEL_CTRL.SEL resets to 7 (VEL = the observer)
    parameter integer ANGLE         = 0,          // 1: ratio angle stage atan(smaller / larger)
    parameter integer RATIO_BITS    = 10,         // ANGLE = 1: ratio table 2**RATIO_BITS entries
    parameter         RATIO_FILE    = "atan.hex", // ANGLE = 1: the ratio table (angle.write_ratio_table)
    parameter integer ANGLE_REG     = 0,          // 1: register after the angle select (latency + 1)
    parameter integer HARM          = 0,          // 1 (ANGLE = 1): harmonic table, HARM_* registers
    parameter integer HARM_LOG2     = 6,          // HARM = 1: 2**HARM_LOG2 table entries per line
    parameter integer LINES_LOG2    = 10,         // encoder lines per revolution = 2**LINES_LOG2
    parameter integer POLE_PAIRS    = 2,          // motor electrical cycles per revolution
    parameter integer SKEW_NS       = 2000,       // DAC channel-to-channel skew
    parameter integer FRAME_NS      = 16000,      // commutation frame
    parameter integer SETTLE_NS     = 16000,      // DAC settling time
    parameter integer WR_CYCLES     = 1,          // DAC write strobe length, clocks (at least
                                                  // DAC_TWR_NS: the longer of the two is used)
    parameter integer DAC_TWR_NS    = 50,         // DAC's minimum write pulse (DAC7625 t_WCS)
    // ---- ADC sample clock (adc_clk; rtl/top/README.md, "Converter timing"): the 8-bit ADC's
    // figures (HI1175 / CXD1175A class; the stated conservative ones are marked) and the FPGA's
    parameter integer ADC_CLK       = 1,          // 1: drive adc_clk (0: held low, no checks)
    parameter integer ADC_FMAX_HZ   = 20_000_000, // maximum conversion rate (HI1175: 20 MSPS)
    parameter integer ADC_TPW_NS    = 23,         // clock high and low, minimum (CXD1175A)
    parameter integer ADC_TPW_MAX_NS = 1100,      // clock high and low, maximum (CXD1175A)
    parameter integer ADC_TOD_NS    = 50,         // output delay after a clock edge, max (stated)
    parameter integer ADC_TH_NS     = 0,          // output hold after a clock edge, min (stated)
    parameter integer ADC_IO_NS     = 25,         // FPGA adc_clk to pin + board + input setup
    parameter integer ADC_IH_NS     = 5,          // FPGA input hold (+ skew) the data must cover
    parameter integer ADC_CAPTURE_LEAD = 0,       // clocks before the core's capture edge at which
                                                  // the board takes the pins (HX8K adapter: 1)
    parameter integer ADDR_BITS     = 8,          // sine ROM: 2**ADDR_BITS quarter-wave entries
    parameter integer MAG_BITS      = 13,         // sine ROM entry width
    parameter integer FS            = 8191,       // sine ROM full scale
    parameter         SINE_FILE     = "sine.hex", // sine ROM (hapgate.golden.sine.write_rom)
    parameter integer DAC_BITS      = 14,         // DAC width
    parameter integer OFFSET_BINARY = 0,          // DAC coding: 0 two's complement, 1 offset binary
    parameter integer BUS_ADDR_BITS = 8,          // DSP word-address lines decoded
    parameter integer SERIAL_MUL    = 0,          // 1: commutator multiplies in 16 clocks (LUT-only boards)
    parameter integer SQ_RAM        = 0,          // 1: interpolators' signal-loss squares from block RAM
    parameter integer HOLD_C        = 0,          // 1: interpolators without stage-D copies
    parameter integer LATCH_RAM     = 0,          // 1: commutator's latched torques/limits in block RAM
    parameter integer CAPTURE       = 1,          // 1: raw ADC capture buffer, CAP_* registers
                                                  // (0: they read 0 and ignore writes)
    parameter integer CAP_DEPTH_LOG2 = 10,        // CAPTURE = 1: 2**N 16-bit entries (block RAM)
    // ---- integrity countermeasures against upsets and stuck-at faults of the FPGA's own
    // flip-flops (rtl/top/README.md, "Integrity alarms"; each latches its HW_FAULT bit and
    // forces zero torque; 0: not built, the design bit for bit without them)
    parameter integer SEC_REGS      = 0,          // 1: parity of the command and snapshot words
    parameter integer SEC_COMM      = 0,          // 1: a second commutator compared at its DAC port
    parameter integer SEC_DAC       = 0,          // 1: the DAC pin registers duplicated, compared
    parameter integer SEC_TICK      = 0,          // 1: servo-tick and watchdog counters range-checked
    parameter integer SEC_POS       = 0           // 1: each axis's position checked sample to sample
) (
    input  wire                     clk,
    input  wire                     rst,
    // ADCs and encoders (axis 0 in the low bits)
    output wire                     adc_strobe,     // words captured at the end of this cycle
    output reg                      adc_clk,        // the converters' sample clock (SAMPLE_HZ)
    input  wire [23:0]              adc_a,
    input  wire [23:0]              adc_b,
    input  wire [2:0]               enc_index,
    // DACs
    output reg  [DAC_BITS-1:0]      dac_data,
    output reg  [2:0]               dac_addr,
    output reg                      dac_wr_n,       // the DAC loads on the rising edge
    // DSP bus (asynchronous) and interrupt
    input  wire                     bus_ce_n,
    input  wire                     bus_re_n,
    input  wire                     bus_we_n,
    input  wire [BUS_ADDR_BITS-1:0] bus_addr,
    input  wire [31:0]              bus_data_in,
    output wire [31:0]              bus_data_out,
    output wire                     bus_data_oe,
    output wire                     bus_ready,
    output wire                     irq
    `HG_SIM_TOP_PORTS  // simulation only (rtl/include/hg_sim.vh): the stage clocks, enables
);
    localparam integer COUNT_BITS  = LUT_BITS + 3 + LINES_LOG2;  // counts per revolution, log2
    localparam integer AB          = ADDR_BITS + 2;              // commutation angle bits
    localparam integer CLK_KHZ     = CLK_HZ / 1000;
    localparam integer SKEW_CLOCKS = CLK_KHZ * SKEW_NS / 1_000_000;
    localparam integer FRAME_CLOCKS = CLK_KHZ * FRAME_NS / 1_000_000;
    // the DAC write strobe: WR_CYCLES clocks, but never shorter than the DAC's t_WCS
    localparam integer WR_MIN      = (DAC_TWR_NS * CLK_KHZ + 999_999) / 1_000_000;
    localparam integer WR_EFF      = (WR_CYCLES > WR_MIN) ? WR_CYCLES : WR_MIN;
    localparam integer ZERO_I      = (OFFSET_BINARY != 0) ? (1 << (DAC_BITS - 1)) : 0;
    localparam [DAC_BITS-1:0] ZERO = ZERO_I[DAC_BITS-1:0];       // the zero-torque DAC word

    generate
        if (AB != 10) begin : g_bad_offset
            hapgate_top_needs_ADDR_BITS_8_for_the_10_bit_OFFSET_register u_stop ();
        end
        if (COUNT_BITS > 26) begin : g_bad_counts
            hapgate_top_LUT_BITS_plus_LINES_LOG2_must_be_at_most_23 u_stop ();
        end
        if (DAC_TWR_NS < 0 || DAC_TWR_NS > 1000) begin : g_bad_twr
            hapgate_top_DAC_TWR_NS_must_be_0_to_1000 u_stop ();
        end
        if (HOLD_C != 0 && CLK_HZ < 2 * SAMPLE_HZ) begin : g_bad_hold_c
            hapgate_top_HOLD_C_needs_CLK_HZ_at_least_2_SAMPLE_HZ u_stop ();
        end
        // the ratio stage runs at 1024 counts per line here: the registers, the commutation
        // offsets and the firmware count 2**20 per revolution (a 4096/line top would need POS,
        // IDX_POS, POS_HOMED and VEL rescaled: not built)
        if (ANGLE != 0 && LUT_BITS != 7) begin : g_bad_angle_lut
            hapgate_top_ANGLE_1_needs_LUT_BITS_7_the_registers_count_1024_per_line u_stop ();
        end
        // the table read-back (HARM_DATA) uses the interpolator's clocks without a sample
        if (HARM != 0 && CLK_HZ < 2 * SAMPLE_HZ) begin : g_bad_harm_clk
            hapgate_top_HARM_needs_CLK_HZ_at_least_2_SAMPLE_HZ u_stop ();
        end
        if (SEC_REGS < 0 || SEC_REGS > 1 || SEC_COMM < 0 || SEC_COMM > 1 || SEC_DAC < 0 ||
            SEC_DAC > 1 || SEC_TICK < 0 || SEC_TICK > 1 || SEC_POS < 0 || SEC_POS > 1)
        begin : g_bad_sec
            hapgate_top_SEC_parameters_must_be_0_or_1 u_stop ();
        end
    endgenerate
    localparam integer SEC = SEC_REGS + 2 * SEC_COMM + 4 * SEC_DAC + 8 * SEC_TICK + 16 * SEC_POS;
    wire [4:0] sec_err;        // the top's integrity alarms this clock (HW_FAULT bits 1, 2, 4)
    wire       sec_fault;      // HW_FAULT latched in the register file

    // ---------------------------------------------------------------- ADC sample clock
    // The converters' clock (rtl/top/README.md, "Converter timing"): SAMPLE_HZ, ADC_HI clocks
    // high, rising ADC_Q clocks before the core's capture edge (the edge that ends the adc_strobe
    // clock), so every pin read sits inside one phase of it: ADC_SU clocks after its last edge
    // (>= t_OD + the IO budget) and ADC_HO clocks before its next (>= the input hold - t_H).
    // A part may change its outputs after either edge; both count. With ADC_CAPTURE_LEAD = 0
    // the pins are read at the core's capture edge, centred in a 50 % clock. With a lead (the
    // HX8K pair adapter) they are read twice per sample, at LEAD and LEAD + ADC_S clocks before
    // it (B and A words): both reads in the high phase, so the A and B words of a sample come
    // from the same converter cycle whichever edge the part's outputs follow. The word taken
    // for sample n is the conversion of ADC clock cycle n - 3 (2.5-clock pipeline; cycle n
    // starts with the rise ADC_Q clocks before capture n). The counter mirrors sample_strobe's
    // (same reset, same period); the clock stays low from reset to its first rise (no runt).
    localparam integer ADC_DIV  = CLK_HZ / SAMPLE_HZ;
    localparam integer ADC_S    = ADC_DIV - ADC_DIV / 2;               // A read -> B read
    localparam integer ADC_M    = (ADC_DIV - ADC_S - 1) / 2;           // lead: margin each side
    localparam integer ADC_HI   = (ADC_CAPTURE_LEAD == 0) ? ADC_DIV / 2 : ADC_S + 2 * ADC_M;
    localparam integer ADC_Q    = (ADC_CAPTURE_LEAD == 0) ? ADC_HI / 2
                                                          : ADC_CAPTURE_LEAD + ADC_S + ADC_M;
    localparam integer ADC_SU   = (ADC_CAPTURE_LEAD == 0) ? ADC_Q : ADC_M;
    localparam integer ADC_HO   = (ADC_CAPTURE_LEAD == 0) ? ADC_HI - ADC_Q : ADC_M;
    localparam integer ADC_LO   = ADC_DIV - ADC_HI;
    localparam integer ADC_PW   = (ADC_HI < ADC_LO) ? ADC_HI : ADC_LO;   // shorter phase
    localparam integer ADC_PWX  = (ADC_HI < ADC_LO) ? ADC_LO : ADC_HI;   // longer phase
    localparam integer ADC_CW   = (ADC_DIV > 2) ? $clog2(ADC_DIV) : 1;
    localparam integer ADC_PH0_I  = (ADC_Q + ADC_DIV - 1) % ((ADC_DIV > 0) ? ADC_DIV : 1);
    localparam integer ADC_LAST_I = ADC_DIV - 1;
    localparam [ADC_CW-1:0] ADC_PH0  = ADC_PH0_I[ADC_CW-1:0];   // phase after reset
    localparam [ADC_CW-1:0] ADC_LAST = ADC_LAST_I[ADC_CW-1:0];
    localparam [ADC_CW-1:0] ADC_FALL = ADC_HI[ADC_CW-1:0];
    generate
        if (ADC_CLK != 0) begin : g_adc_checks
            if (ADC_DIV < 2 || ADC_DIV > 2000 || ADC_CAPTURE_LEAD < 0 ||
                ADC_CAPTURE_LEAD > ADC_M) begin : g_adc_div
                hapgate_top_ADC_CLK_needs_2_to_2000_clocks_per_sample_and_a_lead_le_ADC_M
                    u_stop ();
            end
            if (SAMPLE_HZ > ADC_FMAX_HZ) begin : g_adc_rate
                hapgate_top_SAMPLE_HZ_above_the_ADC_maximum_conversion_rate u_stop ();
            end
            if (ADC_PW < 1 || ADC_PW * 1_000_000 < ADC_TPW_NS * CLK_KHZ) begin : g_adc_pw
                hapgate_top_ADC_clock_high_or_low_shorter_than_ADC_TPW_NS u_stop ();
            end
            if (ADC_PWX * 1_000_000 > ADC_TPW_MAX_NS * CLK_KHZ) begin : g_adc_pw_max
                hapgate_top_ADC_clock_high_or_low_longer_than_ADC_TPW_MAX_NS u_stop ();
            end
            if (ADC_SU < 1 ||
                ADC_SU * 1_000_000 < (ADC_TOD_NS + ADC_IO_NS) * CLK_KHZ) begin : g_adc_su
                hapgate_top_ADC_capture_earlier_than_t_OD_plus_the_IO_budget u_stop ();
            end
            if (ADC_HO < 1 ||
                ADC_HO * 1_000_000 < (ADC_IH_NS - ADC_TH_NS) * CLK_KHZ) begin : g_adc_ho
                hapgate_top_ADC_capture_later_than_the_next_edge_allows u_stop ();
            end
        end
    endgenerate

    reg [ADC_CW-1:0] adc_ph;   // clocks since the ADC clock's rising phase
    wire [ADC_CW-1:0] adc_ph_next = (adc_ph == ADC_LAST) ? {ADC_CW{1'b0}} : adc_ph + 1'b1;
    always @(posedge clk) begin
        if (rst || ADC_CLK == 0) begin
            adc_ph  <= ADC_PH0;
            adc_clk <= 1'b0;
        end else begin
            adc_ph  <= adc_ph_next;
            if (adc_ph_next == {ADC_CW{1'b0}}) adc_clk <= 1'b1;
            else if (adc_ph_next == ADC_FALL) adc_clk <= 1'b0;
        end
    end

    // ---------------------------------------------------------------- interpolators
    wire        m_valid;
    wire [95:0] pos, pos_homed, vel, index_pos;
    wire [47:0] index_count, overspeed_count;
    wire [2:0]  homed, fault;
    wire [8:0]  faults;
    wire        fault_clear;
    wire [2:0]  home_arm;
    wire [2:0]  cal_en, cal_freeze;
    wire [11:0] cal_mu;
    wire [95:0] vel_obs;
    wire [11:0] obs_bw;
    wire [2:0]  obs_type3;
    wire [2:0]  harm_en, harm_we;
    wire [7:0]  harm_addr, harm_wdata;
    wire [23:0] harm_rdata;
    wire [47:0] cal_phase;
    wire        cal_valid;

    wire [47:0] cal_ofs_a, cal_ofs_b, cal_gain_a, cal_gain_b, cal_updates;
    wire [23:0] cal_gear;
    enc_interp3 #(
        .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .AXES(3), .LUT_BITS(LUT_BITS),
        .LUT_FILE(ASIN_FILE), .VEL_LOG2W(VEL_LOG2W), .AMP_MIN(AMP_MIN), .AMP_MAX(AMP_MAX),
        .LOSS_SAMPLES(LOSS_SAMPLES), .CAL(CAL), .CAL_LUT_FILE(CAL_LUT_FILE),
        .CAL_LINES_LOG2(CAL_LINES_LOG2), .CAL_NLOG(CAL_NLOG), .COARSE(COARSE),
        .SQ_RAM(SQ_RAM), .HOLD_C(HOLD_C), .VEL_OBS(VEL_OBS),
        .ANGLE(ANGLE), .RATIO_BITS(RATIO_BITS), .RATIO_FILE(RATIO_FILE), .ANGLE_REG(ANGLE_REG),
        .HARM(HARM), .HARM_LOG2(HARM_LOG2)
    ) u_interp (
        .clk(clk), .rst(rst), .adc_strobe(adc_strobe), .adc_a(adc_a), .adc_b(adc_b),
        .enc_index(enc_index), .ctl_fault_clear({3{fault_clear}}), .ctl_home_arm(home_arm),
        .m_valid(m_valid), .m_pos(pos), .m_pos_homed(pos_homed), .m_vel(vel),
        .m_index_pos(index_pos), .m_index_count(index_count),
        .m_overspeed_count(overspeed_count), .m_homed(homed), .m_faults(faults),
        .m_fault(fault),
        .ctl_cal_en(cal_en), .ctl_cal_freeze(cal_freeze), .cfg_cal_mu(cal_mu),
        .m_cal_valid(cal_valid), .m_cal_ofs_a(cal_ofs_a), .m_cal_ofs_b(cal_ofs_b),
        .m_cal_gain_a(cal_gain_a), .m_cal_gain_b(cal_gain_b), .m_cal_phase(cal_phase),
        .m_cal_gear(cal_gear), .m_cal_updates(cal_updates),
        // harmonic correction (HARM = 1): table and enable from the HARM_* registers
        .ctl_harm_en(harm_en), .cfg_harm_we(harm_we), .cfg_harm_addr(harm_addr),
        .cfg_harm_data(harm_wdata), .m_harm_rdata(harm_rdata),
        .m_vel_obs(vel_obs), .cfg_obs_bw(obs_bw), .cfg_obs_type3(obs_type3)
        `HG_SIM_BIND(({sim_gclk_de, sim_gclk_c, sim_gclk_b, sim_gclk_a}), sim_gate_en[3:0])
    );
    wire unused_cal_valid = &{1'b0, cal_valid};  // (the registers read the live state)

    // The axis faults as the rest of the FPGA acts on them (zero torque, STATUS.FAULT). With
    // SEC_REGS a reported fault holds until CTRL.FAULT_CLR and the interpolator's first clean
    // report after it, whether or not the interpolator's own sticky flag holds it: an upset or
    // a stuck bit of the reported copy (m_faults) cannot zero an axis for a few frames and let
    // its torque step back unannounced. Fault-free the two are equal (the interpolator's flags
    // are sticky themselves, and cleared by the same FAULT_CLR).
    wire [8:0] faults_k;
    wire [2:0] fault_k;
    generate
        if (SEC_REGS != 0) begin : g_fault_hold
            reg [8:0] held;       // every fault reported since the last clear
            reg       clr_pend;   // FAULT_CLR seen, the interpolators not yet clean
            always @(posedge clk) begin
                if (rst) begin
                    held     <= 9'd0;
                    clr_pend <= 1'b0;
                end else begin
                    if (m_valid) held <= clr_pend ? faults : (held | faults);
                    if (fault_clear)                    clr_pend <= 1'b1;
                    else if (m_valid && faults == 9'd0) clr_pend <= 1'b0;
                end
            end
            assign faults_k = clr_pend ? faults : (held | faults);
            assign fault_k  = {|faults_k[8:6], |faults_k[5:3], |faults_k[2:0]};
            wire unused_fault = &{1'b0, fault};   // (fault_k: the same OR, of the held copy)
        end else begin : g_fault_live
            assign faults_k = faults;
            assign fault_k  = fault;
        end
    endgenerate
    wire [95:0] cal_ofs_w, cal_gain_w, cal_stat_w;

    genvar ax;
    generate
        for (ax = 0; ax < 3; ax = ax + 1) begin : g_ax
            assign cal_ofs_w[32*ax +: 32]  = {cal_ofs_b[16*ax +: 16], cal_ofs_a[16*ax +: 16]};
            assign cal_gain_w[32*ax +: 32] = {cal_gain_b[16*ax +: 16], cal_gain_a[16*ax +: 16]};
            assign cal_stat_w[32*ax +: 32] = {cal_updates[16*ax +: 16], 8'd0, cal_gear[8*ax +: 8]};
        end
    endgenerate
    // The interpolator's data outputs are registers held between samples but not reset: until
    // the first sample they are masked where the register file would remember them (the sticky
    // "index seen") or show them live (homed).
    reg interp_ok;
    always @(posedge clk) begin
        if (rst)
            interp_ok <= 1'b0;
        else if (m_valid)
            interp_ok <= 1'b1;
    end
    wire        ok_now         = interp_ok | m_valid;
    wire [47:0] index_count_ok = ok_now ? index_count : 48'd0;
    wire [2:0]  homed_ok       = ok_now ? homed : 3'b000;

    // ---------------------------------------------------------------- position check (SEC_POS)
    // Each axis's position, sample to sample (rtl/top/README.md, "Integrity alarms"): it never
    // moves more than 3.5 quadrants (overspeed counts two, the fine angle less than one more),
    // and POS - POS_HOMED (the home) changes only in a sample with an index edge. An upset of
    // the quadrant counter, the home or a position register between them breaks one or the other.
    generate
        if (SEC_POS != 0) begin : g_sec_pos
            localparam integer QB_I = LUT_BITS + 1;                 // counts per quadrant, log2
            localparam integer JUMP_I = 7 << (QB_I - 1);             // 3.5 quadrants
            localparam [31:0] JUMP = JUMP_I[31:0];
            reg  [95:0] pos_p, home_p;      // the last sample's position and home, per axis
            reg  [47:0] icnt_p;             // ... and index count
            reg         prev_ok;            // a sample has been seen since reset
            wire [2:0]  jump, moved;
            always @(posedge clk) begin
                if (rst)
                    prev_ok <= 1'b0;
                else if (m_valid)
                    prev_ok <= 1'b1;
            end
            genvar pa;
            for (pa = 0; pa < 3; pa = pa + 1) begin : g_ax
                wire [31:0] d    = pos[32*pa +: 32] - pos_p[32*pa +: 32];
                wire [31:0] ad   = d[31] ? ~d + 32'd1 : d;
                wire [31:0] home = pos[32*pa +: 32] - pos_homed[32*pa +: 32];
                always @(posedge clk) begin
                    if (m_valid) begin
                        pos_p[32*pa +: 32]  <= pos[32*pa +: 32];
                        home_p[32*pa +: 32] <= home;
                        icnt_p[16*pa +: 16] <= index_count[16*pa +: 16];
                    end
                end
                assign jump[pa]  = ad > JUMP;
                assign moved[pa] = home != home_p[32*pa +: 32] &&
                                   index_count[16*pa +: 16] == icnt_p[16*pa +: 16];
            end
            assign sec_err[4] = m_valid & prev_ok & |{jump, moved};
        end else begin : g_no_sec_pos
            assign sec_err[4] = 1'b0;
        end
    endgenerate

    // ---------------------------------------------------------------- bus and registers
    wire        global_en, wdog_expired, tick;
    wire [2:0]  axis_en;
    wire [47:0] torque, tq_limit;
    wire [29:0] offset;
    wire [5:0]  mode;
    wire        dbg_req, dbg_we, dbg_proto_err;
    wire [BUS_ADDR_BITS-1:0] dbg_addr;
    wire [31:0] dbg_wdata;
    wire [127:0] cap_regs;

    hg_bus #(
        .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .VEL_LOG2W(VEL_LOG2W),
        .VEL_BITS(VEL_OBS != 0 ? 32 : LUT_BITS + VEL_LOG2W + 4),  // the interpolator's
        //                                       stored velocity bits (the observer's: all 32)
        .SKEW_CLOCKS(SKEW_CLOCKS), .FRAME_CLOCKS(FRAME_CLOCKS), .ADDR_BITS(BUS_ADDR_BITS),
        .VEL_OBS(VEL_OBS), .VEL_SEL_RST(VEL_OBS_SEL), .HARM(HARM), .HARM_LOG2(HARM_LOG2),
        .SEC(SEC)
    ) u_bus (
        .clk(clk), .rst(rst),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_data_in(bus_data_in), .bus_data_out(bus_data_out), .bus_data_oe(bus_data_oe),
        .bus_ready(bus_ready),
        .in_pos(pos), .in_pos_homed(pos_homed), .in_vel(vel), .in_index_pos(index_pos),
        .in_index_count(index_count_ok), .in_overspeed_count(overspeed_count),
        .in_homed(homed_ok), .in_faults(faults_k), .in_fault(fault_k),
        .in_cal_ofs(cal_ofs_w), .in_cal_gain(cal_gain_w), .in_cal_phase(cal_phase),
        .in_cal_stat(cal_stat_w), .ctl_cal_en(cal_en), .ctl_cal_freeze(cal_freeze),
        .cfg_cal_mu(cal_mu),
        .in_vel_obs(vel_obs), .cfg_obs_bw(obs_bw), .cfg_obs_type3(obs_type3),
        .ctl_harm_en(harm_en), .cfg_harm_we(harm_we), .cfg_harm_addr(harm_addr),
        .cfg_harm_data(harm_wdata), .in_harm_rdata(harm_rdata), .in_cap(cap_regs),
        .ctl_global_en(global_en), .ctl_axis_en(axis_en), .ctl_fault_clear(fault_clear),
        .ctl_home_arm(home_arm), .ctl_torque(torque), .ctl_offset(offset), .ctl_mode(mode),
        .ctl_tq_limit(tq_limit), .wdog_expired(wdog_expired), .irq(irq), .tick(tick),
        .dbg_req(dbg_req), .dbg_we(dbg_we), .dbg_addr(dbg_addr), .dbg_wdata(dbg_wdata),
        .dbg_proto_err(dbg_proto_err), .in_sec_err(sec_err), .sec_fault(sec_fault)
        `HG_SIM_BIND(sim_gclk_bus, sim_gate_en_bus)
    );
    wire unused_dbg = &{1'b0, tick, dbg_proto_err};

    // ---------------------------------------------------------------- capture buffer
    // The raw ADC words at the strobe (what the interpolators take), recorded on request and read
    // back through CAP_ADDR / CAP_DATA (docs/blocks/capture.md). It decodes its own writes from
    // the committed accesses; the register file only returns its four words.
    generate
        if (CAPTURE != 0) begin : g_capture
            hg_capture #(
                .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .DEPTH_LOG2(CAP_DEPTH_LOG2),
                .ADDR_BITS(BUS_ADDR_BITS), .BASE(64)
            ) u_capture (
                .clk(clk), .rst(rst), .adc_strobe(adc_strobe), .adc_a(adc_a), .adc_b(adc_b),
                .enc_index(enc_index), .s_req(dbg_req), .s_we(dbg_we), .s_addr(dbg_addr),
                .s_wdata(dbg_wdata), .m_regs(cap_regs)
            );
        end else begin : g_no_capture
            assign cap_regs = 128'd0;
            wire unused_cap = &{1'b0, dbg_req, dbg_we, dbg_addr, dbg_wdata};
        end
    endgenerate

    // ---------------------------------------------------------------- commutation inputs
    // Per-axis torque clamp to +-TQ_LIMIT (>= 32768: none), in the commutator after its frame
    // latch (LIMITS = 3: one clamp shared by the motors); an axis that is not enabled is OFF.
    reg  [5:0]              mode_eff;
    wire [3*COUNT_BITS-1:0] s_pos;
    integer k;
    always @(*) begin
        for (k = 0; k < 3; k = k + 1)
            mode_eff[2*k +: 2] = axis_en[k] ? mode[2*k +: 2] : 2'd3;
    end

    genvar g;
    generate
        for (g = 0; g < 3; g = g + 1) begin : g_pos
            assign s_pos[COUNT_BITS*g +: COUNT_BITS] = pos_homed[32*g +: COUNT_BITS];
        end
    endgenerate
    wire [95:0] unused_pos = pos_homed;

    // ---------------------------------------------------------------- commutator
    wire [DAC_BITS-1:0] c_data;
    wire [2:0]          c_addr;
    wire                c_wr_n;
    wire                m_frame;
    wire                kill_all = wdog_expired | ~global_en | sec_fault;

    commutator #(
        .CLK_HZ(CLK_HZ), .SKEW_NS(SKEW_NS), .FRAME_NS(FRAME_NS), .SETTLE_NS(SETTLE_NS),
        .WR_CYCLES(WR_EFF), .COUNT_BITS(COUNT_BITS), .POLE_PAIRS(POLE_PAIRS),
        .ADDR_BITS(ADDR_BITS), .MAG_BITS(MAG_BITS), .FS(FS), .LUT_FILE(SINE_FILE),
        .DAC_BITS(DAC_BITS), .OFFSET_BINARY(OFFSET_BINARY), .SERIAL_MUL(SERIAL_MUL),
        .LIMITS(3), .LATCH_RAM(LATCH_RAM)
    ) u_comm (
        .clk(clk), .rst(rst), .s_pos(s_pos), .s_torque(torque), .ctl_offset(offset),
        .ctl_mode(mode_eff), .ctl_enable(~kill_all), .ctl_torque_limit(tq_limit),
        .axis_fault(fault_k), .m_frame(m_frame),
        .dac_data(c_data), .dac_addr(c_addr), .dac_wr_n(c_wr_n)
        `HG_SIM_BIND(sim_gclk_comm, sim_gate_en[4])
    );
    wire unused_frame = m_frame;

    // ---------------------------------------------------------------- commutator check (SEC_COMM)
    // A second commutator (its own scheduler, latches, pipeline and sine ROM) on the same inputs;
    // its DAC port must equal the first's on every clock: the strobe always, the data and address
    // while either strobe is low (a DAC takes them only then). keep_hierarchy: synthesis must
    // not merge the two (hapgate.flows.saboteur flattens it for the fault sites).
    generate
        if (SEC_COMM != 0) begin : g_sec_comm
            wire [DAC_BITS-1:0] k_data;
            wire [2:0]          k_addr;
            wire                k_wr_n, k_frame;
            `HG_SIM_GATE_ONLY(wire k_gate_en; wire unused_k_gate = k_gate_en;)
            (* keep_hierarchy *)
            commutator #(
                .CLK_HZ(CLK_HZ), .SKEW_NS(SKEW_NS), .FRAME_NS(FRAME_NS), .SETTLE_NS(SETTLE_NS),
                .WR_CYCLES(WR_EFF), .COUNT_BITS(COUNT_BITS), .POLE_PAIRS(POLE_PAIRS),
                .ADDR_BITS(ADDR_BITS), .MAG_BITS(MAG_BITS), .FS(FS), .LUT_FILE(SINE_FILE),
                .DAC_BITS(DAC_BITS), .OFFSET_BINARY(OFFSET_BINARY), .SERIAL_MUL(SERIAL_MUL),
                .LIMITS(3), .LATCH_RAM(LATCH_RAM)
            ) u_comm_chk (
                .clk(clk), .rst(rst), .s_pos(s_pos), .s_torque(torque), .ctl_offset(offset),
                .ctl_mode(mode_eff), .ctl_enable(~kill_all), .ctl_torque_limit(tq_limit),
                .axis_fault(fault_k), .m_frame(k_frame),
                .dac_data(k_data), .dac_addr(k_addr), .dac_wr_n(k_wr_n)
                `HG_SIM_BIND(sim_gclk_comm, k_gate_en)   // (its enable equals the first's)
            );
            wire unused_k = k_frame;
            assign sec_err[1] = (k_wr_n != c_wr_n) ||
                                ((~k_wr_n | ~c_wr_n) && {k_data, k_addr} != {c_data, c_addr});
        end else begin : g_no_sec_comm
            assign sec_err[1] = 1'b0;
        end
    endgenerate

    // ---------------------------------------------------------------- DAC output stage
    // One register stage on every DAC pin (the timing between them is the commutator's). The
    // word of a channel whose motor must not move (watchdog expired, global or axis disabled,
    // axis fault) is replaced by ZERO. The decision may change at any clock except inside a load
    // (from the clock the commutator's strobe falls to the clock after the pins' strobe rises),
    // so a load in progress completes unchanged and every later load is zero (the bound on when
    // all six channels are at zero torque: rtl/top/README.md, "Zero torque within one frame").
    wire       [1:0] c_motor = (c_addr[2:1] == 2'd3) ? 2'd0 : c_addr[2:1];
    wire             kill_ch = kill_all | fault_k[c_motor] | ~axis_en[c_motor];
    wire             in_load = ~c_wr_n | ~dac_wr_n;
    reg              kill_q;
    wire             kill_use = in_load ? kill_q : kill_ch;

    always @(posedge clk) begin
        kill_q   <= kill_use;
        dac_data <= kill_use ? ZERO : c_data;
        dac_addr <= c_addr;
    end

    initial dac_wr_n = 1'b1;  // high from FPGA configuration on, as the commutator's (dac_sched.v)
    always @(posedge clk) begin
        if (rst)
            dac_wr_n <= 1'b1;
        else
            dac_wr_n <= c_wr_n;
    end

    // The pin registers' check (SEC_DAC): a second copy of the stage, with its own kill register
    // and strobe, must show the same strobe on every clock and the same word and address while
    // either strobe is low. (* keep *): synthesis must not merge the copies.
    generate
        if (SEC_DAC != 0) begin : g_sec_dac
            (* keep *) reg                kill_k, wr_n_k;
            (* keep *) reg [DAC_BITS-1:0] data_k;
            (* keep *) reg [2:0]          addr_k;
            wire use_k = (~c_wr_n | ~wr_n_k) ? kill_k : kill_ch;
            initial wr_n_k = 1'b1;
            always @(posedge clk) begin
                kill_k <= use_k;
                data_k <= use_k ? ZERO : c_data;
                addr_k <= c_addr;
                wr_n_k <= rst | c_wr_n;
            end
            assign sec_err[2] = (wr_n_k != dac_wr_n) ||
                                ((~wr_n_k | ~dac_wr_n) && {data_k, addr_k} != {dac_data, dac_addr});
        end else begin : g_no_sec_dac
            assign sec_err[2] = 1'b0;
        end
    endgenerate
    assign sec_err[0] = 1'b0;    // (the register file's own: parity)
    assign sec_err[3] = 1'b0;    // (the register file's own: the tick range)
endmodule

`default_nettype wire
