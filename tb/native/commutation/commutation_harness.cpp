// SPDX-License-Identifier: Apache-2.0
// Native replay harness for rtl/commutation/commutator.v (+ rtl/dac_sched/dac_sched.v, built with
// HG_SIM_SKIP and its hook dac_sched_skip.v): streams per-frame inputs from a binary file through the Verilated RTL, clock by clock
// at the CLK_HZ it was built for, records every DAC load (rising dac_wr_n) and checks the DAC
// port's timing in clocks. Driven by models/hapgate/runners/native_comm.py (run_commutation).
//
// usage: commutation_harness IN OUT N_FRAMES [skip|noskip|force]
//   IN : N_FRAMES records of 32 bytes: u32 pos[3] (low COUNT_BITS used), i16 torque[3],
//        u16 offset[3], u8 mode (2 bits per motor), u8 enable, u8 fault (1 bit per motor),
//        u8 pad, u16 limit, u16 pad.  Row i is on the inputs from the start of frame i (row 0
//        from before reset) and latched at the start of frame i+1; frame 0 starts at the last
//        clock edge with rst high and writes zero torque.
//   OUT: N_FRAMES + 1 records of 6 x u16 DAC word (the pins' coding) and 6 x u32 load clock
//        (clock edges from that frame's start to the channel's rising dac_wr_n). Record j is
//        frame j (record 0: the reset frame).
//   skip (default): idle clocks are skipped through dac_sched's HG_SIM_SKIP hook: where the hook
//        reports sim_room = R > 0 (every request answered, strobe high, no request or frame start
//        before R more clocks), one edge advances R + 1 clocks. noskip: every clock is an edge.
//        Both give the same words and load clocks (tb/commutation/test_commutator_native.py).
//        force (tests only): also skip one clock at each load edge, which the checks must catch.
// Port checks (each failure counts one violation, the first few are printed on stderr), in
// clocks, skipped clocks included:
//   a frame has exactly six loads, channel k the k-th; data/address never change while
//   dac_wr_n is low nor on the edge it rises (hold >= 1 clock); dac_wr_n never falls on the edge
//   the data change (setup >= 1 clock); the strobe is low exactly WR_CYCLES clocks; no channel is
//   reloaded sooner than SETTLE_CLOCKS; a load falls inside its own frame; a skip edge starts
//   with the strobe high and no frame start and changes nothing on the DAC port.
// Prints "frames=N clocks=C violations=V seconds=S cpu_seconds=U edges=E skips=K" on stdout
// (S wall and U CPU seconds of the clock loop; E evaluated edges, K of them skip edges).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <vector>

#include "Vcommutator.h"
#include "Vcommutator___024root.h"
#include "testb.h"
#include "verilated.h"
#include "../vl_internals.h"

// Vcommutator::eval() wraps the scheduler in per-call bookkeeping for threads and deferred
// deletes (two mutex operations per call: half the run time of this small model). After the
// first eval() has initialised the model, the clock loop calls the root scheduler directly;
// the design has no $display/$finish or DPI, so the bookkeeping has nothing to do. That function
// and the clock's edge detector are generated internals, used only through
// tb/native/vl_internals.h (which fails the build on any other Verilator than the pinned one);
// the hook's sim_skip / sim_room are `verilator public` signals. A test compares this harness
// with the model bit for bit.
HG_VL_DECLARE_EVAL(Vcommutator);

#if !defined(COUNT_BITS) || !defined(ANGLE_BITS) || !defined(FRAME_CLOCKS) || \
    !defined(WR_CYCLES) || !defined(SETTLE_CLOCKS)
#error "COUNT_BITS, ANGLE_BITS, FRAME_CLOCKS, WR_CYCLES and SETTLE_CLOCKS must be defined"
#endif

namespace {

constexpr int kChannels = 6;
constexpr size_t kRecIn = 32;
constexpr size_t kRecOut = kChannels * 2 + kChannels * 4;

struct Checker {
    uint64_t violations = 0;
    void fail(uint64_t clk, const char* what, long long a = 0, long long b = 0) {
        if (violations < 5)
            std::fprintf(stderr, "violation at clock %llu: %s (%lld, %lld)\n",
                         static_cast<unsigned long long>(clk), what, a, b);
        ++violations;
    }
};

double cpu_seconds() {  // this process's CPU time (the machine is shared: wall time is noisy)
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

inline uint32_t rd32(const uint8_t* p) {
    return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
inline uint16_t rd16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

void present(Vcommutator* top, const uint8_t* r) {
    const uint64_t cmask = (1ULL << COUNT_BITS) - 1;
    uint64_t pos = 0, tq = 0;
    uint32_t off = 0;
    for (int m = 0; m < 3; ++m) {
        pos |= (rd32(r + 4 * m) & cmask) << (COUNT_BITS * m);
        tq |= static_cast<uint64_t>(rd16(r + 12 + 2 * m)) << (16 * m);
        off |= (rd16(r + 18 + 2 * m) & ((1U << ANGLE_BITS) - 1)) << (ANGLE_BITS * m);
    }
    top->s_pos = pos;
    top->s_torque = tq;
    top->ctl_offset = off;
    top->ctl_mode = r[24] & 0x3F;
    top->ctl_enable = r[25] & 1;
    top->axis_fault = r[26] & 7;
    top->ctl_torque_limit = rd16(r + 28);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4 && argc != 5) {
        std::fprintf(stderr, "usage: %s IN OUT N_FRAMES [skip|noskip]\n", argv[0]);
        return 2;
    }
    // 0 noskip, 1 skip, 2 force (tests only: also skip one clock at every edge where the strobe
    // is low, i.e. over the DAC load, to show that the checks below catch a skip over activity)
    const char* mode_arg = argc == 5 ? argv[4] : "skip";
    const int mode = std::strcmp(mode_arg, "noskip") == 0 ? 0
                   : std::strcmp(mode_arg, "skip") == 0  ? 1
                   : std::strcmp(mode_arg, "force") == 0 ? 2 : -1;
    if (mode < 0) {
        std::fprintf(stderr, "error: the 4th argument is skip, noskip or force, not %s\n",
                     mode_arg);
        return 2;
    }
    // N_FRAMES 0: every frame of IN until its end (a pipe: the replay streams through it)
    const uint64_t limit = std::strtoull(argv[3], nullptr, 10);
    FILE* in = std::fopen(argv[1], "rb");
    FILE* out = std::fopen(argv[2], "wb");
    if (!in || !out) {
        std::fprintf(stderr, "error: cannot open %s or %s\n", argv[1], argv[2]);
        return 2;
    }
    // the rows, read a block at a time (memory bounded by the block, not by the file)
    const size_t block = 1 << 14;
    std::vector<uint8_t> ibuf(block * kRecIn);
    size_t ibuf_len = 0, ibuf_pos = 0;
    uint64_t read_rows = 0;
    auto next_row = [&]() -> const uint8_t* {
        if (limit && read_rows == limit) return nullptr;
        if (ibuf_pos == ibuf_len) {
            const size_t want = limit ? static_cast<size_t>(std::min<uint64_t>(block, limit - read_rows))
                                      : block;
            const size_t r = std::fread(ibuf.data(), kRecIn, want, in);
            if (r == 0) return nullptr;
            ibuf_len = r * kRecIn;
            ibuf_pos = 0;
        }
        const uint8_t* row = &ibuf[ibuf_pos];
        ibuf_pos += kRecIn;
        ++read_rows;
        return row;
    };
    const uint8_t* row0 = next_row();
    if (!row0) {
        std::fprintf(stderr, "error: %s holds no frames\n", argv[1]);
        return 2;
    }

    hg_tb::TestB<Vcommutator> tb;
    Vcommutator* const top = tb.top.get();
    Checker chk;

    uint64_t frames = UINT64_MAX;  // the reset frame, then one per row: known at the input's end
    std::vector<uint8_t> obuf;
    const size_t chunk = 1 << 14;   // frames per write
    obuf.reserve(chunk * kRecOut);

    present(top, row0);
    top->eval();
    tb.reset(4);   // the 4th edge is the last with rst high: frame 0 starts

    uint64_t clk = 0;              // edges since frame 0's start
    uint64_t frame = 0;            // current frame number
    uint64_t frame_start = 0;      // its start edge
    uint64_t presented = 1;        // rows presented so far (row 0 before reset)
    int loads = 0;                 // loads seen in the current frame
    uint16_t words[kChannels] = {0};
    uint32_t at[kChannels] = {0};
    uint64_t last_change = 0, last_fall = 0;
    bool any_change = false;
    uint64_t last_load[kChannels];
    bool loaded[kChannels] = {false};
    for (auto& v : last_load) v = 0;

    auto flush_frame = [&]() {
        if (loads != kChannels) chk.fail(clk, "loads in a frame", static_cast<long long>(frame), loads);
        for (int k = 0; k < kChannels; ++k) {
            obuf.push_back(static_cast<uint8_t>(words[k]));
            obuf.push_back(static_cast<uint8_t>(words[k] >> 8));
        }
        for (int k = 0; k < kChannels; ++k)
            for (int b = 0; b < 4; ++b) obuf.push_back(static_cast<uint8_t>(at[k] >> (8 * b)));
        if (obuf.size() >= chunk * kRecOut) {
            std::fwrite(obuf.data(), 1, obuf.size(), out);
            obuf.clear();
        }
        loads = 0;
        std::memset(words, 0, sizeof words);
        std::memset(at, 0, sizeof at);
    };

    Vcommutator___024root* const root = top->rootp;
    // The hook's members (dac_sched_skip.v, HG_SIM_SKIP): the edge's extra clocks and the room for them.
    auto& sim_skip = root->commutator__DOT__u_sched__DOT__u_skip__DOT__sim_skip;
    const auto& sim_room = root->commutator__DOT__u_sched__DOT__u_skip__DOT__sim_room;
    uint64_t edges = 0, skips = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    // Run until the last frame's six loads are in: at most FRAME_CLOCKS edges after its start.
    for (;;) {
        // clk low: inputs for the next latch are on the pins while m_frame is high
        const bool frame_edge = top->m_frame;
        const uint32_t d0 = top->dac_data, a0 = top->dac_addr;
        const uint8_t w0 = top->dac_wr_n;
        const uint32_t room = static_cast<uint32_t>(sim_room);
        const uint32_t skip = mode == 0 ? 0U : (mode == 2 && !w0 ? 1U : room);
        if (skip) {
            // Quiet by the hook's definition (sim_room > 0); what the harness sees must agree:
            if (skip > room) chk.fail(clk, "skip beyond the hook's room", skip, room);
            if (!w0 || frame_edge) chk.fail(clk, "skip with the strobe low or at a frame start");
            sim_skip = static_cast<decltype(+sim_skip)>(skip);
        }
        top->clk = 1;
        Vcommutator___024root___eval(root);
        ++edges;
        clk += 1 + skip;
        if (skip) {
            sim_skip = 0;
            ++skips;
            if (top->dac_data != d0 || top->dac_addr != a0 || top->dac_wr_n != w0)
                chk.fail(clk, "the DAC port changed on a skip edge");
        }
        if (frame_edge) {
            if (frame + 1 == frames) break;  // every frame done (its loads are in)
            flush_frame();
            ++frame;
            frame_start = clk;
        }
        const uint32_t d1 = top->dac_data, a1 = top->dac_addr;
        const uint8_t w1 = top->dac_wr_n;
        if (d1 != d0 || a1 != a0) {
            if (!w0 || !w1) chk.fail(clk, "data/address changed while dac_wr_n is low");
            last_change = clk;
            any_change = true;
        }
        if (w0 && !w1) {  // strobe falls
            if (any_change && clk - last_change < 1) chk.fail(clk, "setup < 1 clock");
            last_fall = clk;
        }
        if (!w0 && w1) {  // strobe rises: the DAC loads
            if (clk - last_fall != WR_CYCLES)
                chk.fail(clk, "strobe low clocks", static_cast<long long>(clk - last_fall), WR_CYCLES);
            if (any_change && last_change == clk) chk.fail(clk, "hold: data changed on the load edge");
            const int ch = static_cast<int>(a1);
            if (loaded[ch] && clk - last_load[ch] < SETTLE_CLOCKS)
                chk.fail(clk, "channel reloaded within settling", ch,
                         static_cast<long long>(clk - last_load[ch]));
            loaded[ch] = true;
            last_load[ch] = clk;
            if (loads >= kChannels || ch != loads) {
                chk.fail(clk, "channel order", loads, ch);
            } else {
                words[loads] = static_cast<uint16_t>(d1);
                at[loads] = static_cast<uint32_t>(clk - frame_start);
            }
            ++loads;
        }
        if (frame_edge && frames == UINT64_MAX) {  // row `presented` is latched at the next frame start
            if (const uint8_t* row = next_row()) {
                present(top, row);
                ++presented;
            } else {
                frames = presented + 1;
                std::fclose(in);
                if (limit && presented < limit) {
                    std::fprintf(stderr, "error: %s holds fewer than %llu frames\n", argv[1],
                                 static_cast<unsigned long long>(limit));
                    return 3;
                }
            }
        }
        // Falling edge: nothing in the design works on it and the inputs set above are read by
        // the next rising-edge evaluation, so instead of evaluating it, record it in the model's
        // edge detector as that evaluation would (the device harness does the same).
        top->clk = 0;
        hg_vl::clk_fell(root);
    }
    flush_frame();
    std::fwrite(obuf.data(), 1, obuf.size(), out);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double cpu = cpu_seconds() - c0;
    if (std::fclose(out) != 0) {
        std::fprintf(stderr, "error: writing %s failed\n", argv[2]);
        return 3;
    }
    std::printf("frames=%llu clocks=%llu violations=%llu seconds=%.6f cpu_seconds=%.6f "
                "edges=%llu skips=%llu\n",
                static_cast<unsigned long long>(frames), static_cast<unsigned long long>(clk),
                static_cast<unsigned long long>(chk.violations), secs, cpu,
                static_cast<unsigned long long>(edges), static_cast<unsigned long long>(skips));
    return 0;
}
