// SPDX-License-Identifier: Apache-2.0
// Co-simulation HAL: the firmware's fpga_read32/fpga_write32 drive the EMIF-like bus pins of the
// Verilated hapgate_top with SETUP / STROBE / HOLD measured in FPGA clocks (or wait for ready),
// ticking the clock as a real access takes time. The irq save/restore pair is a no-op: the
// runner is single-threaded and calls the ISR only between background steps.
#include <cstdio>
#include <cstdlib>

#include "Vhapgate_top___024root.h"
#include "cosim.h"

extern "C" {
#include "hg_hal.h"
}

namespace cosim {

Testbench* tb = nullptr;
BusTiming bus_timing;
BusStats bus_stats;
std::vector<BusWrite> bus_writes;
int64_t current_isr = -1;
bool drop_enable = false;
uint32_t drop_addr = 0;

Testbench::Testbench() : ctx(new VerilatedContext), top(new Vhapgate_top(ctx.get())) {
    top->clk = 0;
    top->rst = 1;
    top->bus_ce_n = top->bus_re_n = top->bus_we_n = 1;
    top->bus_addr = 0;
    top->bus_data_in = 0;
    top->adc_a = top->adc_b = 0;
    top->enc_index = 0;
    top->eval();
}

Testbench::~Testbench() { top->final(); }

void Testbench::reset() {
    top->rst = 1;
    for (int i = 0; i < 4; ++i) {
        top->clk = 1; top->eval();
        top->clk = 0; top->eval();
    }
    edge = 0;  // the last edge above sampled rst high
    top->rst = 0;
    top->eval();
    prev_wr_n_ = top->dac_wr_n;
    prev_irq_ = top->irq;
}

void Testbench::tick() {
    top->clk = 1;
    top->eval();
    ++edge;
    // monitors (values right after the edge)
    const int wr_n = top->dac_wr_n;
    if (wr_n && !prev_wr_n_) {
        int code = static_cast<int>(top->dac_data);
        if (code >= 8192) code -= 16384;  // 14-bit two's complement (OFFSET_BINARY = 0)
        loads.push_back({edge, static_cast<int>(top->dac_addr), code});
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
    top->clk = 0;
    top->eval();
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

void check_timing() {
    static bool checked = false;
    if (checked) return;
    checked = true;
    const BusTiming& t = bus_timing;
    if (t.setup < 0 || t.hold < 0 || t.hold + t.setup < 3 || (!t.use_ready && t.strobe < 5)) {
        std::fprintf(stderr, "error: bus timing setup=%d strobe=%d hold=%d violates the "
                     "documented minimums (strobe >= 5 or ready, recovery >= 3)\n",
                     t.setup, t.strobe, t.hold);
        std::exit(2);
    }
}

// Strobe low until the access is done: STROBE clocks, or until ready (bounded).
void strobe_phase() {
    if (bus_timing.use_ready) {
        for (int n = 0; n < 64; ++n) {
            tb->tick();
            if (tb->top->bus_ready) return;
        }
        std::fprintf(stderr, "error: bus_ready never came (edge %llu)\n",
                     static_cast<unsigned long long>(tb->edge));
        std::exit(3);
    }
    for (int n = 0; n < bus_timing.strobe; ++n) tb->tick();
}

}  // namespace
}  // namespace cosim

using namespace cosim;

extern "C" uint32_t fpga_read32(uint32_t addr) {
    check_timing();
    auto& t = *tb->top;
    t.bus_addr = addr & 0xFFU;
    t.bus_ce_n = 0;
    t.eval();
    for (int n = 0; n < bus_timing.setup; ++n) tb->tick();
    t.bus_re_n = 0;
    t.eval();
    strobe_phase();
    if (!t.bus_data_oe) ++bus_stats.not_oe;
    const uint32_t v = t.bus_data_out;  // sampled just before the strobe rises
    t.bus_re_n = 1;
    t.eval();
    for (int n = 0; n < bus_timing.hold; ++n) tb->tick();
    t.bus_ce_n = 1;
    t.eval();
    ++bus_stats.reads;
    return v;
}

extern "C" void fpga_write32(uint32_t addr, uint32_t v) {
    check_timing();
    if (drop_enable && addr == drop_addr) {
        bus_writes.push_back({tb->edge, tb->edge, addr, v, true, current_isr});
        ++bus_stats.dropped;
        return;
    }
    auto& t = *tb->top;
    t.bus_addr = addr & 0xFFU;
    t.bus_data_in = v;
    t.bus_ce_n = 0;
    t.eval();
    for (int n = 0; n < bus_timing.setup; ++n) tb->tick();
    t.bus_we_n = 0;
    t.eval();
    const uint64_t fall = tb->edge;  // the strobe falls after this edge
    strobe_phase();
    t.bus_we_n = 1;
    t.eval();
    const uint64_t rise = tb->edge;  // ... and rises after this one
    for (int n = 0; n < bus_timing.hold; ++n) tb->tick();
    t.bus_ce_n = 1;
    t.eval();
    bus_writes.push_back({fall, rise, addr, v, false, current_isr});
    ++bus_stats.writes;
}

extern "C" uint32_t hg_hal_irq_save(void) { return 0; }
extern "C" void hg_hal_irq_restore(uint32_t token) { (void)token; }
