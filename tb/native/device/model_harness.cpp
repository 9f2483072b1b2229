// SPDX-License-Identifier: Apache-2.0
// The virtual device at model fidelity: the FPGA replaced by a transaction-level port of its
// golden models (hapgate.golden.regmodel, interp, commutation, dacsched, top), the unchanged
// firmware on the same grid-aligned bus timing as device_harness.cpp, and the multirate plant.
// Nothing runs per clock: the register file, the servo tick, the watchdog, the frame latches and
// the DAC loads are events on the clock-edge axis of the RTL, the interpolator is evaluated only
// at the samples whose results someone reads (a snapshot, a frame latch, a velocity window).
// Simplifications and where they can differ from the RTL: README.md "Model fidelity".
//
// usage: model_harness PLANT_CFG RUN_CFG OUTDIR
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "bus_hal.h"
#include "dac_word.h"
#include "harness_common.h"
#include "plant.h"

extern "C" {
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "hg_servo.h"
}

namespace {

using namespace hg_dev;

constexpr int64_t kNever = int64_t(1) << 62;
constexpr int kRing = 8192;                 // grid points of true angles kept (>= 2 velocity windows)
constexpr int kLatency = 5;                 // interpolator: capture to output registers (golden.top)
int64_t load_clocks = 0;                    // frame start -> channel 0 load edge (run config dac_load)
int64_t wr_cycles = 0;                      // the DAC write strobe's length in clocks (t_WCS)

RunCfg cfg;
hg_plant* plant = nullptr;
int64_t D = 6;                              // clocks per grid point (1 us)
uint64_t noise_seed = 1;

// ------------------------------------------------------------------ noise per sample index
inline uint64_t mix(uint64_t z) {
    z += 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}
inline double unif(uint64_t z) { return (static_cast<double>(mix(z) >> 11) + 1.0) * (1.0 / 9007199254740992.0); }
void normals(uint64_t seed, int axis, int64_t n, double* za, double* zb) {
    const uint64_t k = mix(seed * 4 + static_cast<uint64_t>(axis)) ^ static_cast<uint64_t>(n) * 0xD1B54A32D192ED03ULL;
    const double r1 = std::sqrt(-2.0 * std::log(unif(k))), t1 = 2 * kPi * unif(k + 1);
    const double r2 = std::sqrt(-2.0 * std::log(unif(k + 2))), t2 = 2 * kPi * unif(k + 3);
    *za = r1 * std::cos(t1);
    *zb = r2 * std::cos(t2);
}

// ------------------------------------------------------------------ the plant on the grid
struct Grid {
    int64_t done = -1;                      // last grid point processed
    std::vector<double> q = std::vector<double>(kRing * 3, 0.0);  // true q at each grid point
    bool dynamic = false;
    int64_t scene0 = 0;
    int64_t mech_next = 0;                  // grid point of the next mechanics step
    struct Pend { int64_t at; int ch; int code; };
    static constexpr int64_t kPend = 1024;  // DAC words on their way (ring), in arrival order
    Pend pend[kPend];
    int64_t pend_head = 0, pend_tail = 0;
    int64_t amp_g = 0;                      // the amplifier's currents are those of this grid point
    RecordFile<FrameRec> frames;            // written as the run goes (harness_common.h)
    RecordFile<int8_t> adc;
    int steps_per_us = 1;
    // the multirate plant's steps: q between two step boundaries is linear (semi-implicit Euler
    // moves q by dt * qd_new); step m covers the grid points (g0, g0 + k], m = (g - 1) / 16
    struct Step { int64_t g0; double q0[3], dq[3]; };
    std::vector<Step> steps = std::vector<Step>(1024);
    int64_t lazy_from = kNever;             // grid points after this one come from `steps`
    double qat(int64_t g, int i) const {
        if (g <= lazy_from) return q[static_cast<size_t>(g & (kRing - 1)) * 3 + static_cast<size_t>(i)];
        const Step& st = steps[static_cast<size_t>(((g - 1) >> 4) & 1023)];
        return st.q0[i] + st.dq[i] * static_cast<double>(g - st.g0);
    }
};
Grid G;

// ------------------------------------------------------------------ one interpolator axis
struct Axis {
    bool built = false;
    int lut_bits = 7, fb = 8;
    // sequential (exact) state, samples 0 .. n_exact
    int64_t n_exact = -1;
    int sa = 0, sb = 0, q_prev = 0, last_dir = 1;
    int32_t qc = 0;
    bool idx_prev = true, armed = false, homed = false, ever_homed = false;
    int32_t home = 0, index_pos = 0;
    uint32_t index_count = 0, ovs_count = 0;
    int bad_run = 0;
    int faults = 0;
    std::vector<int32_t> pos_ring = std::vector<int32_t>(kRing, 0);
    std::vector<uint8_t> fine_due = std::vector<uint8_t>(kRing, 0);   // pos_ring lacks the fine angle
    struct Hist { int32_t index_pos; uint16_t index_count, ovs; uint8_t faults, homed; };   // (POS: pos_ring)
    std::vector<Hist> hist = std::vector<Hist>(kRing);
    // pulses (sample index they apply to)
    std::vector<int64_t> arm_at, clear_at;
    // event mode (after the release): faults as (sample, bits) events; clears as samples
    std::vector<std::pair<int64_t, int>> fault_ev;
    int64_t dropout_from = kNever;          // first sample with A = B = 0
    bool simple = false;                    // no fault event, no clear after n_exact (fault_bits)
    void update_simple() { simple = built && fault_ev.empty() && (clear_at.empty() || clear_at.back() <= n_exact); }
    int64_t qm_ref = 0;                     // absolute measured quadrant of sample n_exact
    // hold values (an axis that is not built)
    uint32_t hold_pos_homed = 0, hold_index_pos = 0, hold_index_count = 0;
};
Axis AX[3];
std::vector<int64_t> asin_lut;

double lines_of(int i, int64_t n) { return (G.qat(n + 1, i) - cfg.q_index[i]) / (2 * kPi) * 1024.0; }

double noise_lsb[3] = {0, 0, 0};
struct CodeCache { double x = NAN; int a = 0, b = 0; };
CodeCache code_cache[3];

void codes(int i, int64_t n, int* a, int* b) {    // the ADC words of sample n (grid n + 1)
    if (n >= AX[i].dropout_from) { *a = *b = 0; return; }
    const double x = lines_of(i, n);
    CodeCache& c = code_cache[i];
    if (noise_lsb[i] > 0) {
        double za, zb;
        normals(noise_seed, i, n, &za, &zb);
        int8_t a8, b8;
        hg_plant_encode1(plant, i, x, za, zb, &a8, &b8);
        *a = a8;
        *b = b8;
        return;
    }
    if (x != c.x) {                               // (noise-free: the same angle, the same words)
        int8_t a8, b8;
        hg_plant_encode1(plant, i, x, 0.0, 0.0, &a8, &b8);
        c = {x, a8, b8};
    }
    *a = c.a;
    *b = c.b;
}

int fine(const Axis& x, int a, int b, int sa, int sb) {
    if (cfg.coarse) return 0;
    const int odd = sa ^ sb;
    const int ma = std::abs(a), mb = std::abs(b);
    const int y = odd ? mb : ma, xx = odd ? ma : mb;
    const bool half = y >= xx;
    const int m = std::min(half ? xx : y, 128);
    const int t = static_cast<int>(asin_lut[static_cast<size_t>(m)]);
    return half ? (2 << x.lut_bits) - t : t;
}

// The exact sequential interpolator (rtl/interp, hapgate.golden.interp.run) on sample n. With
// sq >= 0 the sample lies in a homing-safe bin (make_safe_table): its words are not evaluated,
// their sign-bit quadrant is sq, they neither clip nor leave the signal window, and the fine
// angle is added to pos_ring when someone reads it (pos_of).
void exact_sample(int i, int64_t n, int a, int b, bool idx, int sq = -1) {
    Axis& x = AX[i];
    for (int64_t c : x.clear_at)
        if (c == n) x.faults = 0;
    if (sq >= 0) {
        x.sa = sq >> 1;
        x.sb = x.sa ^ (sq & 1);
    } else {
        if (a != 0) x.sa = a < 0;
        if (b != 0) x.sb = b < 0;
    }
    const int q = (x.sa << 1) | (x.sa ^ x.sb);
    const int f = sq >= 0 ? 0 : fine(x, a, b, x.sa, x.sb);
    if (n == 0) {
        x.qc = q;
    } else {
        int st = (q - x.q_prev) & 3;
        if (st == 3) st = -1;
        if (st == 2) {
            st = 2 * x.last_dir;
            x.faults |= 1;
            x.ovs_count = std::min<uint32_t>(x.ovs_count + 1, 0xFFFF);
        } else if (st != 0) {
            x.last_dir = st;
        }
        x.qc = static_cast<int32_t>(static_cast<uint32_t>(x.qc) + static_cast<uint32_t>(st));
    }
    x.q_prev = q;
    const int32_t pos = static_cast<int32_t>((static_cast<uint32_t>(x.qc) << x.fb) + static_cast<uint32_t>(f));
    const int32_t line_start = static_cast<int32_t>(static_cast<uint32_t>((x.qc + 2) & ~3) << x.fb);
    for (int64_t c : x.arm_at)
        if (c == n) { x.armed = true; x.homed = false; }
    if (idx && !x.idx_prev) {
        x.index_pos = line_start;
        x.index_count = (x.index_count + 1) & 0xFFFF;
        if (x.armed) { x.home = line_start; x.homed = x.ever_homed = true; x.armed = false; }
    }
    x.idx_prev = idx;
    const bool clip = sq < 0 && (a == -128 || a == 127 || b == -128 || b == 127);
    const int amp2 = a * a + b * b;
    const bool bad = sq < 0 && (amp2 < cfg.amp_min * cfg.amp_min || amp2 > cfg.amp_max * cfg.amp_max);
    x.bad_run = bad ? x.bad_run + 1 : 0;
    if (clip) x.faults |= 2;
    if (x.bad_run >= cfg.loss_samples) x.faults |= 4;
    x.pos_ring[static_cast<size_t>(n & (kRing - 1))] = pos;
    x.fine_due[static_cast<size_t>(n & (kRing - 1))] = sq >= 0;
    x.hist[static_cast<size_t>(n & (kRing - 1))] = {x.index_pos, static_cast<uint16_t>(x.index_count),
                                             static_cast<uint16_t>(x.ovs_count), static_cast<uint8_t>(x.faults),
                                             static_cast<uint8_t>(x.homed)};
    x.n_exact = n;
    x.update_simple();
}

// Sign bits of sample n with the zero code held (look back over zero codes, at most 64 samples).
void signs(int i, int64_t n, int a, int b, int* sa, int* sb) {
    int ra = a, rb = b;
    int64_t k = n;
    for (int look = 0; (ra == 0 || rb == 0) && look < 64; ++look) {
        if (k - 1 <= AX[i].n_exact) break;
        --k;
        if (k >= AX[i].dropout_from) k = AX[i].dropout_from - 1;
        if (k <= AX[i].n_exact) break;
        int ca, cb;
        codes(i, k, &ca, &cb);
        if (ra == 0) ra = ca;
        if (rb == 0) rb = cb;
    }
    *sa = ra != 0 ? ra < 0 : AX[i].sa;      // beyond the look-back: the last exact sample's sign
    *sb = rb != 0 ? rb < 0 : AX[i].sb;
}

// Absolute measured quadrant of sample n: the sign-bit quadrant q, placed at the multiple of 4
// nearest the true angle (4 * lines): exact while the decoder never steps two quadrants.
// std::llround (half away from zero) inline: v - trunc(v) is exact (Sterbenz), |v| < 2^53 here.
inline int64_t round_half_away(double v) {
    int64_t t = static_cast<int64_t>(v);
    const double d = v - static_cast<double>(t);
    if (d >= 0.5) ++t;
    else if (d <= -0.5) --t;
    return t;
}

inline int64_t qm_at(double lines, int q) {
    const double x4 = 4.0 * lines;
    return q + 4 * round_half_away((x4 - q - 0.5) / 4.0);
}
int64_t qm_of(int i, int64_t n, int q) { return qm_at(lines_of(i, n), q); }

int fault_bits_slow(int i, int64_t n) {
    const Axis& x = AX[i];
    if (!x.built) return 0;
    if (n <= x.n_exact) return n >= 0 ? x.hist[static_cast<size_t>(n & (kRing - 1))].faults : 0;
    if (x.fault_ev.empty() && (x.clear_at.empty() || x.clear_at.back() <= x.n_exact)) return x.faults;
    int64_t last_clear = -1;
    for (int64_t c : x.clear_at)
        if (c <= n) last_clear = std::max(last_clear, c);
    int bits = last_clear > x.n_exact ? 0 : x.faults;
    for (const auto& e : x.fault_ev)
        if (e.first <= n && e.first >= last_clear) bits |= e.second;
    return bits;
}

// The fault bits of sample n: after the release, with no fault event and no clear pending, the
// exact counter's bits (the common case, one compare); else the event lists.
inline int fault_bits(int i, int64_t n) {
    const Axis& x = AX[i];
    if (x.simple && n > x.n_exact) return x.faults;
    return fault_bits_slow(i, n);
}

int32_t pos_of(int i, int64_t n) {                // POS of sample n
    Axis& x = AX[i];
    if (n <= x.n_exact) {
        const size_t r = static_cast<size_t>(n & (kRing - 1));
        if (x.fine_due[r]) {                      // a homing-safe sample: its words now
            int a, b;
            codes(i, n, &a, &b);
            x.pos_ring[r] = static_cast<int32_t>(static_cast<uint32_t>(x.pos_ring[r]) +
                                                 static_cast<uint32_t>(fine(x, a, b, a < 0, b < 0)));
            x.fine_due[r] = 0;
        }
        return x.pos_ring[r];
    }
    const bool drop = n >= x.dropout_from;        // the counter stands still, the fine angle of 0, 0
    const int64_t m = drop ? x.dropout_from - 1 : n;
    int sa = x.sa, sb = x.sb, a = 0, b = 0;
    int32_t qc = x.qc;                            // (m == n_exact: a dropout from the release on)
    if (m > x.n_exact) {
        codes(i, m, &a, &b);
        if (!drop && (a == 127 || a == -128 || b == 127 || b == -128)) {  // clipping, seen where evaluated
            bool have = false;
            for (const auto& e : x.fault_ev) have = have || (e.first <= n && (e.second & 2));
            if (!have) { x.fault_ev.push_back({n, 2}); x.update_simple(); }
        }
        signs(i, m, a, b, &sa, &sb);
        const int q = (sa << 1) | (sa ^ sb);
        qc = static_cast<int32_t>(static_cast<uint32_t>(x.qc) + static_cast<uint32_t>(qm_of(i, m, q) - x.qm_ref));
    }
    if (drop) a = b = 0;
    const int f = fine(x, a, b, sa, sb);
    return static_cast<int32_t>((static_cast<uint32_t>(qc) << x.fb) + static_cast<uint32_t>(f));
}

struct Sample {                                   // what the register file's inputs carry
    int32_t pos, pos_homed, vel, index_pos;
    uint32_t index_count, ovs;
    int faults, homed;
};

Sample sample_of(int i, int64_t n, bool need_vel = true) {
    const Axis& x = AX[i];
    Sample s{};
    if (!x.built) {
        s.pos_homed = static_cast<int32_t>(x.hold_pos_homed);
        s.pos = static_cast<int32_t>(x.hold_pos_homed + x.hold_index_pos);
        s.index_pos = static_cast<int32_t>(x.hold_index_pos);
        s.index_count = n >= 0 ? x.hold_index_count : 0;
        s.homed = n >= 0 && x.hold_index_count != 0;   // (the held bank's HOMED)
        return s;
    }
    if (n < 0) return s;
    s.pos = pos_of(i, n);
    const int w = 1 << cfg.vel_log2w;
    if (need_vel && n >= w) {
        const int dw = cfg.lut_bits + cfg.vel_log2w + 4;
        const uint32_t d = (static_cast<uint32_t>(s.pos) - static_cast<uint32_t>(pos_of(i, n - w))) & ((1u << dw) - 1);
        s.vel = d >= (1u << (dw - 1)) ? static_cast<int32_t>(d) - (1 << dw) : static_cast<int32_t>(d);
    }
    const int64_t k = std::min(n, x.n_exact);
    const Axis::Hist& h = x.hist[static_cast<size_t>(k & (kRing - 1))];
    s.index_pos = h.index_pos;
    s.index_count = h.index_count;
    s.ovs = h.ovs;
    s.homed = h.homed;
    s.faults = fault_bits(i, n);
    s.pos_homed = x.ever_homed ? static_cast<int32_t>(static_cast<uint32_t>(s.pos) - static_cast<uint32_t>(x.home)) : s.pos;
    return s;
}

inline int64_t floordiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// the latest sample whose results an edge sees: (n + 1) * D + LATENCY < edge
int64_t seen(int64_t edge) { return floordiv(edge - kLatency - 1, D) - 1; }

// ------------------------------------------------------------------ the register file
struct Reg { uint32_t word, reset, wmask; int64_t rmin, rmax; };
std::vector<Reg> regs;
uint32_t stored[256];
bool mapped[256];
Sample snap[3];
uint32_t seq = 0, irq = 0;
bool wd_expired = false, cfg_err = false, bus_err = false, index_seen[3] = {false, false, false};
int64_t wd_expiry = kNever, next_tick = kNever, snap_at = kNever, cfg_err_at = kNever;
int64_t done_edge = 0;                            // every edge <= done_edge has been applied
bool pending_rose = false;
int64_t irq_edge = 0;
std::vector<int64_t> expiries;

uint32_t tick_div() { return stored[HG_REG_TICK_DIV]; }
uint32_t wdog_timeout() { return stored[HG_REG_WDOG_TIMEOUT]; }
bool global_en() { return stored[HG_REG_CTRL] & HG_CTRL_GLOBAL_EN; }
bool axis_en(int i) { return stored[HG_REG_CTRL] & HG_CTRL_AXIS_EN(i); }

// ------------------------------------------------------------------ commutation (golden.commutation)
std::vector<int64_t> sine_rom;
// the shipped commutation configuration (CommutationConfig defaults; the runner refuses others)
// (the codes saturate at the DAC's full scale, dac_word.h; the ROM's full scale is the same, which
// the runner checks: comm.rom.fs)
constexpr int kCB = 20, kAB = 10, kPolePairs = 2, kShift = 15, kMaxCode = hg_dac::kFullScale, kFS = hg_dac::kFullScale;
constexpr int kPhaseB = (1024 + 1) / 3;
int64_t six_edges[6];
const int kSixA[7] = {0, 1, 1, 0, -1, -1, 0}, kSixB[7] = {-1, -1, 0, 1, 1, 0, -1};

int64_t unfold(int64_t k) {
    k &= 1023;
    const int64_t q = k >> 8, i = k & 255;
    const int64_t mag = sine_rom[static_cast<size_t>((q & 1) ? 255 - i : i)];
    return (q & 2) ? -mag : mag;
}

int64_t scale(int64_t v, int64_t t) {
    const int64_t p = v * t;
    const int64_t a = (std::llabs(p) + (int64_t(1) << (kShift - 1))) >> kShift;
    const int64_t q = p < 0 ? -a : a;
    return std::max<int64_t>(-kMaxCode, std::min<int64_t>(kMaxCode, q));
}

int64_t clamp_torque(int64_t t, int64_t lim) {
    lim = std::min<int64_t>(lim, 32768);
    return std::max(-lim, std::min(lim, t));
}

// Where on a line the decoded quadrant is certain without the ADC words: kBins bins per line;
// bin b holds the sign-bit quadrant if both channels' noise-free codes are >= 2 + 6 sigma in
// magnitude, with the same signs, at both ends of the bin (the signals change by < 0.3 LSB
// across one), so every sample in it decodes to that quadrant with no zero code; else 255.
constexpr int kBins = 4096;
std::vector<uint8_t> safe_q[3];

// The homing sweep's exact interpolator needs more of a sample than its quadrant: no clipping
// and no signal loss either. hsafe_q[i][b]: the quadrant of bin b if, in addition, the noise-free
// codes of a noise-free axis stay inside both limits with one LSB to spare at both ends (a code
// inside the bin is within one of its ends': the signal changes by < 0.3 LSB across it); else 255.
std::vector<uint8_t> hsafe_q[3];

void make_safe_table(int i) {
    safe_q[i].assign(kBins, 255);
    hsafe_q[i].assign(kBins, 255);
    const double lim = 2.0 + 6.0 * noise_lsb[i];
    int prev_q = -1, prev_a = 0, prev_b = 0;
    bool prev_ok = false;
    for (int b = 0; b <= kBins; ++b) {
        int8_t a8, b8;
        hg_plant_encode1(plant, i, static_cast<double>(b) / kBins, 0.0, 0.0, &a8, &b8);
        const bool ok = std::abs(a8) >= lim && std::abs(b8) >= lim;
        const int sa = a8 < 0, sb = b8 < 0, q = (sa << 1) | (sa ^ sb);
        if (b > 0 && ok && prev_ok && q == prev_q) {
            safe_q[i][static_cast<size_t>(b - 1)] = static_cast<uint8_t>(q);
            const int lo_a = std::min(std::abs(a8), prev_a) - 1, hi_a = std::max(std::abs(a8), prev_a) + 1;
            const int lo_b = std::min(std::abs(b8), prev_b) - 1, hi_b = std::max(std::abs(b8), prev_b) + 1;
            if (noise_lsb[i] == 0 && hi_a <= 126 && hi_b <= 126 &&
                lo_a * lo_a + lo_b * lo_b >= cfg.amp_min * cfg.amp_min &&
                hi_a * hi_a + hi_b * hi_b <= cfg.amp_max * cfg.amp_max)
                hsafe_q[i][static_cast<size_t>(b - 1)] = static_cast<uint8_t>(q);
        }
        prev_q = q;
        prev_ok = ok;
        prev_a = std::abs(a8);
        prev_b = std::abs(b8);
    }
}

// The homing-safe quadrant of a sample at fraction fr of a line, or -1 (evaluate its words).
inline int homing_safe_q(int i, double fr) {
    if (cfg.coarse) return -1;
    const uint8_t q = hsafe_q[i][static_cast<size_t>(std::min(kBins - 1, static_cast<int>(fr * kBins)))];
    return q == 255 ? -1 : q;
}

// Bits 31..9 of POS_HOMED of sample n (what sine commutation reads) from the true angle alone,
// when the sample lies in a safe bin: the counter's quadrant count over two (no zero code means
// a fine angle < 2^(L+1), which never carries into bit 9). False: evaluate the sample.
bool sine_hi(int i, int64_t n, int32_t* hi) {
    const Axis& x = AX[i];
    if (!x.built || n <= x.n_exact || n >= x.dropout_from || cfg.coarse) return false;
    const double ln = lines_of(i, n);
    const double fr = ln - std::floor(ln);
    const uint8_t q = safe_q[i][static_cast<size_t>(std::min(kBins - 1, static_cast<int>(fr * kBins)))];
    if (q == 255) return false;
    const int32_t qc = static_cast<int32_t>(static_cast<uint32_t>(x.qc) + static_cast<uint32_t>(qm_at(ln, q) - x.qm_ref));
    const int32_t pos_hi = qc >> 1;               // (pos >> 9 with pos = qc << 8 + f, f < 256)
    *hi = x.ever_homed ? pos_hi - (x.home >> 9) : pos_hi;
    return true;
}

struct Frame { int64_t k, base; int64_t code[6]; int next_ch; };
constexpr int64_t kOpen = 8;                      // latched frames whose loads are still due (ring)
Frame frames_open[kOpen];
int64_t open_head = 0, open_tail = 0;
int64_t present_off[6];                           // frame start -> channel c's presentation, clocks
int64_t present_seen[6];                          // seen(frame start + present_off) - 16 k
int64_t latch_seen = 0;                           // seen(frame start) - 16 k
int64_t ev_present = kNever;                      // the next output-stage presentation (run_to)
int64_t ev_reg = kNever;                          // the register file's next own event (run_to)
int64_t load_after_present = 0;                   // presentation -> load edge (the write strobe + 1)
int64_t next_latch_k = 0;                 // frame 0: the commutator's reset frame (zero torque)
int16_t frame_codes[6] = {0, 0, 0, 0, 0, 0};
RecordFile<LoadRec> loads;
uint32_t skew_clk = 0, frame_clk = 0;

void latch(int64_t k) {
    const int64_t e = k * frame_clk;
    const int64_t n = 16 * k + latch_seen;        // seen(e): the frame is 16 grid points
    if (open_tail - open_head == kOpen) {
        std::fprintf(stderr, "error: internal: more than %lld DAC frames open\n", static_cast<long long>(kOpen));
        std::exit(3);
    }
    Frame& f = frames_open[open_tail & (kOpen - 1)];
    f.k = k;
    f.base = e;
    f.next_ch = 0;
    const bool enable = global_en() && !wd_expired;
    for (int m = 0; m < 3; ++m) {
        const uint32_t mode = axis_en(m) ? (stored[HG_REG_AXIS(m, HG_AX_MODE)] & 3) : HG_MODE_OFF;
        const int faults = fault_bits(m, n);
        const int64_t mask = (int64_t(1) << kCB) - 1;
        int64_t pos = 0;
        int32_t hi = 0;
        const bool fast = mode == HG_MODE_SINE && sine_hi(m, n, &hi);
        if (!fast) {
            const Sample s = sample_of(m, n, false);   // (the commutator reads no velocity)
            pos = static_cast<int64_t>(static_cast<uint32_t>(s.pos_homed)) & mask;
        }
        const int64_t tq = clamp_torque(static_cast<int16_t>(stored[HG_REG_AXIS(m, HG_AX_TORQUE)] & 0xFFFF),
                                        stored[HG_REG_AXIS(m, HG_AX_TQ_LIMIT)] & 0xFFFF);
        const int64_t off = stored[HG_REG_AXIS(m, HG_AX_OFFSET)] & 1023;
        int64_t u = (pos * kPolePairs) & mask;
        if (mode == HG_MODE_ALIGN) u = 0;
        const int64_t ua = (u + (off << (kCB - kAB))) & mask;
        // (sine mode reads only the angle code: bits 18..9 of the position, plus the offset)
        const int64_t ka = fast ? ((static_cast<int64_t>(hi) & 1023) + off) & 1023 : ua >> (kCB - kAB);
        const int64_t kb = (ka - kPhaseB) & 1023;
        int64_t va, vb;
        if (mode == HG_MODE_SIX_STEP) {
            int ne = 0;
            for (int64_t d : six_edges) ne += ua >= d;
            va = kSixA[ne] * kFS;
            vb = kSixB[ne] * kFS;
        } else {
            va = unfold(ka);
            vb = unfold(kb);
        }
        const bool zero = !enable || faults != 0 || mode == HG_MODE_OFF || k == 0 || n < 0;
        f.code[2 * m] = zero ? 0 : scale(va, tq);
        f.code[2 * m + 1] = zero ? 0 : scale(vb, tq);
    }
    ++open_tail;
}

// Channel loads of the latched frames up to edge e (output stage: golden.top.simulate), in frame
// and channel order (a frame's last presentation comes before the next frame's first). The
// caller passes the edge before the next other event, so the controls and the fault lists that
// decide the zeroing are those of each presentation's own edge.
void present_due(int64_t e) {
    const bool rec = cfg.record & 2;
    while (open_head < open_tail) {
        Frame& f = frames_open[open_head & (kOpen - 1)];
        const bool off = wd_expired || !global_en();
        const int64_t n0 = 16 * f.k, g0 = 16 * f.k + 2;
        int c = f.next_ch;
        for (; c < 6; ++c) {
            const int64_t pe = f.base + present_off[c];
            if (pe > e) break;
            const int m = c >> 1;
            const bool kill = off || !axis_en(m) || fault_bits(m, n0 + present_seen[c]) != 0;
            const int code = kill ? 0 : static_cast<int>(f.code[c]);
            if (rec) loads.push({pe + load_after_present, c, code});
            if (G.pend_tail - G.pend_head == Grid::kPend) {
                std::fprintf(stderr, "error: internal: more than %lld DAC words in flight\n", static_cast<long long>(Grid::kPend));
                std::exit(3);
            }
            G.pend[G.pend_tail++ & (Grid::kPend - 1)] = {g0 + 2 * c, c, code};
            frame_codes[c] = static_cast<int16_t>(code);
        }
        f.next_ch = c;
        if (c == 6 && rec && !G.frames.empty()) std::memcpy(G.frames.back().dac, frame_codes, sizeof frame_codes);
        if (c < 6) {
            ev_present = f.base + present_off[c];
            return;
        }
        ++open_head;
    }
    ev_present = kNever;
}

// Register-file events of edge e (golden.regmodel._edge), with the committed write if any.
void update_ev_reg();
void reg_edge(int64_t e, int word = -1, uint32_t data = 0, bool we = false) {
    const uint32_t timeout_pre = wdog_timeout();
    const bool tick = e == next_tick;
    const bool snapnow = tick || e == snap_at;
    uint32_t ack = 0;
    bool fault_clr = false, pet = false, tick_ok = false;
    if (word >= 0 && !mapped[word]) bus_err = true;
    if (word >= 0 && mapped[word] && we) {
        const Reg* r = nullptr;
        for (const auto& x : regs)
            if (x.word == static_cast<uint32_t>(word)) r = &x;
        const uint32_t w = static_cast<uint32_t>(word);
        if (w == HG_REG_CTRL) {
            stored[w] = data & r->wmask;
            const int64_t n_pulse = e / D;   // first sample captured at or after e + 1
            if (data & HG_CTRL_FAULT_CLR) {
                fault_clr = true;
                for (auto& x : AX) { x.clear_at.push_back(n_pulse); x.update_simple(); }
            }
            for (int i = 0; i < 3; ++i)
                if (data & HG_CTRL_HOME_ARM_AXIS(i)) AX[i].arm_at.push_back(n_pulse);
            if (data & HG_CTRL_SNAP) snap_at = e + 1;
        } else if (w == HG_REG_IRQ) {
            ack = data & 3;
        } else if (w == HG_REG_WDOG) {
            pet = data == HG_WDOG_KEY;
        } else if (r->rmin >= 0) {
            if (static_cast<int64_t>(data) >= r->rmin && static_cast<int64_t>(data) <= r->rmax) {
                stored[w] = data & r->wmask;
                tick_ok = w == HG_REG_TICK_DIV;
            } else {
                cfg_err_at = e + 1;
            }
        } else {
            stored[w] = (stored[w] & ~r->wmask) | (data & r->wmask);
        }
    }
    const uint32_t t_pre = irq & 1, m_pre = (irq >> 1) & 1;
    const uint32_t t_new = tick ? 1 : (t_pre & ~ack & 1);
    const uint32_t m_new = (tick && t_pre) ? 1 : (m_pre & ~(ack >> 1) & 1);
    if (t_new && !t_pre) {
        pending_rose = true;
        irq_edge = e;
    }
    irq = t_new | (m_new << 1);
    if (tick || tick_ok) next_tick = e + tick_div();
    if (snapnow) {
        const int64_t n = seen(e);
        for (int i = 0; i < 3; ++i) snap[i] = sample_of(i, n);
        ++seq;
    }
    if (e == snap_at) snap_at = kNever;
    const bool cfg_set = e == cfg_err_at;
    if (cfg_set) cfg_err_at = kNever;
    cfg_err = cfg_set || (cfg_err && !fault_clr);
    if (fault_clr) bus_err = word >= 0 && !mapped[word];
    if (pet || fault_clr) {
        if (fault_clr) wd_expired = false;
        wd_expiry = e + static_cast<int64_t>(timeout_pre) * D;
    } else if (!wd_expired && e == wd_expiry) {
        wd_expired = true;
        expiries.push_back(e);
    }
    done_edge = e;
    update_ev_reg();
}

void grid_point(int64_t g);

// A DAC word reaches the amplifier at grid point g (before that grid point's own work, as in
// device_harness.cpp): the lazy current loop catches up to g first.
void dac_arrival() {
    const Grid::Pend& p = G.pend[G.pend_head++ & (Grid::kPend - 1)];
    if (G.dynamic && cfg.mech_us > 1) {
        hg_plant_amp(plant, static_cast<int>(p.at - G.amp_g));
        G.amp_g = p.at;
    }
    hg_plant_set_dac(plant, p.ch, p.code);
}

// The next grid point with work (a frame record, a mechanics step): every one through the homing
// sweep and with the 1 us plant, else only those. (DAC words arriving in between are applied at
// the next grid point visited, before its work: nothing reads the amplifier in between.)
int64_t next_grid() {
    const int64_t g = G.done + 1;
    if (!G.dynamic || cfg.mech_us <= 1) return g;
    int64_t n = G.mech_next;
    if (cfg.record & 3) n = std::min(n, (g + 15) & ~int64_t(15));
    return std::max(n, g);
}

// The next event of each kind, kept up to date where it changes (run_to's loop compares them;
// ev_present and ev_reg are declared with the frames).
int64_t ev_grid = 0, ev_grid_g = 0;               // the next grid point (its edge, its index)

void update_ev_present() {
    ev_present = kNever;
    if (open_head < open_tail) {
        const Frame& f = frames_open[open_head & (kOpen - 1)];
        ev_present = f.base + present_off[f.next_ch];
    }
}
void update_ev_reg() {
    ev_reg = std::min(next_tick, std::min(snap_at, cfg_err_at));
    if (!wd_expired) ev_reg = std::min(ev_reg, wd_expiry);
}
void update_ev_grid() { ev_grid_g = next_grid(); ev_grid = ev_grid_g * D; }

// Apply everything up to edge E, in edge order: frame latches and output stages (they see the
// controls set before their edge), the register file's own events, the grid points (plant).
void run_to(int64_t E) {
    while (true) {
        const int64_t nl = next_latch_k * frame_clk;
        const int64_t nxt = std::min(std::min(nl, ev_present), std::min(ev_reg, ev_grid));
        if (nxt > E) break;
        if (nl == nxt) { latch(next_latch_k); ++next_latch_k; update_ev_present(); }
        if (ev_present == nxt)   // (every presentation before the next other event: at an equal edge
            present_due(std::min(std::min(E, nl - 1), std::min(ev_reg, ev_grid)));   // a latch comes first)
        if (ev_reg == nxt) reg_edge(nxt);
        if (ev_grid == nxt) { grid_point(ev_grid_g); update_ev_grid(); }
    }
    done_edge = std::max(done_edge, E);
    // (the grid points skipped up to E had nothing to do: the next one with work is > E already)
}

// ------------------------------------------------------------------ the grid point (1 us)
void grid_point(int64_t g) {
    while (G.pend_head < G.pend_tail && G.pend[G.pend_head & (Grid::kPend - 1)].at <= g) dac_arrival();
    G.done = g;
    const bool lazy = G.dynamic && cfg.mech_us > 1;
    if (lazy) hg_plant_amp(plant, static_cast<int>(g - G.amp_g));   // commands held since amp_g
    const bool exact = cfg.mech_us <= 1;        // the plant of the RTL path, every 1 us
    if (exact || !G.dynamic || g >= G.mech_next) {
        double* dst = &G.q[static_cast<size_t>(g & (kRing - 1)) * 3];
        hg_plant_q(plant, dst);
    }
    const bool rec = g % 16 == 0 && G.dynamic && (cfg.record & 3);
    const bool mech = !exact && G.dynamic && g >= G.mech_next;
    hg_plant_out o;
    if (rec && !mech) hg_plant_read(plant, &o);
    if (exact) {
        hg_plant_step(plant, G.steps_per_us);
    } else if (!G.dynamic) {
        hg_plant_held_us(plant);
        G.amp_g = g + 1;
    } else {
        if (mech) {   // one mechanics step to the next multiple of mech_us (and the record)
            const int k = cfg.mech_us - static_cast<int>(g & (cfg.mech_us - 1));   // (a power of 2)
            double q0[3], q1[3];
            hg_plant_q(plant, q0);
            hg_plant_mech_read(plant, k, rec ? &o : nullptr);
            hg_plant_q(plant, q1);
            const double inv = 1.0 / k;
            Grid::Step& st = G.steps[static_cast<size_t>((g >> 4) & 1023)];
            st.g0 = g;
            for (int i = 0; i < 3; ++i) {
                st.q0[i] = q0[i];
                st.dq[i] = (q1[i] - q0[i]) * inv;
            }
            const double* dq = st.dq;
            if (G.lazy_from == kNever) G.lazy_from = g;
            for (int i = 0; i < 3; ++i) {   // overspeed: a step of >= 1/8 line per sample
                if (AX[i].built && std::fabs(dq[i]) / (2 * kPi) * 1024.0 >= 0.125) { AX[i].fault_ev.push_back({g, 1}); AX[i].update_simple(); }
            }
            G.mech_next = g + k;
        }
        hg_plant_amp(plant, 1);
        G.amp_g = g + 1;
    }
    if (rec) G.frames.push(frame_record(o, (static_cast<double>(g) - static_cast<double>(G.scene0)) * 1e-6, cfg.record));
    // the exact interpolator through the homing sweep: sample g - 1 is the ADC word of grid g
    if (!G.dynamic && g >= 1) {
        for (int i = 0; i < 3; ++i) {
            if (!AX[i].built) continue;
            int a = 0, b = 0;
            const double x = lines_of(i, g - 1);
            const double line = std::floor(x);
            const double mline = line - 1024.0 * std::floor(line / 1024.0);
            const int sq = homing_safe_q(i, x - line);
            if (sq < 0) codes(i, g - 1, &a, &b);
            exact_sample(i, g - 1, a, b, mline == 0.0 && x - line < 0.25, sq);
        }
    }
    if (G.dynamic && (cfg.record & 4) && g > G.scene0) {
        for (int i = 0; i < 3; ++i) {
            int a = 0, b = 0;
            if (AX[i].built) codes(i, g - 1, &a, &b);
            G.adc.push(static_cast<int8_t>(a));
            G.adc.push(static_cast<int8_t>(b));
        }
    }
}

// ------------------------------------------------------------------ the HAL: one access per 2 us
int64_t edge_now = 0;                             // the firmware's position on the clock-edge axis
Scenario SC;                                      // the scene's faults, ISR records, enable (harness_common.h)

uint32_t reg_read(uint32_t w) {
    if (w >= 256 || !mapped[w]) return 0xDEADBEEFu;
    const int64_t n = seen(done_edge + 1);
    if (w == HG_REG_STATUS) {
        uint32_t v = 0;
        for (int i = 0; i < 3; ++i) {
            const Sample s = sample_of(i, n);
            if (s.faults) v |= HG_STAT_FAULT(i);
            if (s.homed) v |= HG_STAT_HOMED(i);
            if (s.index_count) index_seen[i] = true;
            if (index_seen[i]) v |= HG_STAT_INDEX(i);
        }
        if (wd_expired) v |= HG_STAT_WDOG;
        if (cfg_err) v |= HG_STAT_CFG_ERR;
        if (bus_err) v |= HG_STAT_BUS_ERR;
        return v;
    }
    if (w == HG_REG_SEQ) return seq;
    if (w == HG_REG_IRQ) return irq;
    if (w == HG_REG_WDOG) return 0;
    for (uint32_t i = 0; i < 3; ++i) {
        const Sample& s = snap[i];
        if (w == HG_REG_AXIS(i, HG_AX_POS)) return static_cast<uint32_t>(s.pos);
        if (w == HG_REG_AXIS(i, HG_AX_VEL))
            return static_cast<uint32_t>((static_cast<int64_t>(s.vel) * 1000000) >> cfg.vel_log2w);
        if (w == HG_REG_AXIS(i, HG_AX_IDX_POS)) return static_cast<uint32_t>(s.index_pos);
        if (w == HG_REG_AXIS(i, HG_AX_POS_HOMED)) return static_cast<uint32_t>(s.pos_homed);
        if (w == HG_REG_AXIS(i, HG_AX_FAULT_CNT)) return (s.index_count << 16) | (s.ovs & 0xFFFF);
        if (w == HG_REG_AXIS(i, HG_AX_FLAGS))
            return static_cast<uint32_t>(s.faults) | (static_cast<uint32_t>(s.homed) << HAPGATE__AXIS_T__FLAGS__HOMED_bp);
    }
    return stored[w];                             // storage, constants, the CAL registers' resets
}

int64_t access_grid() {                           // wait_grid(): the next grid point
    return (edge_now + D - 1) / D;
}

}  // namespace

// The device harness's accesses (bus_hal.h device_timing), applied at the edges the slave
// serves them (hg_bus::grid_access).
extern "C" uint32_t fpga_read32(uint32_t addr) {
    const hg_bus::GridAccess a = hg_bus::grid_access(hg_bus::device_timing(static_cast<uint64_t>(D)), access_grid());
    const uint32_t w = addr & 0xFFU;
    run_to(a.read_state);
    const uint32_t v = reg_read(w);
    run_to(a.commit - 1);
    reg_edge(a.commit, static_cast<int>(w), 0, false);   // a read commits nothing but BUS_ERR
    edge_now = a.end;
    return v;
}

extern "C" void fpga_write32(uint32_t addr, uint32_t v) {
    if (SC.write_lost(addr)) return;  // injected fault: the key write is lost
    const hg_bus::GridAccess a = hg_bus::grid_access(hg_bus::device_timing(static_cast<uint64_t>(D)), access_grid());
    const uint32_t w = addr & 0xFFU;
    run_to(a.commit - 1);
    reg_edge(a.commit, static_cast<int>(w), v, true);
    if (w == HG_REG_WDOG) SC.key_written(a.strobe_rise);
    edge_now = a.end;
}

extern "C" uint32_t hg_hal_irq_save(void) { return 0; }
extern "C" void hg_hal_irq_restore(uint32_t token) { (void)token; }

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s PLANT_CFG RUN_CFG OUTDIR (model fidelity has no PC link)\n", argv[0]);
        return 2;
    }
    std::string err;
    const std::string ptext = slurp(argv[1]);
    const std::string rtext = slurp(argv[2]);
    if (!parse_run(rtext, cfg, err, true)) {
        std::fprintf(stderr, "error: %s: %s\n", argv[2], err.c_str());
        return 2;
    }
    {   // dac_load = LOAD_CLOCKS WR_CYCLES: the edge of channel 0's load after the frame start (the
        // RTL harness's HG_LOAD_CLOCKS) and the write strobe's length (golden.top: presentation =
        // load - 1 - wr, load = presentation + wr + 1)
        const double l = cfg.dac_load[0], w = cfg.dac_load[1];
        if (cfg.dac_load_seen != 1) {
            std::fprintf(stderr, "error: %s: dac_load: expected once\n", argv[2]);
            return 2;
        }
        if (l != std::floor(l) || w != std::floor(w) || w < 1 || l < w + 1) {
            std::fprintf(stderr, "error: %s: dac_load: expected LOAD_CLOCKS WR_CYCLES (whole, LOAD > WR >= 1)\n", argv[2]);
            return 2;
        }
        load_clocks = static_cast<int64_t>(l);
        wr_cycles = static_cast<int64_t>(w);
    }
    load_after_present = wr_cycles + 1;
    if (cfg.clk_hz < 6000000 || cfg.clk_hz % 1000000 || cfg.asin_lut.size() != 129 || cfg.sine_rom.size() != 256 ||
        cfg.regs.empty() || (cfg.mech_us > 1 && 16 % cfg.mech_us) || cfg.lut_bits != 7) {
        std::fprintf(stderr, "error: %s: clk_hz, asin_lut (129), sine_rom (256), reg, mech_us (a divisor of 16) "
                             "or interp (lut_bits 7) missing or unsupported\n", argv[2]);
        return 2;
    }
    char perr[256] = {0};
    plant = hg_plant_new(ptext.c_str(), perr, sizeof perr);
    if (!plant) {
        std::fprintf(stderr, "error: %s: %s\n", argv[1], perr);
        return 2;
    }
    const std::string outdir = argv[3];
    D = cfg.clk_hz / 1000000;
    noise_seed = 0;
    {
        double dt = 1e-6;
        std::istringstream in(ptext);
        std::string line;
        while (std::getline(in, line)) {
            if (line.rfind("dt_s", 0) == 0) dt = std::strtod(line.substr(line.find('=') + 1).c_str(), nullptr);
            if (line.rfind("seed", 0) == 0) noise_seed = static_cast<uint64_t>(std::strtod(line.substr(line.find('=') + 1).c_str(), nullptr));
        }
        G.steps_per_us = std::max(1, static_cast<int>(std::lround(1e-6 / dt)));
    }
    for (double v : cfg.asin_lut) asin_lut.push_back(static_cast<int64_t>(v));
    for (double v : cfg.sine_rom) sine_rom.push_back(static_cast<int64_t>(v));
    for (int j = 0; j < 6; ++j) six_edges[j] = ((int64_t(1) << kCB) * (2 * j + 1) + 11) / 12;
    std::memset(stored, 0, sizeof stored);
    std::memset(mapped, 0, sizeof mapped);
    for (size_t k = 0; k + 4 < cfg.regs.size() + 1; k += 5) {
        Reg r{static_cast<uint32_t>(cfg.regs[k]), static_cast<uint32_t>(cfg.regs[k + 1]),
              static_cast<uint32_t>(cfg.regs[k + 2]), static_cast<int64_t>(cfg.regs[k + 3]),
              static_cast<int64_t>(cfg.regs[k + 4])};
        regs.push_back(r);
        stored[r.word & 0xFF] = r.reset;
        mapped[r.word & 0xFF] = true;
    }
    skew_clk = stored[HG_WORD(offsetof(hapgate_t, DAC_SKEW))];
    frame_clk = stored[HG_WORD(offsetof(hapgate_t, DAC_FRAME))];
    if (frame_clk != 16 * D || skew_clk != 2 * D) {
        std::fprintf(stderr, "error: %s: DAC_SKEW/DAC_FRAME must be 2 us / 16 us\n", argv[2]);
        return 2;
    }
    if (load_clocks >= static_cast<int64_t>(skew_clk)) {   // a word must be loaded before it reaches the amplifier
        std::fprintf(stderr, "error: %s: dac_load: the load must come within one slot (%u clocks)\n", argv[2], skew_clk);
        return 2;
    }
    for (int c = 0; c < 6; ++c) {
        present_off[c] = c * static_cast<int64_t>(skew_clk) + load_clocks - 1 - wr_cycles;
        present_seen[c] = seen(present_off[c]);   // (frame_clk = 16 D: seen(16 k D + x) = 16 k + seen(x))
    }
    latch_seen = seen(0);
    for (int i = 0; i < 3; ++i) {
        noise_lsb[i] = hg_plant_noise_lsb(plant, i);
        AX[i].built = (cfg.axis_mask >> i) & 1;
        if (AX[i].built) make_safe_table(i);     // (read for built axes only)
        AX[i].lut_bits = cfg.lut_bits;
        AX[i].fb = cfg.lut_bits + 1;
        AX[i].hold_pos_homed = cfg.hold_pos_homed[i];
        AX[i].hold_index_pos = cfg.hold_index_pos[i];
        AX[i].hold_index_count = cfg.hold_index_count[i];
    }
    G.frames.open(outdir + "/frames.bin");
    loads.open(outdir + "/loads.bin");
    G.adc.open(outdir + "/adc.bin");
    // reset: the last edge that samples rst high is edge 0
    wd_expiry = static_cast<int64_t>(wdog_timeout()) * D;
    next_tick = tick_div();
    update_ev_reg();
    hg_plant_hold(plant, 1);
    grid_point(0);
    update_ev_grid();

    const auto w0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    hg_servo_cfg_t fw;
    fw_config(cfg, cfg.clk_hz, &fw);
    hg_calib_t stored;        // the board's flash: the scene's calibration, if it has one
    const bool have_stored = fw_store_calib(&fw, &stored);
    static hg_servo_t s;
    static hg_bringup_t bu;
    const uint8_t init_err = hg_servo_init(&s, &fw);
    const uint32_t skew = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_SKEW)));
    const uint32_t frame = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_FRAME)));
    const uint32_t wdog_us = fpga_read32(HG_REG_WDOG_TIMEOUT);
    hg_servo_isr_ctx = &s;
    if (init_err != HG_ERR_NONE) std::fprintf(stderr, "warning: firmware init error %u\n", init_err);

    G.scene0 = std::llround(cfg.t_hold_s * 1e6);
    const int64_t end_us = G.scene0 + std::llround(cfg.duration_s * 1e6);
    SC.start(cfg, G.scene0, D);
    const int64_t end_edge = end_us * D;

    // The main loop of device_harness.cpp at event granularity: its checks run after every clock
    // edge outside a bus access; here they run at the first such edge where one can change
    // anything (a servo tick, the release, a fault, a progress line, the hang's resumption).
    while (edge_now < end_edge) {
        int64_t e = edge_now + 1;
        if (!pending_rose) {
            int64_t c = std::min(end_edge, next_tick);
            if (!G.dynamic) c = std::min(c, G.scene0 * D);
            c = std::min(c, SC.next_edge());
            e = std::max(e, c);
        }
        run_to(e);
        edge_now = e;
        const int64_t g_now = e / D;
        if (!G.dynamic && g_now >= G.scene0) {
            hg_plant_hold(plant, 0);
            hg_plant_set_q(plant, cfg.q0, cfg.qd0);
            G.dynamic = true;
            G.mech_next = G.done + 1;
            update_ev_grid();
            for (int i = 0; i < 3; ++i) {
                if (!AX[i].built) continue;
                const int q = (AX[i].sa << 1) | (AX[i].sa ^ AX[i].sb);
                AX[i].qm_ref = qm_of(i, AX[i].n_exact, q);
            }
        }
        SC.at_grid(g_now, [&](const RunCfg::Fault& f) {
            if (f.kind != FaultKind::dropout) return;
            // A = B = 0 from the next grid point's word: sample g_now on
            AX[f.axis].dropout_from = g_now;
            if (AX[f.axis].built) { AX[f.axis].fault_ev.push_back({g_now + cfg.loss_samples - 1, 4}); AX[f.axis].update_simple(); }
        });
        const bool rose = pending_rose;
        pending_rose = false;
        if (!SC.isr_due(rose, e, (irq & 1) != 0, wdog_us)) continue;
        const int64_t tick_g = (rose ? irq_edge : e) / D;
        hg_servo_isr();
        const int64_t gs = tick_g - 1;
        const double qs[3] = {G.qat(gs, 0), G.qat(gs, 1), G.qat(gs, 2)};
        switch (SC.after_isr(s, tick_g, qs)) {   // the background loop (device_harness.cpp)
        case Scenario::Bg::power_up: {
            const int rc = fw_power_up(&s, &bu, cfg, have_stored ? &stored : nullptr);
            if (rc != 0) return rc;
            break;
        }
        case Scenario::Bg::scene:
            if (hg_servo_calibrated(&s) && hg_servo_enable(&s, true) != 0) {
                std::fprintf(stderr, "error: the firmware refused to enable\n");
                return 3;
            }
            SC.enabled((static_cast<double>(edge_now / D) - static_cast<double>(G.scene0)) * 1e-6);
            break;
        case Scenario::Bg::none:
            break;
        }
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    G.frames.close();
    SC.finish(outdir);
    loads.close();
    G.adc.close();
    const double sim_s = static_cast<double>(end_us - G.scene0) * 1e-6;
    print_summary({cfg.clk_hz, cfg.axis_mask, sim_s, wall_s, cpu_s, static_cast<uint64_t>(edge_now), G.frames.size(),
                   SC.ticks.size(), loads.size(), init_err, s.err, s.err_axis, SC.enable_t(), wdog_us,
                   static_cast<uint64_t>(SC.last_key_edge()), G.scene0, skew, frame, static_cast<uint64_t>(D)});
    hg_plant_free(plant);
    return 0;
}
