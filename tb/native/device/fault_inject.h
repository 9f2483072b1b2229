// SPDX-License-Identifier: Apache-2.0
// Fault injection into the gateware's own flip-flops (issue 38, scenes/seu/README.md): the
// device harness built on the saboteur netlist (hapgate.flows.saboteur, -DHG_FI=1
// -DHG_FI_SITES=N) drives its three N-bit injection ports, fi_flip, fi_clr and fi_set, from the
// run configuration's `seu` and `stuck` faults (harness_common.h). Kept apart from
// device_harness.cpp, which calls it at two points of its clock loop: before() just before a
// rising edge is evaluated and after() just after it.
//
//   seu at edge E:          fi_flip[site] is high for the one clock that ends with edge E:
//                           every reader of the flip-flop, its own hold path included, sees the
//                           inverted value at E, so a register that holds keeps it (an upset),
//                           one that loads at E takes its new value (the upset is seen by the
//                           logic behind it for that clock only).
//   stuck V from edge E:    fi_clr[site] (V = 0) or fi_set[site] (V = 1) is high from the clock
//                           ending with edge E for FRAMES DAC frames (FRAMES x the frame's clocks);
//                           released, the flip-flop shows what it holds by then.
//
// E is the edge of the fault's scene time at_s: scene time 0 is the grid point scene0_us, and
// at_s x CLK_HZ clocks after it (rounded). After the last injected edge the ports are cleared and
// the input logic is evaluated again at once (settle), so that the outputs read after that edge
// are the design's.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "harness_common.h"

#ifndef HG_FI_SITES
#error "HG_FI_SITES (the saboteur netlist's number of flip-flop sites) must be defined"
#endif

namespace hg_fi {

constexpr uint64_t kNever = ~uint64_t(0);

class Injector {
public:
    // From the run configuration: its one injection, if any (0: none; -1 and a message: refused).
    int start(const hg_dev::RunCfg& cfg, int64_t scene0_us, uint64_t d, uint64_t clk_hz,
              uint64_t frame_clocks, std::string& err) {
        int n = 0;
        for (const auto& f : cfg.faults) {
            if (!hg_dev::is_injection(f.kind)) continue;
            if (++n > 1) {
                err = "fault: one seu or stuck fault per run";
                return -1;
            }
            if (f.site >= HG_FI_SITES) {
                err = "fault: site " + std::to_string(f.site) + " of " + std::to_string(HG_FI_SITES);
                return -1;
            }
            const int64_t e = scene0_us * static_cast<int64_t>(d) +
                              std::llround(f.at_s * static_cast<double>(clk_hz));
            if (e < 1) {
                err = "fault: injection before the release";
                return -1;
            }
            site_ = f.site;
            on_ = static_cast<uint64_t>(e);
            if (f.kind == hg_dev::FaultKind::seu) {
                mode_ = kFlip;
                off_ = on_;
            } else {
                mode_ = f.value ? kSet : kClr;
                off_ = on_ + static_cast<uint64_t>(f.frames) * frame_clocks - 1;
            }
        }
        return n;
    }
    uint64_t on_edge() const { return applied_ ? kNever : on_; }
    uint64_t off_edge() const { return released_ ? kNever : off_; }

    // Edge `edge` is about to be evaluated: the injection starts with it (true: the ports changed).
    template <class Top>
    bool before(Top& top, uint64_t edge) {
        if (edge != on_edge()) return false;
        set(top, true);
        applied_ = true;
        return true;
    }
    // Edge `edge` was evaluated: the injection ends with it (true: the ports changed, the
    // caller evaluates the input logic again before reading any output).
    template <class Top>
    bool after(Top& top, uint64_t edge) {
        if (edge != off_edge() || !applied_) return false;
        set(top, false);
        released_ = true;
        return true;
    }
    // The summary line (runner.simulate reads key=value pairs).
    void summary(FILE* out) const {
        std::fprintf(out, "fi_sites=%d fi_site=%d fi_mode=%d fi_on_edge=%lld fi_off_edge=%lld fi_done=%d\n",
                     HG_FI_SITES, site_, mode_, static_cast<long long>(site_ < 0 ? -1 : static_cast<int64_t>(on_)),
                     static_cast<long long>(site_ < 0 ? -1 : static_cast<int64_t>(off_)),
                     static_cast<int>(released_));
    }

private:
    enum Mode { kNone = -1, kFlip = 0, kClr = 1, kSet = 2 };
    template <class Top>
    void set(Top& top, bool on) {
        const uint32_t bit = 1u << (site_ % 32);
        auto& port = mode_ == kFlip ? top.fi_flip : mode_ == kClr ? top.fi_clr : top.fi_set;
        if (on) port[site_ / 32] |= bit;
        else port[site_ / 32] &= ~bit;
    }
    int site_ = -1;
    int mode_ = kNone;
    uint64_t on_ = kNever, off_ = kNever;
    bool applied_ = false, released_ = false;
};

}  // namespace hg_fi
