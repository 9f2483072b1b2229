// SPDX-License-Identifier: Apache-2.0
// The stage clocks' equivalence check (README "Stage clocks"): the virtual device's top
// (hapgate_top; AXIS_MASK < 7: the held-axis bank) under a seeded random stimulus that the firmware never
// produces — ADC words with clipping and signal loss, index pulses, and bus traffic of every
// kind: mapped and unmapped reads and writes, FAULT_CLR, SNAP, HOME_ARM, enables, torques,
// modes, offsets and limits, watchdog keys (good and bad), TICK_DIV and WDOG_TIMEOUT in and out
// of range, IRQ acknowledges, strobes dropped before capture, read and write strobes together.
// Built twice, with HG_SIM_GATE (the stage clocks, driven as device_harness.cpp drives them)
// and without it (every register on clk); tb/device/test_stage_clocks.py compares the two
// output files: every output pin after every clock edge.
//
// usage: gate_equiv SEED CLOCKS OUTFILE
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "Vhapgate_top.h"
#include "Vhapgate_top___024root.h"
#include "stage_clocks.h"
#include "verilated.h"

extern "C" {
#include "hg_fpga_regs.h"
}

#ifndef CLK_HZ
#error "CLK_HZ must be defined to match the RTL parameter"
#endif
#ifndef HG_SIM_GATE
#error "HG_SIM_GATE (0 or 1) must be defined"
#endif

namespace {

constexpr uint64_t D = CLK_HZ / 1000000;   // clocks per 1 us sample

struct Rng {   // splitmix64: the same sequence in both builds
    uint64_t s;
    uint64_t next() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return z ^ (z >> 31);
    }
    uint32_t below(uint32_t n) { return static_cast<uint32_t>(next() % n); }
};

#pragma pack(push, 1)
struct Out {   // every output pin after an edge
    uint32_t bus_data_out;
    uint16_t dac_data;
    uint8_t dac_addr, dac_wr_n, irq, bus_data_oe, bus_ready, pad;
};
#pragma pack(pop)

struct Dut {
    std::unique_ptr<VerilatedContext> ctx{new VerilatedContext};
    std::unique_ptr<Vhapgate_top> top{new Vhapgate_top(ctx.get())};
#if HG_SIM_GATE
    unsigned gates = hg_dev::kAllGates;
    bool pins_changed = false;
    void set_gates(unsigned g) { hg_dev::set_gates(*top, g); }
#endif
    void pins() {
#if HG_SIM_GATE
        pins_changed = true;
#endif
    }
    void edge() {   // one full clock: rising edge (stage clocks as announced), falling edge
        top->clk = 1;
#if HG_SIM_GATE
        set_gates(top->rst ? hg_dev::kAllGates : (pins_changed ? (gates | hg_dev::kBusGate) : gates));
        pins_changed = false;
#endif
        top->eval();
#if HG_SIM_GATE
        gates = hg_dev::announced(*top);
#endif
        top->clk = 0;
#if HG_SIM_GATE
        set_gates(0);
#endif
        top->eval();
    }
};

// a write's address and data, biased toward the registers whose logic is gated
void pick_write(Rng& r, uint32_t& a, uint32_t& v) {
    const uint32_t ax = r.below(3);
    v = static_cast<uint32_t>(r.next());
    switch (r.below(16)) {
        case 0: case 13: a = HG_REG_CTRL; v = (r.below(4) ? 0x0FU : 0U) | (r.below(3) ? HG_CTRL_FAULT_CLR : 0)
                               | (r.below(4) ? 0 : HG_CTRL_SNAP) | (r.below(6) ? 0 : HG_CTRL_HOME_ARM); break;
        case 1: a = HG_REG_WDOG; v = r.below(5) ? 0x5AFEC0DEU : v; break;
        case 2: a = HG_REG_TICK_DIV; v = r.below(2) ? CLK_HZ / (1000 * (1 + r.below(10))) : v; break;
        case 3: a = HG_REG_WDOG_TIMEOUT; v = r.below(2) ? 100 + r.below(3000) : v; break;
        case 4: a = HG_REG_IRQ; v &= 3U; break;
        case 5: a = HG_REG_SCRATCH; break;
        case 6: case 7: a = HG_REG_AXIS(ax, HG_AX_TORQUE); v &= 0xFFFFU; break;
        case 8: a = HG_REG_AXIS(ax, HG_AX_MODE); v &= 3U; break;
        case 9: a = HG_REG_AXIS(ax, HG_AX_OFFSET); v &= 0x3FFU; break;
        case 10: a = HG_REG_AXIS(ax, HG_AX_TQ_LIMIT); v &= 0xFFFFU; break;
        case 11: a = HG_REG_HARM_ADDR; break;
        case 12: a = HG_REG_HARM_DATA; break;
        default: a = r.below(256); break;   // anything, unmapped included
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s SEED CLOCKS OUTFILE\n", argv[0]);
        return 2;
    }
    Rng r{std::strtoull(argv[1], nullptr, 0)};
    const uint64_t clocks = std::strtoull(argv[2], nullptr, 0);
    FILE* f = std::fopen(argv[3], "wb");
    if (!f) {
        std::fprintf(stderr, "error: %s: cannot write\n", argv[3]);
        return 2;
    }
    Dut d;
    auto& t = *d.top;
#if AXIS_MASK != 7
    const uint32_t pos_homed[3] = {1000, 2000, 3000}, index_pos[3] = {10, 20, 30},
                   index_count[3] = {1, 1, 1};
    hg_dev::set_held(t, pos_homed, index_pos, index_count);
#endif
    t.bus_ce_n = t.bus_re_n = t.bus_we_n = 1;
    t.clk = 0;
    t.rst = 1;
    t.eval();
    for (int i = 0; i < 4; ++i) d.edge();
    t.rst = 0;
    // the encoder: a phase per axis that moves (fast at times), amplitude 110, noise, clipping
    // bursts, signal loss bursts; the words change at every sample
    double ph[3] = {0.1, 1.7, 3.2}, w[3] = {0.02, -0.013, 0.05};
    int loss[3] = {0, 0, 0}, clip[3] = {0, 0, 0};
    // the bus: a small state machine of accesses (and of broken ones)
    enum { kIdle, kCe, kStrobe, kHold } st = kIdle;
    int left = 50, kind = 0;
    uint32_t addr = 0, data = 0;
    std::vector<Out> buf;
    buf.reserve(4096);
    for (uint64_t e = 0; e < clocks; ++e) {
        if (e % D == 0) {   // a new sample's words
            uint32_t wa = 0, wb = 0, wi = 0;
            for (int i = 0; i < 3; ++i) {
                if (r.below(20000) == 0) w[i] = (static_cast<double>(r.below(2001)) - 1000.0) * 1e-4;
                if (r.below(3000) == 0) loss[i] = 10 + static_cast<int>(r.below(1500));
                if (r.below(5000) == 0) clip[i] = 5 + static_cast<int>(r.below(100));
                ph[i] += w[i];
                const double amp = clip[i] > 0 ? 190.0 : 110.0;
                int a = static_cast<int>(amp * std::sin(ph[i])) + static_cast<int>(r.below(3)) - 1;
                int b = static_cast<int>(amp * std::cos(ph[i])) + static_cast<int>(r.below(3)) - 1;
                a = a < -128 ? -128 : (a > 127 ? 127 : a);
                b = b < -128 ? -128 : (b > 127 ? 127 : b);
                if (loss[i] > 0) { a = b = 0; --loss[i]; }
                if (clip[i] > 0) --clip[i];
                wa |= static_cast<uint32_t>(static_cast<uint8_t>(a)) << (8 * i);
                wb |= static_cast<uint32_t>(static_cast<uint8_t>(b)) << (8 * i);
                wi |= (r.below(500) == 0 ? 1U : 0U) << i;
            }
            t.adc_a = wa;
            t.adc_b = wb;
            t.enc_index = wi;
        }
        if (--left <= 0) {
            switch (st) {
                case kIdle:   // start an access: CE and address (a random pin toggle at times)
                    kind = static_cast<int>(r.below(10));   // 0..5 write, 6..8 read, 9 both strobes
                    if (kind <= 5) pick_write(r, addr, data);
                    else addr = r.below(2) ? HG_REG_AXIS(r.below(3), r.below(16)) : (r.below(8) ? r.below(16) : r.below(256));
                    t.bus_addr = addr & 0xFFU;
                    t.bus_data_in = data;
                    t.bus_ce_n = 0;
                    st = kCe;
                    left = 1 + static_cast<int>(r.below(3));
                    break;
                case kCe:     // the strobe; sometimes too short to be captured
                    if (kind <= 5 || kind == 9) t.bus_we_n = 0;
                    if (kind >= 6) t.bus_re_n = 0;
                    st = kStrobe;
                    left = r.below(8) ? static_cast<int>(D) + static_cast<int>(r.below(3 * D)) : 1 + static_cast<int>(r.below(3));
                    break;
                case kStrobe:
                    t.bus_we_n = t.bus_re_n = 1;
                    st = kHold;
                    left = 1 + static_cast<int>(r.below(3));
                    break;
                case kHold:
                    t.bus_ce_n = 1;
                    st = kIdle;
                    left = r.below(4) ? 2 + static_cast<int>(r.below(6 * D)) : static_cast<int>(r.below(100 * D)) + 1;
                    break;
            }
            d.pins();
        }
        d.edge();
        buf.push_back({t.bus_data_out, static_cast<uint16_t>(t.dac_data), static_cast<uint8_t>(t.dac_addr),
                       static_cast<uint8_t>(t.dac_wr_n), static_cast<uint8_t>(t.irq),
                       static_cast<uint8_t>(t.bus_data_oe), static_cast<uint8_t>(t.bus_ready), 0});
        if (buf.size() == 4096) {
            std::fwrite(buf.data(), sizeof(Out), buf.size(), f);
            buf.clear();
        }
    }
    std::fwrite(buf.data(), sizeof(Out), buf.size(), f);
    std::fclose(f);
    std::printf("clocks=%llu out_bytes=%zu\n", static_cast<unsigned long long>(clocks), sizeof(Out));
    t.final();
    return 0;
}
