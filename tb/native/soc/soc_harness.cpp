// SPDX-License-Identifier: Apache-2.0
// The hapgate SoC (rtl/soc/hapgate_soc_top.v: the soft CPU running the firmware image, and the
// whole FPGA) with its UART pins driven and decoded bit by bit, as a PC's serial port would.
// The image is the RAM's $readmemh file, FW_FILE, read from the working directory at start.
//
//   soc_harness clocks=N out=DIR [send=EDGE:HEX]... [peek=ADDR,...] [profile=1] [trace=FILE.vcd]
//
// send: the bytes HEX (an encoded frame) start on the rx pin at rising edge EDGE, or when the
// previous send has ended, 8N1 at BAUD from CLK_HZ (fractional bit times, rounded per edge).
// Written to DIR: tx.txt (one received byte per line: the edge of its start bit, the byte,
// 1 if its stop bit was high) and ticks.txt (per servo tick: the edge irq rose, the edge it
// fell (0: still high at the end), the register accesses from the rise to the fall, and SEQ,
// the snapshot the interrupt announces). stdout:
// (the FPGA's own ticks, hg_regfile's tick pulse, are counted apart from the interrupts: a tick
// while the previous one is still pending raises no new interrupt, it sets IRQ.MISSED, whose
// settings are counted too)
// key=value lines (the summary, and peek=ADDR:VALUE for each RAM word asked for at the end).
// profile=1 also writes DIR/profile.txt: per PC, the clocks and the instructions retired there
// while the tick interrupt was pending (VexRiscv's public lastStagePc: the clocks of a stall
// count at the instruction in its last stage).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "Vhapgate_soc_top.h"
#include "Vhapgate_soc_top___024root.h"
#include "Vhapgate_soc_top_hapgate_soc_top.h"   // the public signals (public.vlt): the pinned
#include "Vhapgate_soc_top_hg_soc.h"            // Verilator keeps these two modules apart
#include "Vhapgate_soc_top_VexRiscv.h"           // (and the CPU, whose last-stage PC is public)
#include "testb.h"

#ifndef CLK_HZ
#error "build with -DCLK_HZ=... -DBAUD=..."
#endif

namespace {

constexpr double kBit = static_cast<double>(CLK_HZ) / static_cast<double>(BAUD);  // clocks

struct Edge {
    uint64_t edge;
    int level;
};

// The rx line's transitions for every send, in order.
std::vector<Edge> schedule(const std::vector<std::pair<uint64_t, std::vector<uint8_t>>>& sends) {
    std::vector<Edge> ev;
    double free_at = 0.0;
    for (const auto& s : sends) {
        double t0 = std::max(static_cast<double>(s.first), free_at);
        for (size_t j = 0; j < s.second.size(); ++j) {
            const unsigned frame = (static_cast<unsigned>(s.second[j]) << 1) | (1U << 9);
            for (int k = 0; k < 10; ++k) {
                const double t = t0 + (static_cast<double>(j) * 10.0 + k) * kBit;
                ev.push_back({static_cast<uint64_t>(std::llround(t)), static_cast<int>((frame >> k) & 1U)});
            }
        }
        free_at = t0 + static_cast<double>(s.second.size()) * 10.0 * kBit;
        ev.push_back({static_cast<uint64_t>(std::llround(free_at)), 1});
    }
    return ev;
}

std::vector<uint8_t> unhex(const char* h) {
    std::vector<uint8_t> out;
    const size_t n = std::strlen(h);
    if (n % 2) {
        std::fprintf(stderr, "error: odd hex length in send=\n");
        std::exit(2);
    }
    for (size_t i = 0; i < n; i += 2) {
        char b[3] = {h[i], h[i + 1], 0};
        out.push_back(static_cast<uint8_t>(std::strtoul(b, nullptr, 16)));
    }
    return out;
}

struct TxDecoder {  // the PC's receiver on the tx pin
    bool busy = false;
    uint64_t start = 0;
    int k = 0;
    unsigned bits = 0;
    FILE* out = nullptr;
    uint64_t bytes = 0, framing = 0;
    void at(uint64_t edge, int level) {
        if (!busy) {
            if (level == 0) {
                busy = true;
                start = edge;
                k = 0;
                bits = 0;
            }
            return;
        }
        const uint64_t when = start + static_cast<uint64_t>(std::llround((k + 0.5) * kBit));
        if (edge != when) return;
        bits |= static_cast<unsigned>(level) << k;
        if (++k == 10) {
            const bool ok = (bits & 1U) == 0 && ((bits >> 9) & 1U) == 1;
            std::fprintf(out, "%llu %u %d\n", static_cast<unsigned long long>(start),
                         (bits >> 1) & 0xFFU, ok ? 1 : 0);
            ++bytes;
            framing += ok ? 0 : 1;
            busy = false;
        }
    }
};

}  // namespace

int main(int argc, char** argv) {
    uint64_t clocks = 0;
    std::string out_dir = ".", trace;
    bool profile = false;
    std::vector<std::pair<uint64_t, std::vector<uint8_t>>> sends;
    std::vector<uint32_t> peeks;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto eq = a.find('=');
        const std::string k = a.substr(0, eq), v = eq == std::string::npos ? "" : a.substr(eq + 1);
        if (k == "clocks") {
            clocks = std::strtoull(v.c_str(), nullptr, 0);
        } else if (k == "out") {
            out_dir = v;
        } else if (k == "profile") {
            profile = v == "1";
        } else if (k == "trace") {
            trace = v;
        } else if (k == "send") {
            const auto c = v.find(':');
            if (c == std::string::npos) {
                std::fprintf(stderr, "error: send=EDGE:HEX, got %s\n", v.c_str());
                return 2;
            }
            sends.emplace_back(std::strtoull(v.substr(0, c).c_str(), nullptr, 0),
                               unhex(v.substr(c + 1).c_str()));
        } else if (k == "peek") {
            size_t p = 0;
            while (p < v.size()) {
                const size_t q = v.find(',', p);
                peeks.push_back(static_cast<uint32_t>(
                    std::strtoul(v.substr(p, q == std::string::npos ? q : q - p).c_str(), nullptr, 0)));
                p = q == std::string::npos ? v.size() : q + 1;
            }
        } else {
            std::fprintf(stderr, "error: unknown argument %s\n", a.c_str());
            return 2;
        }
    }
    if (clocks == 0) {
        std::fprintf(stderr, "error: clocks=N is required\n");
        return 2;
    }
    const std::vector<Edge> rx_ev = schedule(sends);

    hg_tb::TestB<Vhapgate_soc_top> tb;
#if VM_TRACE
    if (!trace.empty()) tb.trace(trace);
#endif
    auto* top = tb.top.get();
    auto* st = top->rootp->hapgate_soc_top;   // hapgate_soc_top's signals
    // a still encoder on every axis, inside the amplitude window: no signal-loss fault
    const int a_code[3] = {67, -40, 100}, b_code[3] = {92, 105, -55};
    uint32_t a = 0, b = 0;
    for (int i = 0; i < 3; ++i) {
        a |= (static_cast<uint32_t>(a_code[i]) & 0xFFU) << (8 * i);
        b |= (static_cast<uint32_t>(b_code[i]) & 0xFFU) << (8 * i);
    }
    top->adc_a = a;
    top->adc_b = b;
    top->enc_index = 0;
    top->uart_rx = 1;
    tb.hold_reset(16);
    tb.release();

    FILE* tx_f = std::fopen((out_dir + "/tx.txt").c_str(), "w");
    FILE* tick_f = std::fopen((out_dir + "/ticks.txt").c_str(), "w");
    if (!tx_f || !tick_f) {
        std::fprintf(stderr, "error: cannot write into %s\n", out_dir.c_str());
        return 2;
    }
    TxDecoder dec;
    dec.out = tx_f;
    size_t ev_i = 0;
    int prev_irq = 0, prev_ce = 1;
    uint64_t rise_edge = 0, accesses = 0, ticks = 0, acked = 0, all_accesses = 0;
    uint64_t hi_max = 0, hi_min = UINT64_MAX, period_min = UINT64_MAX, period_max = 0;
    uint64_t last_rise = 0, irq_writes = 0, retired_irq = 0, clocks_irq = 0;
    uint64_t ibus_irq = 0, dbus_irq = 0;   // clocks with an instruction / data bus cycle open
    uint64_t fpga_ticks = 0, fpga_last = 0, fpga_min = UINT64_MAX, fpga_max = 0;  // the regfile's
    uint64_t missed_sets = 0, rise_seq = 0;
    int prev_missed = 0;
    std::map<uint32_t, std::pair<uint64_t, uint64_t>> prof;   // pc -> (clocks, retired)
    const auto* cpu = st->u_soc->u_cpu;

    for (uint64_t e = 1; e <= clocks; ++e) {
        while (ev_i < rx_ev.size() && rx_ev[ev_i].edge <= e) top->uart_rx = rx_ev[ev_i++].level & 1;
        tb.rise();
        dec.at(tb.edge, top->uart_tx);
        if (st->u_top__DOT__u_bus__DOT__u_regs__DOT__tick) {   // the FPGA's servo tick itself
            if (fpga_ticks) {
                fpga_min = std::min(fpga_min, tb.edge - fpga_last);
                fpga_max = std::max(fpga_max, tb.edge - fpga_last);
            }
            fpga_last = tb.edge;
            ++fpga_ticks;
        }
        const int missed = st->u_top__DOT__u_bus__DOT__u_regs__DOT__irq_missed_q;
        missed_sets += (missed && !prev_missed) ? 1 : 0;
        prev_missed = missed;
        const int irq = st->irq;
        const int ce = st->bus_ce_n;
        if (!ce && prev_ce) {   // an access starts
            ++accesses;
            ++all_accesses;
            if (!st->bus_we_n && st->bus_addr == 5) ++irq_writes;
        }
        prev_ce = ce;
        if (irq && !prev_irq) {
            if (ticks) {
                const uint64_t p = tb.edge - last_rise;
                period_min = std::min(period_min, p);
                period_max = std::max(period_max, p);
            }
            last_rise = rise_edge = tb.edge;
            rise_seq = st->u_top__DOT__u_bus__DOT__u_regs__DOT__seq_q;
            accesses = 0;
            ++ticks;
        } else if (!irq && prev_irq) {
            const uint64_t hi = tb.edge - rise_edge;
            hi_max = std::max(hi_max, hi);
            hi_min = std::min(hi_min, hi);
            std::fprintf(tick_f, "%llu %llu %llu %llu\n",
                         static_cast<unsigned long long>(rise_edge),
                         static_cast<unsigned long long>(tb.edge),
                         static_cast<unsigned long long>(accesses),
                         static_cast<unsigned long long>(rise_seq));
            ++acked;
        }
        prev_irq = irq;
        if (irq) {
            ++clocks_irq;
            retired_irq += cpu->lastStageIsFiring;
            ibus_irq += st->u_soc->i_cyc;
            dbus_irq += st->u_soc->d_cyc;
            if (profile) {
                auto& p = prof[cpu->lastStagePc];
                ++p.first;
                p.second += cpu->lastStageIsFiring;
            }
        }
        tb.fall();
    }
    if (prev_irq)
        std::fprintf(tick_f, "%llu 0 %llu %llu\n", static_cast<unsigned long long>(rise_edge),
                     static_cast<unsigned long long>(accesses),
                     static_cast<unsigned long long>(rise_seq));
    std::fclose(tx_f);
    std::fclose(tick_f);

    std::printf("clocks=%llu\nclk_hz=%d\nbaud=%d\n", static_cast<unsigned long long>(tb.edge),
                CLK_HZ, BAUD);
    std::printf("ticks=%llu\nacked=%llu\nirq_writes=%llu\naccesses=%llu\n",
                static_cast<unsigned long long>(ticks), static_cast<unsigned long long>(acked),
                static_cast<unsigned long long>(irq_writes),
                static_cast<unsigned long long>(all_accesses));
    std::printf("irq_high_min=%llu\nirq_high_max=%llu\nperiod_min=%llu\nperiod_max=%llu\n",
                static_cast<unsigned long long>(acked ? hi_min : 0),
                static_cast<unsigned long long>(hi_max),
                static_cast<unsigned long long>(ticks > 1 ? period_min : 0),
                static_cast<unsigned long long>(period_max));
    std::printf("irq_missed_sets=%llu\nirq_missed_end=%d\n",
                static_cast<unsigned long long>(missed_sets), prev_missed);
    std::printf("fpga_ticks=%llu\nfpga_period_min=%llu\nfpga_period_max=%llu\n",
                static_cast<unsigned long long>(fpga_ticks),
                static_cast<unsigned long long>(fpga_ticks > 1 ? fpga_min : 0),
                static_cast<unsigned long long>(fpga_max));
    std::printf("irq_clocks=%llu\nirq_retired=%llu\nirq_ibus_clocks=%llu\nirq_dbus_clocks=%llu\n",
                static_cast<unsigned long long>(clocks_irq),
                static_cast<unsigned long long>(retired_irq),
                static_cast<unsigned long long>(ibus_irq), static_cast<unsigned long long>(dbus_irq));
    if (profile) {
        FILE* pf = std::fopen((out_dir + "/profile.txt").c_str(), "w");
        for (const auto& [pc, n] : prof)
            std::fprintf(pf, "%x %llu %llu\n", pc, static_cast<unsigned long long>(n.first),
                         static_cast<unsigned long long>(n.second));
        std::fclose(pf);
    }
    std::printf("tx_bytes=%llu\ntx_framing_errors=%llu\nrx_bytes=%zu\n",
                static_cast<unsigned long long>(dec.bytes),
                static_cast<unsigned long long>(dec.framing), (rx_ev.size() - sends.size()) / 10);
    const auto& mem = st->u_soc->u_ram__DOT__mem;
    for (uint32_t p : peeks) {
        if (p % 4 != 0 || p / 4 >= mem.size()) {
            std::fprintf(stderr, "error: peek=0x%x is not a word of the RAM\n", p);
            return 2;
        }
        std::printf("peek=0x%x:%u\n", p, static_cast<unsigned>(mem[p / 4]));
    }
    return 0;
}
