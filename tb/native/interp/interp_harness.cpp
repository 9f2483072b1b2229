// SPDX-License-Identifier: Apache-2.0
// Native long-run harness for rtl/interp/enc_interp3.v: streams ADC samples from a binary file
// through the Verilated RTL and writes the per-sample outputs. The path for 10^7..10^9 samples
// (cocotb pays ~15 us of Python per clock). Driven by models/hapgate/runners/native.py.
//
// usage: interp_harness IN OUT N_SAMPLES COLMASK [CAL_MU [HARM_TABLE [SCHEDULE]]]
//   IN : N_SAMPLES records of AXES x {int8 a, int8 b, uint8 flags}; flags bit0 index,
//        bit1 fault clear, bit2 home arm (pulses applied with that sample), bit3 calibration
//        enable, bit4 calibration freeze (levels captured with that sample; CAL = 1 builds),
//        bit5 harmonic enable, bit6 (axis 0's record) a reset of two clocks before the sample:
//        the samples in flight are lost, their output records all ones.
//   OUT: N_SAMPLES records of AXES x the selected columns, in this order and size:
//        pos i32, pos_homed i32, vel i32, index_pos i32, index_count u16, homed u8,
//        faults u8, overspeed_count u16, cal_ofs_a i16, cal_ofs_b i16, cal_gain_a u16,
//        cal_gain_b u16, cal_phase i16, cal_gear u8, cal_updates u16, vel_obs i32
//        (COLMASK bit k: column k).
//   CAL_MU: the calibration adaptation shift of every axis (default 6) in bits 3:0; with bit 13
//        set, bits 12:8 are the velocity observer's settings of every axis, bw | type3 << 4
//        (VEL_OBS = 1 builds; default bw 6, type III; vel_obs reads 0 otherwise).
//        AXES such words separated by commas: one per axis (axis 0 first).
//   HARM_TABLE: AXES x 256 signed bytes written through the table port ("-": none).
//   SCHEDULE: per-axis settings changed during the run: records of uint32 sample k, then AXES x
//        uint16 (mu | bw << 8 | type3 << 12), driven with sample k (k ascending).
// Prints "samples=N clocks=C seconds=S" on stdout.
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <utility>
#include <vector>

#include "Venc_interp3.h"
#include "testb.h"

#ifndef AXES
#error "AXES must be defined (-DAXES=n) to match the RTL parameter"
#endif

namespace {

// A field of a packed Verilated port, whatever C type Verilator chose for its width.
inline uint64_t field(uint64_t v, int lo, int width) {
    return (v >> lo) & ((width == 64) ? ~0ULL : ((1ULL << width) - 1));
}
template <std::size_t N>
inline uint64_t field(const VlWide<N>& v, int lo, int width) {
    if (width < 32 && (lo % 32) + width <= 32)  // within one word: the common case
        return (v[lo / 32] >> (lo % 32)) & ((1U << width) - 1U);
    if (width == 32 && lo % 32 == 0) return v[lo / 32];
    uint64_t out = 0;
    for (int b = 0; b < width; ++b) {
        const int bit = lo + b;
        out |= static_cast<uint64_t>((v[bit / 32] >> (bit % 32)) & 1U) << b;
    }
    return out;
}

struct Column {
    int bytes;
};
constexpr int kNCol = 16;
constexpr Column kColumns[kNCol] = {{4}, {4}, {4}, {4}, {2}, {1}, {1}, {2},
                                   {2}, {2}, {2}, {2}, {2}, {1}, {2}, {4}};

template <typename T>
void put(std::vector<uint8_t>& buf, T value, int bytes) {
    for (int i = 0; i < bytes; ++i) buf.push_back(static_cast<uint8_t>(value >> (8 * i)));
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 5 || argc > 8) {
        std::fprintf(stderr, "usage: %s IN OUT N_SAMPLES COLMASK [CAL_MU [HARM_TABLE [SCHEDULE]]]\n"
                     "  (N_SAMPLES 0: until the end of IN, e.g. a pipe)\n", argv[0]);
        return 2;
    }
    // N_SAMPLES 0: read IN (a pipe: the replay streams through it) until its end
    uint64_t n = std::strtoull(argv[3], nullptr, 10);
    const bool to_end = n == 0;
    if (to_end) n = UINT64_MAX;
    const unsigned mask = static_cast<unsigned>(std::strtoul(argv[4], nullptr, 0));
    FILE* in = std::fopen(argv[1], "rb");
    FILE* out = std::fopen(argv[2], "wb");
    if (!in || !out) {
        std::fprintf(stderr, "error: cannot open %s or %s\n", argv[1], argv[2]);
        return 2;
    }

    hg_tb::TestB<Venc_interp3> tb;
    Venc_interp3* const top = tb.top.get();

    const size_t rec_in = 3 * AXES;
    const size_t chunk = 1 << 16;  // samples per read
    std::vector<uint8_t> ibuf(chunk * rec_in);
    std::vector<uint8_t> obuf;
    obuf.reserve(chunk * AXES * 22);
    size_t ibuf_len = 0, ibuf_pos = 0;

    top->adc_a = top->adc_b = 0;
    top->enc_index = top->ctl_fault_clear = top->ctl_home_arm = 0;
    top->ctl_cal_en = top->ctl_cal_freeze = 0;
    top->ctl_harm_en = top->cfg_harm_we = 0;
    top->cfg_harm_addr = top->cfg_harm_data = 0;
    {
        // one word for every axis, or AXES words separated by commas
        const char* p = (argc >= 6) ? argv[5] : "6";
        uint32_t mus = 0, bws = 0, t3s = 0;
        unsigned mv = 6U;
        for (int ax = 0; ax < AXES; ++ax) {
            if (ax == 0 || *p == ',') {
                char* end = nullptr;
                mv = static_cast<unsigned>(std::strtoul(*p == ',' ? p + 1 : p, &end, 0));
                p = end;
            }
            const unsigned oc = ((mv >> 13) & 1U) ? ((mv >> 8) & 31U) : 0x16U;
            mus |= (mv & 15U) << (4 * ax);
            bws |= (oc & 15U) << (4 * ax);
            t3s |= ((oc >> 4) & 1U) << ax;
        }
        if (*p != '\0') {
            std::fprintf(stderr, "error: CAL_MU %s: 1 or %d comma-separated words\n", argv[5],
                         AXES);
            return 2;
        }
        top->cfg_cal_mu = mus;
        top->cfg_obs_bw = bws;
        top->cfg_obs_type3 = t3s;
    }
    // the settings schedule (SCHEDULE): (sample, AXES x uint16) records
    std::vector<std::pair<uint64_t, std::array<uint16_t, AXES>>> sched;
    if (argc == 8) {
        FILE* fs = std::fopen(argv[7], "rb");
        if (!fs) {
            std::fprintf(stderr, "error: cannot open %s\n", argv[7]);
            return 2;
        }
        uint32_t k = 0;
        std::array<uint16_t, AXES> w{};
        while (std::fread(&k, 4, 1, fs) == 1) {
            if (std::fread(w.data(), 2, AXES, fs) != AXES) {
                std::fprintf(stderr, "error: %s: a partial record\n", argv[7]);
                return 2;
            }
            sched.emplace_back(k, w);
        }
        std::fclose(fs);
    }
    size_t sched_pos = 0;
    top->eval();
    tb.hold_reset(4);
    // harmonic table (HARM = 1 builds): AXES x 256 signed bytes, written through the table
    // port, then every entry read back (two clocks each), all while in reset (no sample in flight)
    unsigned harm_bad = 0;
    if (argc >= 7 && std::strcmp(argv[6], "-") != 0) {
        std::vector<uint8_t> tab(256 * AXES);
        FILE* ft = std::fopen(argv[6], "rb");
        if (!ft || std::fread(tab.data(), 1, tab.size(), ft) != tab.size()) {
            std::fprintf(stderr, "error: cannot read %zu bytes of %s\n", tab.size(), argv[6]);
            return 2;
        }
        std::fclose(ft);
        for (int ax = 0; ax < AXES; ++ax) {
            for (unsigned e = 0; e < 256; ++e) {
                top->cfg_harm_we = 1U << ax;
                top->cfg_harm_addr = e;
                top->cfg_harm_data = tab[256 * ax + e];
                tb.cycle();
            }
        }
        top->cfg_harm_we = 0;
        for (unsigned e = 0; e < 256; ++e) {
            top->cfg_harm_addr = e;
            tb.cycle();
            tb.cycle();
            for (int ax = 0; ax < AXES; ++ax)
                if (field(top->m_harm_rdata, 8 * ax, 8) != tab[256 * ax + e]) ++harm_bad;
        }
    }

    tb.release();

    // the calibration state of sample k comes m_cal_valid cycles before its m_valid result
    std::deque<std::array<uint64_t, 7 * AXES>> cal_q;
    uint64_t fed = 0, got = 0, clocks = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (got < n) {
        // clk low: present the next sample in the cycle the FPGA strobes the ADC
        if (top->adc_strobe && fed < n && ibuf_pos == ibuf_len) {
            const size_t want = static_cast<size_t>(std::min<uint64_t>(chunk, n - fed));
            const size_t r = std::fread(ibuf.data(), rec_in, want, in);
            if (r == 0 && to_end) {
                n = fed;  // the end of the stream: drain the pipeline
            } else if (r == 0) {
                std::fprintf(stderr, "error: input ended after %llu samples\n",
                             static_cast<unsigned long long>(fed));
                return 3;
            }
            ibuf_len = r * rec_in;
            ibuf_pos = 0;
        }
        if (top->adc_strobe && fed < n && (ibuf[ibuf_pos + 2] & 64U)) {
            // a reset before this sample: the samples in flight are lost (their output records
            // are all ones), then the sample is presented as the first after the reset
            ibuf[ibuf_pos + 2] &= static_cast<uint8_t>(~64U);
            top->ctl_fault_clear = 0;
            top->ctl_home_arm = 0;
            top->rst = 1;
            for (int i = 0; i < 2; ++i) {
                top->clk = 1; top->eval();
                top->clk = 0; top->eval();
                clocks += 1;
            }
            top->rst = 0;
            top->eval();
            cal_q.clear();
            for (; got < fed; ++got)
                for (int ax = 0; ax < AXES; ++ax)
                    for (int c = 0; c < kNCol; ++c)
                        if (mask & (1U << c)) put(obuf, ~0ULL, kColumns[c].bytes);
            continue;
        }
        if (top->adc_strobe && fed < n) {
            uint32_t a = 0, b = 0, idx = 0, clr = 0, arm = 0, cen = 0, cfr = 0, hen = 0;
            for (int ax = 0; ax < AXES; ++ax) {
                const uint8_t* r = &ibuf[ibuf_pos + 3 * ax];
                a |= static_cast<uint32_t>(r[0]) << (8 * ax);
                b |= static_cast<uint32_t>(r[1]) << (8 * ax);
                idx |= static_cast<uint32_t>(r[2] & 1U) << ax;
                clr |= static_cast<uint32_t>((r[2] >> 1) & 1U) << ax;
                arm |= static_cast<uint32_t>((r[2] >> 2) & 1U) << ax;
                cen |= static_cast<uint32_t>((r[2] >> 3) & 1U) << ax;
                cfr |= static_cast<uint32_t>((r[2] >> 4) & 1U) << ax;
                hen |= static_cast<uint32_t>((r[2] >> 5) & 1U) << ax;
            }
            ibuf_pos += rec_in;
            if (sched_pos < sched.size() && sched[sched_pos].first == fed) {
                uint32_t mus = 0, bws = 0, t3s = 0;
                for (int ax = 0; ax < AXES; ++ax) {
                    const unsigned w = sched[sched_pos].second[ax];
                    mus |= (w & 15U) << (4 * ax);
                    bws |= ((w >> 8) & 15U) << (4 * ax);
                    t3s |= ((w >> 12) & 1U) << ax;
                }
                top->cfg_cal_mu = mus;
                top->cfg_obs_bw = bws;
                top->cfg_obs_type3 = t3s;
                ++sched_pos;
            }
            top->adc_a = a;
            top->adc_b = b;
            top->enc_index = idx;
            top->ctl_fault_clear = clr;
            top->ctl_home_arm = arm;
            top->ctl_cal_en = cen;
            top->ctl_cal_freeze = cfr;
            top->ctl_harm_en = hen;
            ++fed;
        } else {
            top->ctl_fault_clear = 0;
            top->ctl_home_arm = 0;
        }
        tb.rise();
        ++clocks;
        if (top->m_cal_valid) {
            std::array<uint64_t, 7 * AXES> c{};
            for (int ax = 0; ax < AXES; ++ax) {
                c[7 * ax + 0] = field(top->m_cal_ofs_a, 16 * ax, 16);
                c[7 * ax + 1] = field(top->m_cal_ofs_b, 16 * ax, 16);
                c[7 * ax + 2] = field(top->m_cal_gain_a, 16 * ax, 16);
                c[7 * ax + 3] = field(top->m_cal_gain_b, 16 * ax, 16);
                c[7 * ax + 4] = field(top->m_cal_phase, 16 * ax, 16);
                c[7 * ax + 5] = field(top->m_cal_gear, 8 * ax, 8);
                c[7 * ax + 6] = field(top->m_cal_updates, 16 * ax, 16);
            }
            cal_q.push_back(c);
        }
        if (top->m_valid) {
            if (cal_q.empty()) {
                std::fprintf(stderr, "error: a result without its calibration state\n");
                return 3;
            }
            const auto cs = cal_q.front();
            cal_q.pop_front();
            for (int ax = 0; ax < AXES; ++ax) {
                const uint64_t v[kNCol] = {
                    field(top->m_pos, 32 * ax, 32),         field(top->m_pos_homed, 32 * ax, 32),
                    field(top->m_vel, 32 * ax, 32),         field(top->m_index_pos, 32 * ax, 32),
                    field(top->m_index_count, 16 * ax, 16), field(top->m_homed, ax, 1),
                    field(top->m_faults, 3 * ax, 3),        field(top->m_overspeed_count, 16 * ax, 16),
                    cs[7 * ax + 0], cs[7 * ax + 1], cs[7 * ax + 2], cs[7 * ax + 3],
                    cs[7 * ax + 4], cs[7 * ax + 5], cs[7 * ax + 6],
                    field(top->m_vel_obs, 32 * ax, 32)};
                for (int c = 0; c < kNCol; ++c)
                    if (mask & (1U << c)) put(obuf, v[c], kColumns[c].bytes);
            }
            ++got;
            if (obuf.size() >= chunk * 16) {
                std::fwrite(obuf.data(), 1, obuf.size(), out);
                obuf.clear();
            }
        }
        tb.fall();
    }
    std::fwrite(obuf.data(), 1, obuf.size(), out);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fclose(in);
    if (std::fclose(out) != 0) {
        std::fprintf(stderr, "error: writing %s failed\n", argv[2]);
        return 3;
    }
    std::printf("samples=%llu clocks=%llu seconds=%.6f harm_readback_bad=%u\n",
                static_cast<unsigned long long>(got), static_cast<unsigned long long>(clocks),
                secs, harm_bad);
    return 0;
}
