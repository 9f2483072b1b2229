// SPDX-License-Identifier: Apache-2.0
// The one simulation-only mechanism of rtl/ (docs/design/SIMULATION.md): macros that expand to
// nothing, or to clk, in synthesis and in every simulation without the defines below. A reader
// of the design can skip every line that uses them. Defines, set only by the virtual device's
// and the commutation harness's builds (models/hapgate/device/runner.py, runners/native_comm.py;
// the virtual device's held axes are outside rtl/: tb/native/device/held/enc_interp3.v):
//   HG_SIM_GATE  the virtual device's stage clocks: a module's registers of a stage on a clock the
//                harness drives as clk in the cycles whose enable the module announced
//   HG_SIM_SKIP  dac_sched's idle-clock skip hook (tb/native/commutation/dac_sched_skip.v)
`ifndef HG_SIM_VH
`define HG_SIM_VH

`ifdef HG_SIM_GATE
// a module's one simulation-only port bundle: N stage clocks in, their N enables (for the next
// edge) out; written after the last port, without a comma before it
`define HG_SIM_PORTS(N) , input wire [(N)-1:0] sim_gclk, output wire [(N)-1:0] sim_gate_en
// the top's bundle: its six stage clocks {bus, comm, interpolator D+E, C, B, A} in, their
// enables out, the bus clock's on a port of its own (it reads only the bus clock's registers and
// the pins: apart, Verilator evaluates it only when those change, not at every clock)
`define HG_SIM_TOP_PORTS , input wire sim_gclk_a, input wire sim_gclk_b, input wire sim_gclk_c, input wire sim_gclk_de, input wire sim_gclk_comm, input wire sim_gclk_bus, output wire [4:0] sim_gate_en, output wire sim_gate_en_bus
// the clock of the module's stage I: CLK in the design, the harness's stage clock I here
`define HG_SIM_CLK(CLK, I) sim_gclk[I]
// a sub-block's bundle, connected after its last port: its clocks, its enables
`define HG_SIM_BIND(GCLK, EN) , .sim_gclk(GCLK), .sim_gate_en(EN)
// the module's enables, an expression of its state after this edge
`define HG_SIM_EN(EXPR) assign sim_gate_en = EXPR;
// declarations only the enables read
`define HG_SIM_GATE_ONLY(TEXT) TEXT
`else
`define HG_SIM_PORTS(N)
`define HG_SIM_TOP_PORTS
`define HG_SIM_CLK(CLK, I) CLK
`define HG_SIM_BIND(GCLK, EN)
`define HG_SIM_EN(EXPR)
`define HG_SIM_GATE_ONLY(TEXT)
`endif

`ifdef HG_SIM_SKIP
// dac_sched's idle-clock skip: the hook (a simulation-only module, its own README) and the
// extra clocks it adds to an edge of the frame and slot counters
`define HG_SIM_SKIP_HOOK wire [FW-1:0] sim_skip; dac_sched_skip #(.FW(FW), .SW(SW), .CW(CW), .SKEW_CYCLES(SKEW_CYCLES), .FRAME_CYCLES(FRAME_CYCLES), .CHANNELS(CHANNELS)) u_skip (.clk(clk), .rst(rst), .m_req(m_req), .s_valid(s_valid), .wr_go(wr_go), .dac_wr_n(dac_wr_n), .m_frame(m_frame), .slot_cnt(slot_cnt), .frame_cnt(frame_cnt), .skip(sim_skip));
`define HG_SIM_SKIP_ADD(W) + sim_skip[(W)-1:0]
`else
`define HG_SIM_SKIP_HOOK
`define HG_SIM_SKIP_ADD(W)
`endif

`endif
