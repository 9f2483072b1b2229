// SPDX-License-Identifier: Apache-2.0
// The simulation-only stage clocks of the virtual device's top (HG_SIM_GATE; README "Stage
// clocks"): their bits in sim_gate_en and how a harness drives them. Shared by
// device_harness.cpp and gate_equiv.cpp.
#pragma once

namespace hg_dev {

// sim_gate_en bits: {bus, comm, DE, C, B, A}
constexpr unsigned kAllGates = 0x3F;   // every stage clock (reset)
constexpr unsigned kBusGate = 0x20;    // the bus clock: also after the harness changed a bus pin

// The enables the design announced for the next edge, as sim_gate_en bits (the top's one
// simulation-only port bundle: rtl/include/hg_sim.vh).
template <class Top>
inline unsigned announced(const Top& t) {
    return static_cast<unsigned>(t.sim_gate_en);
}

// Drive the stage clocks high whose bit is set (with clk's rising edge), or all low (g = 0).
template <class Top>
inline void set_gates(Top& t, unsigned g) {
    t.sim_gclk = static_cast<decltype(+t.sim_gclk)>(g);
}

}  // namespace hg_dev
