// SPDX-License-Identifier: Apache-2.0
// The virtual device's simulation-only hooks as a harness drives them (docs/design/SIMULATION.md):
// the top's stage clocks (HG_SIM_GATE; README "Stage clocks"), their bits in sim_gate_en, and the
// values of the held axes (README "Axes that are not built"). Shared by device_harness.cpp and
// gate_equiv.cpp.
#pragma once

#include <cstdint>

namespace hg_dev {

// sim_gate_en bits: {bus, comm, DE, C, B, A}
constexpr unsigned kAllGates = 0x3F;   // every stage clock (reset)
constexpr unsigned kBusGate = 0x20;    // the bus clock: also after the harness changed a bus pin

// The enables the design announced for the next edge, as sim_gclk bits (the top's one
// simulation-only port bundle, rtl/include/hg_sim.vh: the bus clock's on a port of its own).
template <class Top>
inline unsigned announced(const Top& t) {
    return static_cast<unsigned>(t.sim_gate_en) | (static_cast<unsigned>(t.sim_gate_en_bus) << 5);
}

// Drive the stage clocks high whose bit is set (with clk's rising edge), or all low (g = 0).
template <class Top>
inline void set_gates(Top& t, unsigned g) {
    t.sim_gclk_a = g & 1U;
    t.sim_gclk_b = (g >> 1) & 1U;
    t.sim_gclk_c = (g >> 2) & 1U;
    t.sim_gclk_de = (g >> 3) & 1U;
    t.sim_gclk_comm = (g >> 4) & 1U;
    t.sim_gclk_bus = (g >> 5) & 1U;
}

#if defined(AXIS_MASK) && AXIS_MASK != 7
// What the interpolators of the axes not built report (tb/native/device/held/enc_interp3.v:
// `verilator public` registers, written before the first evaluation).
template <class Top>
inline void set_held(Top& t, const uint32_t pos_homed[3], const uint32_t index_pos[3],
                     const uint32_t index_count[3]) {
    auto* r = t.rootp;
    for (int i = 0; i < 3; ++i) {
        r->hapgate_top__DOT__u_interp__DOT__hold_pos_homed[i] = pos_homed[i];
        r->hapgate_top__DOT__u_interp__DOT__hold_index_pos[i] = index_pos[i];
    }
    r->hapgate_top__DOT__u_interp__DOT__hold_index_count =
        (static_cast<uint64_t>(index_count[2] & 0xFFFF) << 32) |
        (static_cast<uint64_t>(index_count[1] & 0xFFFF) << 16) | (index_count[0] & 0xFFFF);
}
#endif

}  // namespace hg_dev
