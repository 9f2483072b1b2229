// SPDX-License-Identifier: Apache-2.0
// Formal property wrapper of rtl/render/hg_render.v (SymbiYosys, tb/formal/README.md): every
// input is free at every clock (frame strobes at any spacing, loads, TTLs, writes, the zero
// input, the firmware's torques and limits); the datapath's result is cut by the script. Proven:
// (1) |m_torque| <= min(TQ_LIMIT, 32768) on every axis in every clock; (2) m_torque is zero in
// every clock with ctl_zero high; (3) m_render is zero in every clock after a model's expiry (the
// strobe after its TTL frames) until a new load is taken, before the first load, and from the
// clock after ctl_zero until a load is taken after it. The TTL rule is restated here as an
// observer that counts the frames since the take (rtl/render/README.md, "Control").
`timescale 1ns / 1ps
`default_nettype none

module hg_render_formal #(
    parameter integer MUL_DIGIT = 18,
    parameter integer CLK_HZ    = 48_000_000
) (
    input wire        clk,
    input wire        rst,
    input wire        s_frame,
    input wire [95:0] s_pos,
    input wire [95:0] s_vel,
    input wire        cfg_we,
    input wire [3:0]  cfg_addr,
    input wire [31:0] cfg_wdata,
    input wire        ctl_load,
    input wire [15:0] ctl_ttl,
    input wire        ctl_zero,
    input wire [47:0] s_torque,
    input wire [47:0] ctl_tq_limit
);
    wire [47:0] m_torque;
    wire [50:0] m_render;
    wire        m_valid, m_live, m_pending;

    hg_render #(.CLK_HZ(CLK_HZ), .MUL_DIGIT(MUL_DIGIT), .TTL_BITS(16)) dut (
        .clk(clk), .rst(rst), .s_frame(s_frame), .s_pos(s_pos), .s_vel(s_vel),
        .cfg_we(cfg_we), .cfg_addr(cfg_addr), .cfg_wdata(cfg_wdata), .ctl_load(ctl_load),
        .ctl_ttl(ctl_ttl), .ctl_zero(ctl_zero), .s_torque(s_torque), .ctl_tq_limit(ctl_tq_limit),
        .m_torque(m_torque), .m_render(m_render), .m_valid(m_valid), .m_live(m_live),
        .m_pending(m_pending)
    );

`ifdef FORMAL
    reg init = 1'b1;
    always @(posedge clk) init <= 1'b0;
    always @(*) assume (rst == init);        // one reset, then run

    // ---- the TTL rule as an observer: a load is taken at the first strobe at or after it; the
    // taking strobe's frame is number 0; frames 0 .. TTL-1 render; ctl_zero drops everything
    reg        have = 1'b0, pend = 1'b0;
    reg [15:0] ttl_p = 16'd0, ttl_t = 16'd0, n_since = 16'd0;
    wire       take = pend | ctl_load;
    always @(posedge clk) begin
        if (rst || ctl_zero) begin
            have <= 1'b0;
            pend <= 1'b0;
        end else begin
            if (ctl_load) begin
                pend  <= 1'b1;
                ttl_p <= ctl_ttl;
            end
            if (s_frame) begin
                if (take) begin
                    have    <= 1'b1;
                    ttl_t   <= ctl_load ? ctl_ttl : ttl_p;
                    n_since <= 16'd0;
                    pend    <= 1'b0;
                end else if (n_since != 16'hFFFF) begin
                    n_since <= n_since + 16'd1;
                end
            end
        end
    end
    wire expired = !have || n_since >= ttl_t;

    // ---- the properties
    integer i;
    reg [16:0] lim;
    always @(*) begin
        if (!init) begin
            for (i = 0; i < 3; i = i + 1) begin
                lim = ctl_tq_limit[16*i+15] ? 17'd32768 : {1'b0, ctl_tq_limit[16*i +: 16]};
                assert ($signed({m_torque[16*i+15], m_torque[16*i +: 16]}) <= $signed(lim));
                assert ($signed({m_torque[16*i+15], m_torque[16*i +: 16]}) >= -$signed(lim));
            end
            if (ctl_zero)
                assert (m_torque == 48'd0);
            if (expired)
                assert (m_render == 51'd0);
        end
    end

    // ---- inductive strengthening: the RTL's control state is the observer's (peek_* wires
    // are connected to the RTL's registers by the .sby script)
    wire        peek_live, peek_pending, peek_busy;
    wire [15:0] peek_ttl, peek_left;
    wire [50:0] peek_r;
    always @(*) begin
        if (!init) begin
            assert (peek_pending == pend);
            if (pend)
                assert (peek_ttl == ttl_p);
            assert (peek_live == !expired);
            if (peek_live)
                assert (peek_left == ttl_t - 16'd1 - n_since);
            if (!peek_live)
                assert (peek_r == 51'd0 && !peek_busy);
        end
    end

    // ---- non-vacuity: a non-zero result is shown, then the same model expires
    reg shown = 1'b0;
    always @(posedge clk)
        if (rst) shown <= 1'b0; else if (m_valid && m_render != 51'd0 && have) shown <= 1'b1;
    always @(*) begin
        if (!init) begin
            cover (m_valid && m_render != 51'd0);
            cover (shown && have && expired && !ctl_zero);
        end
    end
`endif
endmodule

`default_nettype wire
