// SPDX-License-Identifier: Apache-2.0
// Formal property wrapper of rtl/interp/enc_interp.v (SymbiYosys, tb/formal/README.md): the
// quadrant counter. Samples (a, b, index), their strobe and the control pulses are free at
// every clock. Proven: a sample whose two sign bits (a zero code keeps its channel's previous
// sign) BOTH differ from the previous sample's - a two-quadrant step, which the decoder cannot
// resolve - raises the sticky overspeed fault on that very sample's output and counts once in
// m_overspeed_count (which saturates); and the count never moves on any other sample.
// The sample pipeline is 5 clocks from the strobe to m_valid (rtl/interp/enc_interp.v).
`timescale 1ns / 1ps
`default_nettype none

module enc_interp_formal #(
    parameter integer VEL_LOG2W = 2         // the smallest window: the property does not use it
) (
    input wire       clk,
    input wire       rst,
    input wire       s_valid,
    input wire [7:0] s_a,
    input wire [7:0] s_b,
    input wire       s_index,
    input wire       ctl_fault_clear,
    input wire       ctl_home_arm
);
    localparam integer LAT = 5;

    wire        m_valid, m_homed, m_fault;
    wire [31:0] m_pos, m_pos_homed, m_vel, m_index_pos;
    wire [15:0] m_index_count, m_overspeed_count;
    wire [2:0]  m_faults;

    enc_interp #(.LUT_BITS(7), .LUT_FILE("asin.hex"), .VEL_LOG2W(VEL_LOG2W)) dut (
        .clk(clk), .rst(rst), .s_valid(s_valid), .s_a(s_a), .s_b(s_b), .s_index(s_index),
        .ctl_fault_clear(ctl_fault_clear), .ctl_home_arm(ctl_home_arm),
        .m_valid(m_valid), .m_pos(m_pos), .m_pos_homed(m_pos_homed), .m_vel(m_vel),
        .m_index_pos(m_index_pos), .m_index_count(m_index_count),
        .m_overspeed_count(m_overspeed_count), .m_homed(m_homed), .m_faults(m_faults),
        .m_fault(m_fault)
    );

`ifdef FORMAL
    reg init = 1'b1;
    always @(posedge clk) init <= 1'b0;
    always @(*) assume (rst == init);        // one reset, then run

    // the spec's sign bits, per captured sample
    reg  sa_q = 1'b0, sb_q = 1'b0, seen = 1'b0;
    wire sa = (s_a == 8'd0) ? sa_q : s_a[7];
    wire sb = (s_b == 8'd0) ? sb_q : s_b[7];
    wire step2 = seen && (sa != sa_q) && (sb != sb_q);
    always @(posedge clk) begin
        if (rst) begin
            sa_q <= 1'b0;
            sb_q <= 1'b0;
            seen <= 1'b0;
        end else if (s_valid) begin
            sa_q <= sa;
            sb_q <= sb;
            seen <= 1'b1;
        end
    end

    // what each output must show, LAT clocks after its strobe
    reg [LAT-1:0] v_pipe = 0, s_pipe = 0;
    always @(posedge clk) begin
        if (rst) begin
            v_pipe <= 0;
            s_pipe <= 0;
        end else begin
            v_pipe <= {v_pipe[LAT-2:0], s_valid};
            s_pipe <= {s_pipe[LAT-2:0], s_valid && step2};
        end
    end
    wire exp_valid = v_pipe[LAT-1];
    wire exp_step2 = s_pipe[LAT-1];

    reg [15:0] cnt_q = 16'd0;                // the count at the previous output
    always @(posedge clk) if (rst) cnt_q <= 16'd0; else if (m_valid) cnt_q <= m_overspeed_count;

    // ---- inductive strengthening: the stages of the pipeline hold the samples the wrapper
    // saw, in order (peek_* wires are connected to the RTL's registers by the .sby script)
    (* keep *) wire       peek_va, peek_vb, peek_vc, peek_vd, peek_sa_prev, peek_sb_prev;
    (* keep *) wire       peek_started;
    (* keep *) wire [7:0] peek_a_a, peek_b_a;
    (* keep *) wire [1:0] peek_q_prev, peek_q_b;
    (* keep *) wire [2:0] peek_flags, peek_flags_d;
    (* keep *) wire [15:0] peek_cnt_c, peek_cnt_d;
    reg [7:0] a_last = 8'd0, b_last = 8'd0;
    reg [2:0] ha = 3'd0, hb = 3'd0;          // signs of the last three samples, newest in bit 0
    reg [1:0] ncap = 2'd0;                   // samples captured (saturating at 3)
    always @(posedge clk) begin
        if (s_valid) begin
            a_last <= s_a;
            b_last <= s_b;
        end
        if (rst) begin
            ha   <= 3'd0;
            hb   <= 3'd0;
            ncap <= 2'd0;
        end else if (s_valid) begin
            ha   <= {ha[1:0], sa};
            hb   <= {hb[1:0], sb};
            ncap <= (ncap == 2'd3) ? ncap : ncap + 2'd1;
        end
    end
    wire [1:0] in_ab = {1'b0, peek_va} + {1'b0, peek_vb};     // samples in stages A and B
    // the count registers after stage C are not reset (datapath): before the first output the
    // port's count stands for 0 (what stage C was reset to); d copies c from 2 clocks on
    reg outs = 1'b0;
    reg [1:0] run_n = 2'd0;
    always @(posedge clk) begin
        if (rst) begin
            outs  <= 1'b0;
            run_n <= 2'd0;
        end else begin
            if (m_valid) outs <= 1'b1;
            if (run_n != 2'd3) run_n <= run_n + 2'd1;
        end
    end
    wire [15:0] m_eff = (outs || m_valid) ? m_overspeed_count : 16'd0;
    function [15:0] sat_inc;
        input [15:0] c;
        input        inc;
        begin
            sat_inc = (inc && c != 16'hffff) ? c + 16'd1 : c;
        end
    endfunction
    always @(*) begin
        if (!init) begin
            assert ({peek_vd, peek_vc, peek_vb, peek_va} == v_pipe[3:0]);
            if (ncap != 2'd0) assert (peek_a_a == a_last && peek_b_a == b_last);
            assert (seen == (ncap != 2'd0) && sa_q == ha[0] && sb_q == hb[0]);
            // history older than the reset reads as the reset signs (0)
            if (ncap == 2'd0) assert (ha == 3'd0 && hb == 3'd0);
            if (ncap == 2'd1) assert (ha[2:1] == 2'd0 && hb[2:1] == 2'd0);
            if (ncap == 2'd2) assert (!ha[2] && !hb[2]);
            // the previous signs the RTL holds are those of the last sample that left stage A
            assert (peek_sa_prev == (peek_va ? ha[1] : ha[0]));
            assert (peek_sb_prev == (peek_va ? hb[1] : hb[0]));
            assert (peek_started == (ncap > in_ab));
            if (peek_vb) assert (peek_q_b == {ha[peek_va], ha[peek_va] ^ hb[peek_va]});
            if (peek_started)
                assert (peek_q_prev == {ha[in_ab], ha[in_ab] ^ hb[in_ab]});
            if (peek_vc && s_pipe[2]) assert (peek_flags[0]);
            if (peek_vd && s_pipe[3]) assert (peek_flags_d[0]);
            if (run_n >= 2'd1)
                assert (peek_vc ? (peek_cnt_c == sat_inc(peek_cnt_d, s_pipe[2]))
                                : (peek_cnt_c == peek_cnt_d));
            if (run_n >= 2'd1)
                assert (peek_vd ? (peek_cnt_d == sat_inc(m_eff, s_pipe[3]))
                                : (peek_cnt_d == m_eff));
            if (!m_valid) assert (cnt_q == m_eff);
        end
    end

    always @(*) begin
        if (!init) begin
            assert (m_valid == exp_valid);
            if (m_valid && exp_step2) begin
                assert (m_faults[0]);
                assert (m_overspeed_count == ((cnt_q == 16'hffff) ? cnt_q : cnt_q + 16'd1));
            end
            if (m_valid && !exp_step2) assert (m_overspeed_count == cnt_q);
        end
    end
`endif
endmodule

`default_nettype wire
