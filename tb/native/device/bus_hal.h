// SPDX-License-Identifier: Apache-2.0
// The DSP bus master, one for every Verilated harness: the firmware's fpga_read32/fpga_write32
// as EMIF-like accesses on the top's bus pins (rtl/bus/README.md), ticking the clock as a real
// access takes time. Timing in FPGA clocks: SETUP (CE and address valid before the strobe
// falls), STROBE (or until ready), HOLD (after the strobe rises). On a grid (the virtual device,
// README "Why any clock gives the same result") an access starts at a grid point and its strobe
// ends at the next one. The testbench TB gives top (the model), edge (posedges since reset),
// tick() (one clock) and pins() (a bus pin changed: evaluate or mark it).
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace hg_bus {

struct Timing {
    int setup = 1;        // clocks, CE low and address/data valid before the strobe falls
    int strobe = 5;       // clocks the strobe is low (unless use_ready or grid)
    int hold = 2;         // clocks after the strobe rises, before CE rises / the next setup
    bool use_ready = false;   // strobe until ready is seen (bounded)
    uint64_t grid = 0;    // > 0: start on a multiple of grid clocks, strobe to the next one
};

// The documented minimums (strobe >= 5 or ready, recovery = setup + hold >= 3): "" or a reason.
inline const char* check(const Timing& t) {
    if (t.setup < 0 || t.hold < 0 || t.hold + t.setup < 3) return "recovery (setup + hold) must be >= 3";
    if (!t.use_ready && !t.grid && t.strobe < 5) return "strobe must be >= 5 clocks (or ready)";
    if (t.grid && t.grid < static_cast<uint64_t>(t.setup) + 5) return "a grid step must hold setup + a 5-clock strobe";
    return "";
}

// The virtual device's bus timing (device_harness.cpp; model_harness.cpp models the same
// accesses without pins): setup 1, strobe from the next clock to the next grid point, hold 2.
constexpr Timing device_timing(uint64_t clocks_per_grid_point) { return Timing{1, 5, 2, false, clocks_per_grid_point}; }

// The edges of a grid access starting at grid point g (edge g * t.grid) as the slave serves it
// (rtl/bus/emif_slave.v): the strobe falls after edge strobe_fall; its two-stage synchroniser
// shows it after strobe_fall + 2, when the read data are taken from the register file's state
// (read_state); the register file serves the access (a write's commit, a read's bus-error
// check) at the edge after the capture (commit = strobe_fall + 4); the strobe rises after
// strobe_rise (the next grid point) and the access ends hold clocks later (end). A model of the
// slave (model_harness.cpp) applies the access at these edges; the pin-level master above
// produces them.
struct GridAccess { int64_t strobe_fall, read_state, commit, strobe_rise, end; };
constexpr int kSyncStages = 2;
constexpr GridAccess grid_access(const Timing& t, int64_t g) {
    const int64_t grid = static_cast<int64_t>(t.grid), fall = g * grid + t.setup;
    return {fall, fall + kSyncStages, fall + kSyncStages + 2, (g + 1) * grid, (g + 1) * grid + t.hold};
}

namespace detail {
template <class TB>
void start(TB& tb, const Timing& t) {
    if (t.grid)
        while (tb.edge % t.grid != 0) tb.tick();
}
template <class TB>
void strobe(TB& tb, const Timing& t) {
    if (t.grid) {
        do tb.tick(); while (tb.edge % t.grid != 0);
    } else if (t.use_ready) {
        for (int n = 0; n < 64; ++n) {
            tb.tick();
            if (tb.top->bus_ready) return;
        }
        std::fprintf(stderr, "error: bus_ready never came (edge %llu)\n", static_cast<unsigned long long>(tb.edge));
        std::exit(3);
    } else {
        for (int n = 0; n < t.strobe; ++n) tb.tick();
    }
}
}  // namespace detail

// A read; the data are taken just before the strobe rises (oe: the slave drove them).
template <class TB>
uint32_t read(TB& tb, const Timing& t, uint32_t addr, bool* oe = nullptr) {
    detail::start(tb, t);
    auto& p = *tb.top;
    p.bus_addr = addr & 0xFFU;
    p.bus_ce_n = 0;
    tb.pins();
    for (int n = 0; n < t.setup; ++n) tb.tick();
    p.bus_re_n = 0;
    tb.pins();
    detail::strobe(tb, t);
    if (oe) *oe = p.bus_data_oe;
    const uint32_t v = p.bus_data_out;
    p.bus_re_n = 1;
    tb.pins();
    for (int n = 0; n < t.hold; ++n) tb.tick();
    p.bus_ce_n = 1;
    tb.pins();
    return v;
}

// A write; fall and rise: the edges after which the strobe fell and rose.
template <class TB>
void write(TB& tb, const Timing& t, uint32_t addr, uint32_t v, uint64_t* fall = nullptr, uint64_t* rise = nullptr) {
    detail::start(tb, t);
    auto& p = *tb.top;
    p.bus_addr = addr & 0xFFU;
    p.bus_data_in = v;
    p.bus_ce_n = 0;
    tb.pins();
    for (int n = 0; n < t.setup; ++n) tb.tick();
    p.bus_we_n = 0;
    tb.pins();
    if (fall) *fall = tb.edge;
    detail::strobe(tb, t);
    p.bus_we_n = 1;
    tb.pins();
    if (rise) *rise = tb.edge;
    for (int n = 0; n < t.hold; ++n) tb.tick();
    p.bus_ce_n = 1;
    tb.pins();
}

}  // namespace hg_bus
