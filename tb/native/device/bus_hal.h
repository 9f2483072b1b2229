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
