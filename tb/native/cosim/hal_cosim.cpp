// SPDX-License-Identifier: Apache-2.0
// Co-simulation HAL: the firmware's fpga_read32/fpga_write32 drive the EMIF-like bus pins of the
// Verilated hapgate_top through the shared bus master (tb/native/device/bus_hal.h) with SETUP /
// STROBE / HOLD measured in FPGA clocks (or wait for ready), counting accesses and writes. The irq save/restore pair is a no-op: the
// runner is single-threaded and calls the ISR only between background steps.
#include <cstdio>
#include <cstdlib>

#include "Vhapgate_top___024root.h"
#include "cosim.h"
#include "dac_word.h"

extern "C" {
#include "hg_fpga_regs.h"
#include "hg_hal.h"
}

namespace cosim {

Testbench* tb = nullptr;
BusTiming bus_timing;
BusStats bus_stats;
std::vector<BusWrite> bus_writes;
int64_t current_isr = -1;
hg_dev::Scenario* scenario = nullptr;

Testbench::Testbench() {
    top->bus_ce_n = top->bus_re_n = top->bus_we_n = 1;
    top->bus_addr = 0;
    top->bus_data_in = 0;
    top->adc_a = top->adc_b = 0;
    top->enc_index = 0;
    top->eval();
}

void Testbench::reset() {
    TestB::reset(4);
    prev_wr_n_ = top->dac_wr_n;
    prev_irq_ = top->irq;
}

void Testbench::tick() {
    rise();
    // monitors (values right after the edge)
    const int wr_n = top->dac_wr_n;
    if (wr_n && !prev_wr_n_) {
        loads.push_back({edge, static_cast<int>(top->dac_addr), hg_dac::decode(top->dac_data)});
    }
    prev_wr_n_ = wr_n;
    if (top->irq && !prev_irq_) {
        irq_rose = true;
        irq_rise_edge = edge;
    }
    prev_irq_ = top->irq;
    auto* r = top->rootp;
    if (!wdog_expired_edge && r->hapgate_top__DOT__wdog_expired) wdog_expired_edge = edge;
    for (int i = 0; i < 3; ++i)
        if (!fault_edge[i] && ((r->hapgate_top__DOT__fault >> i) & 1U)) fault_edge[i] = edge;
    fall();
    // stimulus for the sample captured at the next edge
    if (top->adc_strobe && adc) {
        uint32_t a = 0, b = 0, idx = 0;
        adc(edge + 1, a, b, idx);
        top->adc_a = a;
        top->adc_b = b;
        top->enc_index = idx & 7U;
        top->eval();
    }
}

namespace {

const hg_bus::Timing& timing() {
    static bool checked = false;
    const hg_bus::Timing& t = bus_timing;
    if (checked) return t;
    checked = true;
    const char* why = hg_bus::check(t);
    if (*why) {
        std::fprintf(stderr, "error: bus timing setup=%d strobe=%d hold=%d violates the documented minimums: %s\n",
                     t.setup, t.strobe, t.hold, why);
        std::exit(2);
    }
    return t;
}

}  // namespace
}  // namespace cosim

using namespace cosim;

extern "C" uint32_t fpga_read32(uint32_t addr) {
    bool oe = false;
    const uint32_t v = hg_bus::read(*tb, timing(), addr, &oe);
    if (!oe) ++bus_stats.not_oe;
    ++bus_stats.reads;
    return v;
}

extern "C" void fpga_write32(uint32_t addr, uint32_t v) {
    const hg_bus::Timing t = timing();
    if (scenario && scenario->write_lost(addr)) {
        bus_writes.push_back({tb->edge, tb->edge, addr, v, true, current_isr});
        ++bus_stats.dropped;
        return;
    }
    uint64_t fall = 0, rise = 0;
    hg_bus::write(*tb, t, addr, v, &fall, &rise);
    bus_writes.push_back({fall, rise, addr, v, false, current_isr});
    if (scenario && addr == HG_REG_WDOG) scenario->key_written(static_cast<int64_t>(rise));
    ++bus_stats.writes;
}

extern "C" uint32_t hg_hal_irq_save(void) { return 0; }
extern "C" void hg_hal_irq_restore(uint32_t token) { (void)token; }
