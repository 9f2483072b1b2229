// SPDX-License-Identifier: Apache-2.0
// Capture buffer of the raw ADC words (the interpolators' inputs at the sample strobe): armed over
// the bus, triggered at once or by an index edge, it records every (DECIM+1)-th sample of one
// axis or of all three into block RAM, then the DSP reads it back word by word (CAP_ADDR/CAP_DATA).
// Registers CAP_CTRL..CAP_DATA (rtl/regs/hapgate.rdl); model, timing: docs/blocks/capture.md.
`timescale 1ns / 1ps
`default_nettype none

module hg_capture #(
    parameter integer CLK_HZ     = 48_000_000, // FPGA clock
    parameter integer SAMPLE_HZ  = 1_000_000,  // ADC sample rate (a strobe every CLK_HZ/SAMPLE_HZ)
    parameter integer DEPTH_LOG2 = 10,         // buffer entries = 2**DEPTH_LOG2 (8..15), 16 bits
    parameter integer ADDR_BITS  = 8,          // decoded word-address bits of the bus (7..30)
    parameter integer BASE       = 64          // word address of CAP_CTRL (CAP_STAT, _ADDR, _DATA
                                               // follow); a multiple of 4
) (
    input  wire                 clk,
    input  wire                 rst,
    // the interpolators' inputs (axis 0 in the low bits)
    input  wire                 adc_strobe,    // ADC words are taken at the end of this cycle
    input  wire [23:0]          adc_a,
    input  wire [23:0]          adc_b,
    input  wire [2:0]           enc_index,
    // committed bus accesses (hg_bus dbg_*: one clock each, applied at the end of that clock)
    input  wire                 s_req,
    input  wire                 s_we,
    input  wire [ADDR_BITS-1:0] s_addr,
    input  wire [31:0]          s_wdata,
    // read values of the four registers {CAP_DATA, CAP_ADDR, CAP_STAT, CAP_CTRL}
    output wire [127:0]         m_regs
);
    localparam integer DIV   = CLK_HZ / SAMPLE_HZ;   // clocks per sample
    localparam integer AW    = DEPTH_LOG2;
    localparam integer DEPTH = 1 << DEPTH_LOG2;
    localparam integer LIM3_I = (DEPTH / 3) * 3;     // entries of an all-axes capture
    localparam [AW:0]  LIM1  = DEPTH[AW:0];
    localparam [AW:0]  LIM3  = LIM3_I[AW:0];
    localparam [3:0]   DL2   = DEPTH_LOG2[3:0];
    localparam integer BASE_W = BASE / 4;

    generate
        if (DEPTH_LOG2 < 8 || DEPTH_LOG2 > 15) begin : g_bad_depth
            hg_capture_DEPTH_LOG2_must_be_8_to_15 u_stop ();
        end
        // the three entries of an all-axes sample are written in the clocks after its strobe
        if (SAMPLE_HZ < 1 || DIV < 4) begin : g_bad_div
            hg_capture_needs_CLK_HZ_at_least_4_SAMPLE_HZ u_stop ();
        end
        if (ADDR_BITS < 7 || ADDR_BITS > 30 || BASE % 4 != 0 || BASE + 4 > (1 << ADDR_BITS))
        begin : g_bad_base
            hg_capture_BASE_must_be_a_multiple_of_4_inside_the_bus_address_space u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- register access
    wire        here   = s_req && (s_addr[ADDR_BITS-1:2] == BASE_W[ADDR_BITS-3:0]);
    wire        ctrl_w = here && s_we && s_addr[1:0] == 2'd0;
    wire        addr_w = here && s_we && s_addr[1:0] == 2'd2;
    wire        data_r = here && !s_we && s_addr[1:0] == 2'd3;
    wire        arm    = ctrl_w && s_wdata[0];

    // CAP_CTRL fields, stored as written: SEL[5:4], TRIG[6], TRIG_AXIS[9:8], DECIM[31:16]
    reg  [1:0]  sel_q, tax_q;
    reg         trig_q;
    reg  [15:0] decim_q;
    // state: armed (waiting for the trigger), recording, done (sticky until the next CAP_CTRL
    // write with ARM or reset)
    reg         armed_q, busy_q, done_q;
    reg  [AW:0] count_q;       // entries written
    reg  [15:0] dcnt_q;        // strobes still to skip before the next recorded one
    reg  [1:0]  wpend_q;       // entries of the last recorded sample still to write
    reg  [47:0] wbuf_q;        // those entries, the next one in the low 16 bits
    reg  [2:0]  idx_prev;      // enc_index at the previous strobe
    reg  [AW-1:0] raddr_q;     // CAP_ADDR

    wire [2:0]  idx_rise = enc_index & ~idx_prev;
    wire        idx_edge = (tax_q == 2'd3) ? |idx_rise : idx_rise[tax_q];
    wire        take     = adc_strobe && ((armed_q && (!trig_q || idx_edge)) ||
                                          (busy_q && dcnt_q == 16'd0));
    wire [AW:0] limit    = (sel_q == 2'd3) ? LIM3 : LIM1;
    wire        wr_en    = wpend_q != 2'd0 && !ctrl_w && !rst;
    wire        last_wr  = wpend_q == 2'd1 && count_q + 1'b1 == limit;

    // the selected words of this strobe, {B, A} per axis
    wire [15:0] w0 = {adc_b[7:0],   adc_a[7:0]};
    wire [15:0] w1 = {adc_b[15:8],  adc_a[15:8]};
    wire [15:0] w2 = {adc_b[23:16], adc_a[23:16]};
    wire [15:0] w_sel = (sel_q == 2'd1) ? w1 : (sel_q == 2'd2) ? w2 : w0;

    always @(posedge clk) begin
        if (rst) begin
            sel_q    <= 2'd0;
            tax_q    <= 2'd0;
            trig_q   <= 1'b0;
            decim_q  <= 16'd0;
            armed_q  <= 1'b0;
            busy_q   <= 1'b0;
            done_q   <= 1'b0;
            count_q  <= {(AW + 1){1'b0}};
            dcnt_q   <= 16'd0;
            wpend_q  <= 2'd0;
            idx_prev <= 3'b000;
            raddr_q  <= {AW{1'b0}};
        end else begin
            if (adc_strobe)
                idx_prev <= enc_index;
            if (addr_w)
                raddr_q <= s_wdata[AW-1:0];
            else if (data_r)
                raddr_q <= raddr_q + 1'b1;
            if (ctrl_w) begin           // a CAP_CTRL write: stores the fields, then arms or stops
                sel_q   <= s_wdata[5:4];
                trig_q  <= s_wdata[6];
                tax_q   <= s_wdata[9:8];
                decim_q <= s_wdata[31:16];
                armed_q <= arm;
                busy_q  <= 1'b0;
                wpend_q <= 2'd0;
                if (arm) begin
                    done_q  <= 1'b0;
                    count_q <= {(AW + 1){1'b0}};
                end
            end else begin
                if (take) begin
                    armed_q <= 1'b0;
                    busy_q  <= 1'b1;
                    dcnt_q  <= decim_q;
                    wpend_q <= (sel_q == 2'd3) ? 2'd3 : 2'd1;
                end else if (adc_strobe && busy_q) begin
                    dcnt_q  <= dcnt_q - 16'd1;
                end
                if (wr_en) begin
                    count_q <= count_q + 1'b1;
                    if (!take)
                        wpend_q <= wpend_q - 2'd1;
                    if (last_wr) begin
                        busy_q <= 1'b0;
                        done_q <= 1'b1;
                    end
                end
            end
        end
    end

    // the entries of a recorded sample (datapath: not reset)
    always @(posedge clk) begin
        if (take)
            wbuf_q <= (sel_q == 2'd3) ? {w2, w1, w0} : {32'd0, w_sel};
        else if (wr_en)
            wbuf_q <= {16'd0, wbuf_q[47:16]};
    end

    // ---------------------------------------------------------------- block RAM
    // One write port (the recorder), one registered read port at CAP_ADDR: CAP_DATA shows the
    // entry one clock after an address change (every bus access is several clocks apart).
    reg [15:0] mem [0:DEPTH-1];
    reg [15:0] rdata_q;
    always @(posedge clk) begin
        if (wr_en)
            mem[count_q[AW-1:0]] <= wbuf_q[15:0];
        rdata_q <= mem[raddr_q];
    end

    wire unused_wdata = &{1'b0, s_wdata[15:10], s_wdata[7], s_wdata[3:1]};
    wire [31:0] cap_ctrl = {decim_q, 6'd0, tax_q, 1'b0, trig_q, sel_q, 4'd0};
    wire [31:0] cap_stat = {{(15 - AW){1'b0}}, count_q, 8'd0, DL2, 1'b0, busy_q, armed_q, done_q};
    wire [31:0] cap_addr = {{(32 - AW){1'b0}}, raddr_q};
    wire [31:0] cap_data = {16'd0, rdata_q};
    assign m_regs = {cap_data, cap_addr, cap_stat, cap_ctrl};
endmodule

`default_nettype wire
