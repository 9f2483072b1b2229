// SPDX-License-Identifier: Apache-2.0
// Online calibration of one sin/cos channel pair (enc_interp with CAL = 1): offset, gain and
// quadrature-phase correction of the raw 8-bit codes into 12-bit quarter-LSB channels, learned
// by a block LMS over whole encoder lines. Bit-exact model: models/hapgate/golden/enccal.py.
// Latency: 1 clock (s_valid -> m_valid). The state applies from the sample after an update.
`timescale 1ns / 1ps
`default_nettype none

module enc_calib #(
    parameter integer LINES_LOG2 = 3,   // block = 2**LINES_LOG2 encoder lines (0..6)
    parameter integer NLOG       = 14,  // blocks of 2**NLOG samples or more are ignored (4..16)
    parameter integer AMP_MIN    = 40,  // amplitude window on the raw codes (as enc_interp)
    parameter integer AMP_MAX    = 170
) (
    input  wire               clk,
    input  wire               rst,
    input  wire               s_valid,
    input  wire [7:0]         s_a,        // raw codes (after the INVERT swap)
    input  wire [7:0]         s_b,
    input  wire               ctl_en,     // captured with the sample: 0 = identity + reset state
    input  wire               ctl_freeze, // captured with the sample: 1 = no update from it
    input  wire [3:0]         cfg_mu,     // final adaptation shift (0 acts as 1), at the update
    output reg                m_valid,
    output reg  signed [11:0] m_a,        // corrected channels, quarter-LSB, amplitude 508
    output reg  signed [11:0] m_b,
    output reg                m_clip,     // raw a or b at -128 / +127
    output reg                m_bad,      // raw a^2 + b^2 outside the amplitude window
    output wire signed [15:0] m_ofs_a,    // applied offsets, 1/16 LSB
    output wire signed [15:0] m_ofs_b,
    output wire        [15:0] m_gain_a,   // applied gains, 2^-14
    output wire        [15:0] m_gain_b,
    output wire signed [15:0] m_phase,    // applied phase coupling, 2^-14
    output reg         [7:0]  m_gear,     // valid blocks since enable (saturating)
    output reg         [15:0] m_updates   // valid blocks since reset (wrapping)
);
    localparam integer QW = LINES_LOG2 + 2;       // quadrant bits inside a cell
    localparam integer NW = NLOG + 1;             // block length counter (saturates at 2**NLOG)
    localparam integer SW = 27;                   // block sums
    localparam integer XW = 36;                   // block sum of a b
    localparam integer EW = 42;                   // update arithmetic
    localparam integer AMP2_MIN_I = AMP_MIN * AMP_MIN;
    localparam integer AMP2_MAX_I = AMP_MAX * AMP_MAX;
    localparam [16:0] AMP2_MIN = AMP2_MIN_I[16:0];
    localparam [16:0] AMP2_MAX = AMP2_MAX_I[16:0];
    localparam integer NSAT_I = 1 << NLOG;
    localparam [NW-1:0] NSAT = NSAT_I[NW-1:0];
    localparam signed [EW-1:0] T16 = 42'sd5174;   // round(16 * 508 * 2 / pi): target 16 mean|ac|
    // internal coefficient registers: applied value = x >>> 8
    localparam signed [17:0] OFS_LO = -18'sd131072;       // -512 << 8
    localparam signed [17:0] OFS_HI = 18'sd131071;
    localparam signed [23:0] GAIN_LO = 24'sd2097152;      // 8192 << 8
    localparam signed [23:0] GAIN_HI = 24'sd8388607;      // (32768 << 8) - 1
    localparam signed [23:0] GAIN_ONE = 24'sd4194304;     // 16384 << 8
    localparam signed [19:0] KP_LO = -20'sd524288;        // -2048 << 8
    localparam signed [19:0] KP_HI = 20'sd524287;

    generate
        if (LINES_LOG2 < 0 || LINES_LOG2 > 6) begin : g_bad_lines
            enc_calib_LINES_LOG2_must_be_0_to_6 u_stop ();
        end
        if (NLOG < 4 || NLOG > 16) begin : g_bad_nlog
            enc_calib_NLOG_must_be_4_to_16 u_stop ();
        end
        if (AMP_MIN < 0 || AMP_MAX > 182 || AMP_MIN >= AMP_MAX) begin : g_bad_amp
            enc_calib_needs_0_le_AMP_MIN_lt_AMP_MAX_le_182 u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- coefficients
    reg signed [17:0] oa_x, ob_x;
    reg signed [23:0] ga_x, gb_x;
    reg signed [19:0] kp_x;
    wire signed [9:0]  oa = oa_x[17:8];
    wire signed [9:0]  ob = ob_x[17:8];
    wire signed [15:0] ga = ga_x[23:8];
    wire signed [15:0] gb = gb_x[23:8];
    wire signed [11:0] kp = kp_x[19:8];
    assign m_ofs_a  = {{6{oa[9]}}, oa};
    assign m_ofs_b  = {{6{ob[9]}}, ob};
    assign m_gain_a = ga;
    assign m_gain_b = gb;
    assign m_phase  = {{4{kp[11]}}, kp};

    // ---------------------------------------------------------------- correction
    wire signed [7:0]  sa8 = s_a;
    wire signed [7:0]  sb8 = s_b;
    wire signed [12:0] a1  = {sa8[7], sa8, 4'd0} - {{3{oa[9]}}, oa};
    wire signed [12:0] b1  = {sb8[7], sb8, 4'd0} - {{3{ob[9]}}, ob};
    wire signed [29:0] pa  = a1 * ga;
    wire signed [29:0] pb  = b1 * gb + a1 * kp;
    wire signed [29:0] pa_r = pa + 30'sd32768;
    wire signed [29:0] pb_r = pb + 30'sd32768;
    wire signed [11:0] ac  = ctl_en ? pa_r[27:16] : {{2{sa8[7]}}, sa8, 2'b00};  // identity: 4a
    wire signed [11:0] bc  = ctl_en ? pb_r[27:16] : {{2{sb8[7]}}, sb8, 2'b00};
    wire unused_p = &{1'b0, pa_r[29:28], pa_r[15:0], pb_r[29:28], pb_r[15:0]};

    // raw faults
    wire signed [15:0] a_sq = sa8 * sa8;
    wire signed [15:0] b_sq = sb8 * sb8;
    wire        [16:0] amp2 = {1'b0, a_sq} + {1'b0, b_sq};
    wire clip = (s_a == 8'h80) || (s_a == 8'h7f) || (s_b == 8'h80) || (s_b == 8'h7f);
    wire bad  = (amp2 < AMP2_MIN) || (amp2 > AMP2_MAX);

    // ---------------------------------------------------------------- raw quadrant cells
    reg  sa_prev, sb_prev, started, last_up;
    reg  [1:0] q_prev;
    reg  [QW-1:0] qlow;
    wire rsa = (s_a == 8'd0) ? sa_prev : s_a[7];
    wire rsb = (s_b == 8'd0) ? sb_prev : s_b[7];
    wire [1:0] q  = {rsa, rsa ^ rsb};
    wire [1:0] dq = q - q_prev;
    wire ovs  = started && (dq == 2'd2);
    wire fwd  = started && ((dq == 2'd1) || (ovs && last_up));
    wire back = started && ((dq == 2'd3) || (ovs && !last_up));
    wire signed [QW+1:0] step = !started ? {(QW + 2){1'b0}}
                              : (dq == 2'd1) ? 1 : (dq == 2'd3) ? -1
                              : ovs ? (last_up ? 2 : -2) : 0;
    wire signed [QW+1:0] qsum = $signed({2'b00, qlow}) + step;
    wire xing = started && (qsum[QW+1:QW] != 2'b00);   // left the cell of 4 * 2**LINES_LOG2
    wire [QW-1:0] qlow_next = !started ? {{(QW - 2){1'b0}}, q} : qsum[QW-1:0];

    // ---------------------------------------------------------------- blocks
    reg                  entered, seg_fwd, seg_ok;
    reg  [NW-1:0]        seg_n;
    reg  [NW-1:0]        seg_n1;                 // samples before the middle of the cell
    reg                  half_seen;
    reg  signed [SW-1:0] s_sa, s_sb, s_ua, s_ub;
    reg  signed [XW-1:0] s_x;
    wire                 bad_now  = clip | bad | ovs | ctl_freeze | ~ctl_en;
    wire                 opp      = seg_fwd ? back : fwd;
    // speed about constant: |N1 - N2| = |2 N1 - N| <= N / 32
    wire signed [NW+1:0] half_d   = $signed({1'b0, seg_n1, 1'b0}) - $signed({2'b00, seg_n});
    wire        [NW+1:0] half_abs = half_d[NW+1] ? -half_d : half_d;
    wire                 steady   = half_seen && (half_abs <= {7'd0, seg_n[NW-1:5]});
    wire                 toggle   = qlow_next[QW-1] ^ qlow[QW-1];
    wire                 blk_end  = xing && entered && seg_ok && (fwd == seg_fwd) &&
                                    (seg_n != NSAT) && steady;
    wire                 do_upd   = blk_end && ctl_en;

    wire signed [SW-1:0] ac_e  = {{(SW - 12){ac[11]}}, ac};
    wire signed [SW-1:0] bc_e  = {{(SW - 12){bc[11]}}, bc};
    wire signed [SW-1:0] aac_e = ac[11] ? -ac_e : ac_e;
    wire signed [SW-1:0] abc_e = bc[11] ? -bc_e : bc_e;
    wire signed [23:0]   ab_p  = ac * bc;
    wire signed [XW-1:0] xc_e  = {{(XW - 24){ab_p[23]}}, ab_p};

    // ---------------------------------------------------------------- update
    function [4:0] msb;   // floor(log2 v), v >= 1
        input [16:0] v;
        integer j;
        begin
            msb = 5'd0;
            for (j = 1; j < 17; j = j + 1)
                if (v[j]) msb = j[4:0];
        end
    endfunction

    wire [7:0]  gear_n = (m_gear == 8'd255) ? 8'd255 : m_gear + 8'd1;
    wire [3:0]  mu_l   = (cfg_mu == 4'd0) ? 4'd1 : cfg_mu;
    wire [4:0]  g_lg   = msb({9'd0, gear_n});               // floor(log2 c)
    wire [4:0]  mu_e   = ({1'b0, mu_l} < g_lg) ? {1'b0, mu_l} : g_lg;
    wire [16:0] n17    = {{(17 - NW){1'b0}}, seg_n};
    wire [4:0]  n_msb  = msb(n17);
    wire        n_half = n17[n_msb - 5'd1];                 // N >= 1.5 * 2**msb: round up
    wire [5:0]  sh     = {1'b0, n_msb} + {5'd0, n_half} + {1'b0, mu_e};

    wire signed [EW-1:0] n_e   = {{(EW - NW){1'b0}}, seg_n};
    wire signed [EW-1:0] e_oa  = {{(EW - SW){s_sa[SW-1]}}, s_sa} <<< 10;
    wire signed [EW-1:0] e_ob  = {{(EW - SW){s_sb[SW-1]}}, s_sb} <<< 10;
    wire signed [EW-1:0] e_ga  = (T16 * n_e - ({{(EW - SW){s_ua[SW-1]}}, s_ua} <<< 4)) <<< 10;
    wire signed [EW-1:0] e_gb  = (T16 * n_e - ({{(EW - SW){s_ub[SW-1]}}, s_ub} <<< 4)) <<< 10;
    wire signed [EW-1:0] e_kp  = {{(EW - XW){s_x[XW-1]}}, s_x} <<< 5;
    wire signed [EW-1:0] d_oa  = e_oa >>> sh;
    wire signed [EW-1:0] d_ob  = e_ob >>> sh;
    wire signed [EW-1:0] d_ga  = e_ga >>> sh;
    wire signed [EW-1:0] d_gb  = e_gb >>> sh;
    wire signed [EW-1:0] d_kp  = -(e_kp >>> sh);

    function signed [EW-1:0] sat;
        input signed [EW-1:0] v;
        input signed [EW-1:0] lo;
        input signed [EW-1:0] hi;
        begin
            sat = (v < lo) ? lo : (v > hi) ? hi : v;
        end
    endfunction

    wire signed [EW-1:0] oa_n = sat({{(EW - 18){oa_x[17]}}, oa_x} + d_oa,
                                    {{(EW - 18){OFS_LO[17]}}, OFS_LO}, {{(EW - 18){1'b0}}, OFS_HI});
    wire signed [EW-1:0] ob_n = sat({{(EW - 18){ob_x[17]}}, ob_x} + d_ob,
                                    {{(EW - 18){OFS_LO[17]}}, OFS_LO}, {{(EW - 18){1'b0}}, OFS_HI});
    wire signed [EW-1:0] ga_n = sat({{(EW - 24){ga_x[23]}}, ga_x} + d_ga,
                                    {{(EW - 24){1'b0}}, GAIN_LO}, {{(EW - 24){1'b0}}, GAIN_HI});
    wire signed [EW-1:0] gb_n = sat({{(EW - 24){gb_x[23]}}, gb_x} + d_gb,
                                    {{(EW - 24){1'b0}}, GAIN_LO}, {{(EW - 24){1'b0}}, GAIN_HI});
    wire signed [EW-1:0] kp_n = sat({{(EW - 20){kp_x[19]}}, kp_x} + d_kp,
                                    {{(EW - 20){KP_LO[19]}}, KP_LO}, {{(EW - 20){1'b0}}, KP_HI});

    // saturated: the high bits are sign copies
    wire unused_hi = &{1'b0, oa_n[EW-1:18], ob_n[EW-1:18], ga_n[EW-1:24], gb_n[EW-1:24],
                       kp_n[EW-1:20]};

    // ---------------------------------------------------------------- registers
    always @(posedge clk) begin
        if (s_valid) begin
            m_a    <= ac;
            m_b    <= bc;
            m_clip <= clip;
            m_bad  <= bad;
            if (xing) begin
                s_sa <= ac_e;
                s_sb <= bc_e;
                s_ua <= aac_e;
                s_ub <= abc_e;
                s_x  <= xc_e;
            end else begin
                s_sa <= s_sa + ac_e;
                s_sb <= s_sb + bc_e;
                s_ua <= s_ua + aac_e;
                s_ub <= s_ub + abc_e;
                s_x  <= s_x + xc_e;
            end
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            m_valid   <= 1'b0;
            sa_prev   <= 1'b0;
            sb_prev   <= 1'b0;
            started   <= 1'b0;
            last_up   <= 1'b1;
            q_prev    <= 2'd0;
            qlow      <= {QW{1'b0}};
            entered   <= 1'b0;
            seg_fwd   <= 1'b1;
            seg_ok    <= 1'b0;
            seg_n     <= {NW{1'b0}};
            seg_n1    <= {NW{1'b0}};
            half_seen <= 1'b0;
            oa_x      <= 18'sd0;
            ob_x      <= 18'sd0;
            ga_x      <= GAIN_ONE;
            gb_x      <= GAIN_ONE;
            kp_x      <= 20'sd0;
            m_gear    <= 8'd0;
            m_updates <= 16'd0;
        end else begin
            m_valid <= s_valid;
            if (s_valid) begin
                sa_prev <= rsa;
                sb_prev <= rsb;
                started <= 1'b1;
                q_prev  <= q;
                qlow    <= qlow_next;
                if (started && dq == 2'd1) last_up <= 1'b1;
                if (started && dq == 2'd3) last_up <= 1'b0;
                if (xing) begin
                    entered <= 1'b1;
                    seg_fwd <= fwd;
                    seg_ok  <= ~bad_now;
                    seg_n   <= {{(NW - 1){1'b0}}, 1'b1};
                    half_seen <= 1'b0;
                end else begin
                    if (started && toggle && !half_seen) begin
                        half_seen <= 1'b1;
                        seg_n1    <= seg_n;
                    end
                    seg_ok <= seg_ok & ~bad_now & ~opp;
                    if (seg_n != NSAT) seg_n <= seg_n + 1'b1;
                end
                if (!ctl_en) begin
                    oa_x   <= 18'sd0;
                    ob_x   <= 18'sd0;
                    ga_x   <= GAIN_ONE;
                    gb_x   <= GAIN_ONE;
                    kp_x   <= 20'sd0;
                    m_gear <= 8'd0;
                end else if (do_upd) begin
                    oa_x      <= oa_n[17:0];
                    ob_x      <= ob_n[17:0];
                    ga_x      <= ga_n[23:0];
                    gb_x      <= gb_n[23:0];
                    kp_x      <= kp_n[19:0];
                    m_gear    <= gear_n;
                    m_updates <= m_updates + 16'd1;
                end
            end
        end
    end
endmodule

`default_nettype wire
