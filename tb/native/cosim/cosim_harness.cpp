// SPDX-License-Identifier: Apache-2.0
// Firmware co-simulation runner: the DSP firmware (dsp-fw/src/*.c, unchanged, C99) runs natively
// against the Verilated FPGA top over the modelled EMIF bus (hal_cosim.cpp). The harness moves
// three encoders along a prescribed "hand" trajectory (into a virtual wall and back), feeds the
// ADC codes at every adc_strobe, calls hg_servo_isr() on every rising edge of irq, records every
// DAC load, and checks the result itself: it exits 0 and prints "result=PASS" only if every
// check holds. Driven by models/hapgate/runners/cosim.py, which reads the scene
// (scenes/cosim/*.toml), writes its run configuration and re-checks the outputs independently.
//
// usage: cosim_harness RUN_CFG OUTDIR
//   RUN_CFG: the run configuration (hg_dev::parse_run with the cosim_* keys; its file stem names
//   the scenario in the summary): the trajectory, the firmware's wall (env_*) and the check's
//   (cosim_wall_*), the tick rate, the bus timing, at most one fault (the shared scenario engine
//   runs it), or cosim_kind = 1: bus throughput.
// Outputs in OUTDIR: ticks.bin (the engine's record per ISR), isr.csv (beside it: edges, codes),
// frames.csv (one row per DAC frame), loads.bin (every DAC load); the shared key=value summary
// and the co-simulation's own lines on stdout (README.md "Outputs").
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cosim.h"
#include "dac_word.h"
#include "plant.h"

extern "C" {
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "hg_servo.h"
}

using namespace cosim;
using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>;  // m[row][col]

namespace {

// ------------------------------------------------------------------ plant constants
constexpr double kPi = 3.14159265358979323846;
constexpr double kLines = 1024.0;        // encoder lines per revolution
constexpr double kAdcR = 110.0;          // ADC amplitude (codes): the plant's enc_amplitude
constexpr int kPolePairs = 2;
constexpr double kDacFs = hg_dac::kFullScale;   // DAC code at full scale (dac_word.h)
#if !defined(HG_LOAD_CLOCKS) || !defined(HG_WR_CYCLES)
#error "HG_LOAD_CLOCKS and HG_WR_CYCLES (from the top's configuration) must be defined"
#endif
// frame start -> channel 0 load (the commutator's load latency + the output stage's register,
// rtl/top/README.md; longer where the DAC's t_WCS needs a longer strobe)
constexpr int kLoadClocks = HG_LOAD_CLOCKS;

double deg(double x) { return x * kPi / 180.0; }

// ------------------------------------------------------------------ the plant's encoders and geometry
// The virtual device's plant (tb/native/device/plant.cpp) serves as the encoder front end
// (noise-free, amplitude kAdcR) and as the independent reference kinematics of the force check
// (a double implementation of docs/design/KINEMATICS.md, h = 0, apart from the firmware's, which
// is the code under test). Its joints are not simulated here: the hand trajectory sets them.
hg_plant* g_plant = nullptr;

Vec3 fk(const Vec3& q) {
    Vec3 p{};
    hg_plant_fk(g_plant, q.data(), p.data());
    return p;
}

Mat3 jac(const Vec3& q) {   // m[row][col] = d p_row / d q_col
    double m9[9];
    hg_plant_jac(g_plant, q.data(), m9);
    Mat3 m{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m[i][j] = m9[3 * i + j];
    return m;
}

// Solve A x = b (Cramer; A well conditioned in the workspace used here).
Vec3 solve(const Mat3& a, const Vec3& b) {
    auto det = [](const Mat3& m) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
               m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det(a);
    Vec3 x{};
    for (int c = 0; c < 3; ++c) {
        Mat3 m = a;
        for (int r = 0; r < 3; ++r) m[r][c] = b[r];
        x[c] = det(m) / d;
    }
    return x;
}

// Largest singular value of a 3x3 matrix (power iteration on M^T M).
double norm2(const Mat3& m) {
    Vec3 v = {1.0, 0.7, 0.4};
    double s = 0.0;
    for (int it = 0; it < 60; ++it) {
        Vec3 w{}, u{};
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) w[i] += m[i][j] * v[j];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) u[j] += m[i][j] * w[i];
        const double n = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int j = 0; j < 3; ++j) v[j] = u[j] / n;
        s = std::sqrt(n);
    }
    return s;
}

Mat3 inv_t(const Mat3& j) {  // (J^T)^-1 by columns
    Mat3 jt{}, r{};
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) jt[i][k] = j[k][i];
    for (int c = 0; c < 3; ++c) {
        Vec3 e{};
        e[c] = 1.0;
        const Vec3 x = solve(jt, e);
        for (int i = 0; i < 3; ++i) r[i][c] = x[i];
    }
    return r;
}

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// ------------------------------------------------------------------ the hand trajectory
struct Trajectory {
    Vec3 q_free{};            // the scene's free pose (run q0), rad
    Vec3 q_deep{};            // the deepest pose (cosim_q_deep), rad
    Vec3 q_index{};           // joint angle at the index (line 0 starts there)
    Vec3 sweep{};             // homing sweep: the joints power up this far before q_free
    Vec3 powerup{};           // power-up position after the index, rad in [0, 2 pi)
    double qd_home = 90.0;    // rad/s, the sweep's speed (the firmware's qd_max is 100 rad/s)
    double t_home = 0;        // s, the sweep (it crosses the index once); drive is enabled after it
    double t_push = 0;        // s, start of the push (3 ms after the sweep)
    double t_in = 0;          // s, into the wall (raised cosine), the same back (cosim_push)
    double t_hold = 0;        // s, held at the deepest point
    double t_end = 0;         // s, the scene's duration after the push start

    // Power-up anywhere in the revolution (seeded): joint i starts at q_index + powerup[i]
    // (uniform over the whole revolution), sweeps forwards at qd_home through the next index
    // and stops at q_free, a random 0.25..20 deg after it. The raw position (relative to
    // power-up) and the homed one then differ by a random angle: commutating from the raw one
    // cannot pass.
    Trajectory(uint64_t seed, const hg_dev::RunCfg& run) {
        for (int i = 0; i < 3; ++i) {
            q_free[i] = run.q0[i];
            q_deep[i] = run.cosim.q_deep[i];
        }
        t_in = run.cosim.t_in;
        t_hold = run.cosim.t_hold;
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> turn(0.0, 2 * kPi), after(deg(0.25), deg(20.0));
        double longest = 0;
        for (int i = 0; i < 3; ++i) {
            powerup[i] = turn(rng);
            const double past = after(rng);
            q_index[i] = q_free[i] - past;
            sweep[i] = (2 * kPi - powerup[i]) + past;
            longest = std::max(longest, sweep[i]);
        }
        t_home = std::ceil(longest / qd_home * 1e3) * 1e-3;
        t_push = t_home + 3e-3;
        t_end = t_push + run.duration_s;
    }
    double s(double t) const {  // 0 free .. 1 deep
        const double u = t - t_push;
        if (u <= 0) return 0.0;
        if (u < t_in) return 0.5 * (1 - std::cos(kPi * u / t_in));
        if (u < t_in + t_hold) return 1.0;
        if (u < 2 * t_in + t_hold) return 0.5 * (1 + std::cos(kPi * (u - t_in - t_hold) / t_in));
        return 0.0;
    }
    Vec3 q(double t) const {
        Vec3 r{};
        const double ss = s(t);
        for (int i = 0; i < 3; ++i) {
            const double sw = std::min(0.0, qd_home * t - sweep[i]);  // each at qd_home, then stops
            r[i] = q_free[i] + sw + ss * (q_deep[i] - q_free[i]);
        }
        return r;
    }
    Vec3 qdot(double t) const {
        const double h = 1e-6;
        const Vec3 a = q(t - h), b = q(t + h);
        return {(b[0] - a[0]) / (2 * h), (b[1] - a[1]) / (2 * h), (b[2] - a[2]) / (2 * h)};
    }
};

double edge_time(uint64_t e) { return static_cast<double>(e) / CLK_HZ; }

// What the co-simulation's checks need of each ISR call beyond the engine's record (TickRec, the
// same index in Scenario::ticks): its edges and the DAC codes the firmware computed.
struct IsrEdges {
    uint64_t irq_edge, start, end;
    int16_t code[3];
};

struct Frame {
    uint64_t start;
    int code[6];
    int n = 0;
};

// ------------------------------------------------------------------ the run configuration
// Parse RUN_CFG into `run` (static in main: the scenario engine keeps a pointer to it), name the
// scenario after its file stem and set the bus timing. Returns 0, or the exit code (2: bad input).
int configure(int argc, char** argv, hg_dev::RunCfg& run, std::string& scenario, std::string& outdir) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s RUN_CFG OUTDIR\n", argv[0]);
        return 2;
    }
    std::string err;
    if (FILE* f = std::fopen(argv[1], "r")) {
        std::fclose(f);
    } else {
        std::fprintf(stderr, "error: %s: cannot read the run configuration\n", argv[1]);
        return 2;
    }
    if (!hg_dev::parse_run(hg_dev::slurp(argv[1]), run, err, hg_dev::Keys::cosim)) {
        std::fprintf(stderr, "error: %s: %s\n", argv[1], err.c_str());
        return 2;
    }
    if (run.faults.size() > 1) {
        std::fprintf(stderr, "error: %s: fault: at most one fault per co-simulation scene\n", argv[1]);
        return 2;
    }
    scenario = argv[1];   // the run configuration's file stem
    scenario = scenario.substr(scenario.find_last_of('/') + 1);
    scenario = scenario.substr(0, scenario.find('.'));
    outdir = argv[2];
    const hg_dev::RunCfg::Cosim& co = run.cosim;
    bus_timing.setup = co.bus[0];
    bus_timing.strobe = co.bus[1];
    bus_timing.hold = co.bus[2];
    bus_timing.use_ready = co.bus[3] != 0;
    return 0;
}

// ------------------------------------------------------------------ cosim_kind = 1: bus throughput
// Back-to-back SCRATCH write / read-back pairs; no firmware, no frames.
int bus_throughput(const std::string& scenario, uint32_t n) {
    Testbench bench;
    tb = &bench;
    bench.reset();
    const auto t0 = std::chrono::steady_clock::now();
    uint64_t bad = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t v = i * 2654435761u;
        fpga_write32(HG_REG_SCRATCH, v);
        bad += fpga_read32(HG_REG_SCRATCH) != v;
    }
    const double w = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const uint32_t st = fpga_read32(HG_REG_STATUS);
    const bool ok = bad == 0 && (st & (HG_STAT_BUS_ERR | HG_STAT_PROTO_ERR)) == 0;
    std::printf("scenario=%s clk_hz=%d setup=%d strobe=%d hold=%d ready=%d\n", scenario.c_str(), CLK_HZ,
                bus_timing.setup, bus_timing.strobe, bus_timing.hold, int(bus_timing.use_ready));
    std::printf("sim_s=%.9g wall_s=%.6g clocks=%llu bus_reads=%llu bus_writes=%llu mismatches=%llu tx_per_s=%.6g "
                "sim_per_wall=%.6g status=%u\n", edge_time(bench.edge), w, static_cast<unsigned long long>(bench.edge),
                static_cast<unsigned long long>(bus_stats.reads), static_cast<unsigned long long>(bus_stats.writes),
                static_cast<unsigned long long>(bad), 2.0 * n / w, edge_time(bench.edge) / w, st);
    std::printf("result=%s\n", ok ? "PASS" : "FAIL");
    return ok ? 0 : 1;
}

constexpr uint64_t kD = CLK_HZ / 1000000;   // clocks per microsecond (the engine's grid)
static_assert(CLK_HZ % 1000000 == 0, "CLK_HZ must be a whole number of MHz");

// ------------------------------------------------------------------ the servo run
// One scene, step by step (main calls them in order): setup, the firmware and the clock loop,
// the DAC frames from the loads, the homing error, the per-frame checks (torque, force) with
// frames.csv, the other outputs, the safety reaction, the verdict and the report. Each step
// leaves its results in the members the later ones read.
class ServoRun {
public:
    ServoRun(hg_dev::RunCfg& run, std::string scenario, std::string outdir)
        : run_(run), co_(run.cosim), scenario_(std::move(scenario)), outdir_(std::move(outdir)),
          fkind_(run.faults.empty() ? kNoFault : run.faults[0].kind), s_wall_(fkind_ == kNoFault),
          s_wdog_(fkind_ == hg_dev::FaultKind::watchdog), s_hang_(fkind_ == hg_dev::FaultKind::hang),
          s_drop_(fkind_ == hg_dev::FaultKind::dropout), drop_axis_(s_drop_ ? run.faults[0].axis : 0),
          tr_(co_.seed, run) {}

    int setup();
    int simulate();
    void build_frames();
    int homing_error();
    int check_frames();
    int write_outputs();
    void check_reaction();
    std::vector<std::string> verdict();
    int report(const std::vector<std::string>& fails);

private:
    int clock_loop();
    void check_frame(const Frame& f, FILE* fcsv);
    void check_force(const double trec[3], const double tbud[3], const Vec3& qs, const IsrEdges& ir,
                     const hg_dev::TickRec& tk);

    // the scene's fault (none: the normal run, its checks; the negative control is a normal run
    // with a commutation offset error, comm_err)
    static constexpr hg_dev::FaultKind kNoFault = static_cast<hg_dev::FaultKind>(-1);
    hg_dev::RunCfg& run_;
    const hg_dev::RunCfg::Cosim& co_;
    const std::string scenario_, outdir_;
    const hg_dev::FaultKind fkind_;
    const bool s_wall_, s_wdog_, s_hang_, s_drop_;
    const int drop_axis_;
    Trajectory tr_;
    double t_fault_ = 0, wall_k_ = 0;
    Vec3 nrm_{}, p0_{};

    // the testbench and its stimulus
    Testbench bench_;
    bool dropout_on_ = false;
    // the true joint angles of the samples captured at each grid point (a ring): the snapshot of
    // a tick at grid point g holds the sample of grid point g - 1 (tb/native/device/README.md)
    static constexpr size_t kRing = 64;
    std::vector<Vec3> q_ring_ = std::vector<Vec3>(kRing);

    // the firmware and the scenario engine, what the clock loop saw
    hg_servo_t s_{};
    uint8_t init_err_ = 0;
    uint32_t dac_skew_ = 0, dac_frame_ = 0, clk_khz_ = 0, wdog_us_ = 0;
    hg_dev::Scenario sc_;
    int64_t scene0_us_ = 0;
    std::vector<IsrEdges> isrs_;   // isrs_[k] and sc_.ticks[k]: the same ISR call
    uint64_t fault_edge_cmd_ = 0, post_hang_status_edge_ = 0;
    uint32_t status_after_ = 0, irq_reg_ = 0;
    double wall_s_ = 0, cpu_s_ = 0;

    // the DAC frames and the TORQUE register writes per axis
    uint64_t frame_ = 0, skew_ = 0;
    std::vector<Frame> frames_;
    bool frame_timing_ok_ = true;
    struct TW { uint64_t fall, rise; int16_t v; int64_t isr; };
    std::vector<TW> tw_[3];
    uint32_t tq_limit_[3] = {0, 0, 0};

    // homing
    double home_err_[3] = {0, 0, 0};
    double home_q_[3] = {0, 0, 0};  // the homing error rounded to whole quadrants (256 counts)
    double interp_cnt_ = 0;

    // the frame checks
    uint64_t cause_edge_ = 0, normal_end_ = 0;
    double max_terr_ = 0, max_terr_ratio_ = 0, max_ferr_ = 0, max_ferr_ratio_ = 0, max_free_ = 0;
    double max_depth_ = 0, max_force_ = 0, min_cos_ = 1;
    uint64_t n_tq_ = 0, n_force_ = 0, n_wall_ = 0, n_torn_ = 0, n_nonzero_ = 0;

    // the safety reaction
    uint64_t bound_ = 0, latch_edge_ = 0;
    int64_t reaction_ = -1;
    bool nonzero_before_ = false, all_zero_after_latch_ = true;
};

// The plant, the check's reference wall, the testbench's ADC stimulus; reset.
int ServoRun::setup() {
    for (int i = 0; i < 3; ++i) run_.q_index[i] = tr_.q_index[i];   // the firmware's calibration (fw_config)
    {
        char text[96], err[256] = {0};
        std::snprintf(text, sizeof text, "enc_amplitude = %.17g %.17g %.17g\n", kAdcR, kAdcR, kAdcR);
        g_plant = hg_plant_new(text, err, sizeof err);
        if (!g_plant) {
            std::fprintf(stderr, "error: plant: %s\n", err);
            return 3;
        }
    }
    t_fault_ = s_wall_ ? 0.0 : tr_.t_push + run_.faults[0].at_s;   // scene time from the push

    // The check's reference wall, the scene's (cosim_wall_at, cosim_wall_k; b = 0) through the
    // plant's kinematics: through the point wall_at of the way from the free to the deep pose,
    // normal into free space. The firmware gets its wall from the env_* keys (cosim.run_config
    // writes both from the scene), so a wrong env_* is a failed force check.
    wall_k_ = co_.wall_k;   // N/m
    const Vec3 pf = fk(tr_.q_free), pd = fk(tr_.q_deep);
    double l = 0;
    for (int i = 0; i < 3; ++i) l += (pf[i] - pd[i]) * (pf[i] - pd[i]);
    l = std::sqrt(l);
    for (int i = 0; i < 3; ++i) {
        nrm_[i] = (pf[i] - pd[i]) / l;
        p0_[i] = pf[i] + co_.wall_at * (pd[i] - pf[i]);
    }

    tb = &bench_;
    bench_.adc = [this](uint64_t cap, uint32_t& a, uint32_t& b, uint32_t& idx) {
        const Vec3 q = tr_.q(edge_time(cap));
        q_ring_[(cap / kD) % kRing] = q;
        for (int i = 0; i < 3; ++i) {
            const double x = (q[i] - tr_.q_index[i]) / (2 * kPi) * kLines;
            int8_t ca = 0, cb = 0;
            hg_plant_encode1(g_plant, i, x, 0.0, 0.0, &ca, &cb);
            if (dropout_on_ && i == drop_axis_) ca = cb = 0;
            a |= static_cast<uint32_t>(static_cast<uint8_t>(ca)) << (8 * i);
            b |= static_cast<uint32_t>(static_cast<uint8_t>(cb)) << (8 * i);
            const double line = std::floor(x);
            const bool ix = std::fmod(std::fmod(line, kLines) + kLines, kLines) == 0.0 && x - line < 0.25;
            idx |= static_cast<uint32_t>(ix) << i;
        }
    };
    bench_.reset();
    return 0;
}

// The firmware's init (board code), then the clock loop; timed (wall_s, cpu_s).
int ServoRun::simulate() {
    const auto w0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    hg_servo_cfg_t cfg;
    hg_dev::fw_config(run_, CLK_HZ, &cfg);
    init_err_ = hg_servo_init(&s_, &cfg);
    dac_skew_ = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_SKEW)));
    dac_frame_ = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_FRAME)));
    clk_khz_ = fpga_read32(HG_REG_CLK_KHZ);
    wdog_us_ = fpga_read32(HG_REG_WDOG_TIMEOUT);
    fpga_write32(HG_REG_CTRL, HG_CTRL_HOME_ARM);  // arm homing of all three axes
    hg_servo_isr_ctx = &s_;
    if (const int rc = clock_loop()) return rc;
    if (!status_after_) status_after_ = fpga_read32(HG_REG_STATUS);
    irq_reg_ = fpga_read32(HG_REG_IRQ);
    wall_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    cpu_s_ = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;  // one core
    return 0;
}

// The shared scenario engine (harness_common.h) on the 1 us grid, scene time 0 at the push:
// the scene's fault (every watchdog key write lost, the DSP hung: it resumes 2 ms after the
// expiry, or an axis's signal gone), the ISR records (ticks.bin) and the enable.
int ServoRun::clock_loop() {
    scene0_us_ = std::llround(tr_.t_push * 1e6);
    sc_.start(run_, scene0_us_, static_cast<int64_t>(kD), true);   // its sweep homes the FPGA
    cosim::scenario = &sc_;
    // whole microseconds: the push starts on one, the scene's duration is a whole number of them
    const uint64_t end_edge = static_cast<uint64_t>(scene0_us_ + std::llround(run_.duration_s * 1e6)) * kD;
    while (bench_.edge < end_edge) {
        bench_.tick();
        if (bench_.edge % kD == 0)
            sc_.at_grid(static_cast<int64_t>(bench_.edge / kD), [&](const hg_dev::RunCfg::Fault& f) {
                fault_edge_cmd_ = bench_.edge;
                if (f.kind == hg_dev::FaultKind::dropout) dropout_on_ = true;
            });
        const bool rose = bench_.irq_rose;
        bench_.irq_rose = false;
        const bool hung = sc_.hanging() && !sc_.resumed();
        const bool call = sc_.isr_due(rose, static_cast<int64_t>(bench_.edge), bench_.top->irq != 0, wdog_us_);
        if (hung && sc_.resumed()) {
            // the DSP is back: a "debugger" reads STATUS, then the pending interrupt is serviced
            // and the firmware must refuse to drive
            status_after_ = fpga_read32(HG_REG_STATUS);
            post_hang_status_edge_ = bench_.edge;
        }
        if (!call) continue;
        IsrEdges r{};
        r.irq_edge = rose ? bench_.irq_rise_edge : bench_.edge;
        r.start = bench_.edge;
        current_isr = static_cast<int64_t>(isrs_.size());
        hg_servo_isr();
        current_isr = -1;
        r.end = bench_.edge;
        for (int i = 0; i < 3; ++i) r.code[i] = s_.code[i];
        isrs_.push_back(r);
        const int64_t tick_g = static_cast<int64_t>(r.irq_edge / kD);
        // ---- background loop: homing, then the scene and enable at the tick before scene time 0
        if (sc_.after_isr(s_, tick_g, q_ring_[static_cast<size_t>(tick_g - 1) % kRing].data()) == hg_dev::Scenario::Bg::scene) {
            const int rc = hg_dev::fw_home_scene_enable(&s_, run_, true);
            if (rc != 0) return rc;
            sc_.enabled(sc_.scene_t(static_cast<int64_t>(bench_.edge / kD)));
        }
    }
    return 0;
}

// The DAC frames from the loads (six channels, each kLoadClocks + addr * skew after the frame
// start, frames one DAC_FRAME apart on its grid), and the TORQUE / TQ_LIMIT writes per axis.
void ServoRun::build_frames() {
    frame_ = dac_frame_;
    skew_ = dac_skew_;
    for (const auto& ld : bench_.loads) {
        const uint64_t st = ld.edge - kLoadClocks - static_cast<uint64_t>(ld.addr) * skew_;
        if (frames_.empty() || frames_.back().start != st) {
            if (!frames_.empty() && (frames_.back().n != 6 || st != frames_.back().start + frame_))
                frame_timing_ok_ = false;
            frames_.push_back({st, {0, 0, 0, 0, 0, 0}, 0});
        }
        Frame& f = frames_.back();
        if (ld.addr != f.n) frame_timing_ok_ = false;
        f.code[ld.addr] = ld.code;
        f.n++;
    }
    if (!frames_.empty() && frames_.back().n != 6) frames_.pop_back();  // cut by the end of the run
    if (!frames_.empty() && frames_.front().start % frame_ != 0) frame_timing_ok_ = false;

    // TORQUE writes per axis; the register value a frame latch at edge L sees
    for (const auto& w : bus_writes) {
        for (uint32_t i = 0; i < 3; ++i) {
            if (w.addr == HG_REG_AXIS(i, HG_AX_TORQUE))
                tw_[i].push_back({w.fall, w.rise, static_cast<int16_t>(w.data & 0xFFFFU), w.isr});
            if (w.addr == HG_REG_AXIS(i, HG_AX_TQ_LIMIT)) tq_limit_[i] = w.data;
        }
    }
}

// The homing error: firmware joint angle minus the truth of its sample at the first driving tick
// (the tick at the push start: its sample is the last before the push, the joints at rest at
// q_free), in counts. The interpolator latches the quadrant the sign bits show at the index edge;
// on a slow approach that is the quadrant before the index quadrant (see README).
int ServoRun::homing_error() {
    const hg_dev::TickRec* ref = nullptr;
    for (const auto& r : sc_.ticks)
        if (r.drive) { ref = &r; break; }
    if (!ref) { std::fprintf(stderr, "error: no driving tick after enable\n"); return 1; }
    for (int i = 0; i < 3; ++i) home_err_[i] = (ref->q_fw[i] - ref->q_true[i]) * HG_ENC_COUNTS_PER_REV / (2 * kPi);
    // interpolation accuracy at this ADC amplitude, counts: the arcsine table assumes R = 127, so
    // the fine angle is asin(g sin t) instead of t (worst at 45 deg, g = R/127), plus 1/2 LUT
    // step and 1/2 ADC LSB of angle (1024 counts per 360 deg electrical)
    const double g = kAdcR / 127.0, cnt_per_rad = 1024.0 / (2 * kPi);
    interp_cnt_ = (kPi / 4 - std::asin(g * std::sin(kPi / 4))) * cnt_per_rad + 0.5 * 1024.0 / 1024.0 +
                  0.5 / kAdcR * cnt_per_rad;
    for (int i = 0; i < 3; ++i) home_q_[i] = 256.0 * std::round(home_err_[i] / 256.0);
    return 0;
}

// Every DAC frame: its row of frames.csv, and the torque (b1) and force (b2) checks on the frames
// before the cause.
int ServoRun::check_frames() {
    cause_edge_ = s_drop_ ? bench_.fault_edge[drop_axis_] : (s_wall_ ? 0 : bench_.wdog_expired_edge);
    normal_end_ = s_wall_ ? UINT64_MAX : (cause_edge_ ? cause_edge_ : fault_edge_cmd_);
    FILE* fcsv = std::fopen((outdir_ + "/frames.csv").c_str(), "w");
    if (!fcsv) { std::fprintf(stderr, "error: cannot write %s\n", outdir_.c_str()); return 2; }
    std::fprintf(fcsv, "start,c0,c1,c2,c3,c4,c5,q0,q1,q2,tlo0,tlo1,tlo2,thi0,thi1,thi2,snap_edge,drive,qs0,qs1,qs2\n");
    for (const auto& f : frames_) check_frame(f, fcsv);
    std::fclose(fcsv);
    return 0;
}

void ServoRun::check_frame(const Frame& f, FILE* fcsv) {
    const double t_scale = 32768.0 / (1.5 * kDacFs);  // sum_j code_j sin(theta_j) -> torque command
    auto clampt = [&](int v, int i) { const int l = static_cast<int>(tq_limit_[i]); return std::clamp(v, -l, l); };
    const std::vector<hg_dev::TickRec>& ticks = sc_.ticks;
    const uint64_t L = f.start;
    const double t = edge_time(L);
    const Vec3 q = tr_.q(t);
    int tlo[3], thi[3];
    int64_t isr_of[3];
    bool amb = false;
    for (int i = 0; i < 3; ++i) {
        int lo = 0, hi = 0;
        int64_t is = -1;
        for (const auto& w : tw_[i]) {  // few hundred per axis per second: fine
            if (w.fall >= L) break;
            hi = w.v;
            is = w.isr;
            if (w.rise + 1 < L) lo = w.v;
        }
        tlo[i] = clampt(lo, i);
        thi[i] = clampt(hi, i);
        isr_of[i] = is;
        amb = amb || tlo[i] != thi[i];
    }
    const bool same = isr_of[0] == isr_of[1] && isr_of[1] == isr_of[2] && isr_of[0] >= 0;
    const size_t k = same ? static_cast<size_t>(isr_of[0]) : 0;
    const IsrEdges* ir = same ? &isrs_[k] : nullptr;
    const hg_dev::TickRec* tk = same ? &ticks[k] : nullptr;
    const Vec3 qs = tk ? Vec3{tk->q_true[0], tk->q_true[1], tk->q_true[2]} : Vec3{0, 0, 0};
    std::fprintf(fcsv, "%llu,%d,%d,%d,%d,%d,%d,%.12g,%.12g,%.12g,%d,%d,%d,%d,%d,%d,%lld,%d,%.12g,%.12g,%.12g\n",
                 static_cast<unsigned long long>(L), f.code[0], f.code[1], f.code[2], f.code[3], f.code[4],
                 f.code[5], q[0], q[1], q[2], tlo[0], tlo[1], tlo[2], thi[0], thi[1], thi[2],
                 ir ? static_cast<long long>(ir->irq_edge) : -1LL, tk ? int(tk->drive) : 0, qs[0], qs[1], qs[2]);
    // a frame is checked if all six of its loads came before the cause (a frame the cause
    // cuts through has some channels zeroed: the zero-torque check below covers those)
    if (L == 0 || L + kLoadClocks + 5 * skew_ >= normal_end_) return;
    // (b1) torque reconstruction: amplifier third phase -(a + b), sinusoidal windings
    double trec[3], tbud[3];
    for (int m = 0; m < 3; ++m) {
        const double th = 2 * kPi * kPolePairs * (q[m] - tr_.q_index[m]) / (2 * kPi);
        const double ia = f.code[2 * m], ib = f.code[2 * m + 1], ic = -(ia + ib);
        const double sum = ia * std::sin(th) + ib * std::sin(th - 2 * kPi / 3) + ic * std::sin(th + 2 * kPi / 3);
        trec[m] = sum * t_scale;
        const double tmax = std::max(std::abs(tlo[m]), std::abs(thi[m]));
        // budget: +-0.5 LSB output rounding and +-0.5 LSB ROM rounding x t/2^15 per phase,
        // through the 2-of-3 reconstruction (<= sqrt(3)(|ea|+|eb|)), plus the commutation's
        // 0.3 % angle/phase ripple budget (hapgate.golden.commutation.SINE_RIPPLE_BUDGET)
        tbud[m] = 2 * std::sqrt(3.0) * (0.5 + 0.5 * tmax / 32768.0) * t_scale + 0.003 * tmax;
        const double e = std::min(std::abs(trec[m] - tlo[m]), std::abs(trec[m] - thi[m]));
        max_terr_ = std::max(max_terr_, e);
        max_terr_ratio_ = std::max(max_terr_ratio_, e / tbud[m]);
        n_tq_++;
        if (f.code[2 * m] || f.code[2 * m + 1]) n_nonzero_++;
    }
    // (b2) the force, on a frame not torn between two TORQUE values or two ISRs
    if (amb || !ir) { n_torn_++; return; }
    check_force(trec, tbud, qs, *ir, *tk);
}

// (b2) The endpoint force from the reconstructed torques trec (budgets tbud, DAC codes) at the
// pose qs the firmware sampled (ISR ir, record tk) against the wall law.
void ServoRun::check_force(const double trec[3], const double tbud[3], const Vec3& qs, const IsrEdges& ir,
                           const hg_dev::TickRec& tk) {
    const double nm_per_code = 0.06 * 0.8 * 10.0 / 32767.0;
    auto qref = [&](const Vec3& qt) {  // the truth in the firmware's homed frame
        Vec3 r = qt;
        for (int i = 0; i < 3; ++i) r[i] += home_q_[i] * 2 * kPi / HG_ENC_COUNTS_PER_REV;
        return r;
    };
    const Vec3 qsr = qref(qs);
    const Mat3 J = jac(qsr), JiT = inv_t(J);
    Vec3 tau{}, F{}, taub{};
    for (int m = 0; m < 3; ++m) {
        tau[m] = trec[m] * nm_per_code;
        taub[m] = tbud[m] * nm_per_code;
    }
    for (int i = 0; i < 3; ++i)
        for (int m = 0; m < 3; ++m) F[i] += JiT[i][m] * tau[m];
    const Vec3 ps = fk(qsr);
    const double d = dot({p0_[0] - ps[0], p0_[1] - ps[1], p0_[2] - ps[2]}, nrm_);
    const double fmag = tk.drive ? wall_k_ * std::max(0.0, d) : 0.0;
    Vec3 err{};
    for (int i = 0; i < 3; ++i) err[i] = F[i] - nrm_[i] * fmag;
    const double en = std::sqrt(dot(err, err));
    const Vec3 qd = tr_.qdot(edge_time(ir.irq_edge));
    const double dq = std::sqrt(dot(qd, qd)) * 3e-6 + std::sqrt(3.0) * interp_cnt_ * 2 * kPi / HG_ENC_COUNTS_PER_REV;
    const double fbud = norm2(JiT) * std::sqrt(dot(taub, taub)) + wall_k_ * norm2(J) * dq + 1e-4 * fmag;
    max_ferr_ = std::max(max_ferr_, en);
    max_ferr_ratio_ = std::max(max_ferr_ratio_, en / fbud);
    n_force_++;
    if (fmag > 0) {
        n_wall_++;
        max_depth_ = std::max(max_depth_, d);
        max_force_ = std::max(max_force_, fmag);
        if (fmag > 10 * fbud) min_cos_ = std::min(min_cos_, dot(F, nrm_) / std::sqrt(dot(F, F)));
    } else {
        max_free_ = std::max(max_free_, std::sqrt(dot(F, F)));
    }
}

// The engine's records (ticks.bin), and beside them, row for row, the ISRs' edges and codes
// (isr.csv); every DAC load (loads.bin).
int ServoRun::write_outputs() {
    sc_.finish(outdir_);
    FILE* icsv = std::fopen((outdir_ + "/isr.csv").c_str(), "w");
    if (!icsv) { std::fprintf(stderr, "error: cannot write %s\n", outdir_.c_str()); return 3; }
    std::fprintf(icsv, "irq_edge,start,end,code0,code1,code2\n");
    for (const auto& r : isrs_)
        std::fprintf(icsv, "%llu,%llu,%llu,%d,%d,%d\n", static_cast<unsigned long long>(r.irq_edge),
                     static_cast<unsigned long long>(r.start), static_cast<unsigned long long>(r.end), r.code[0],
                     r.code[1], r.code[2]);
    std::fclose(icsv);
    std::vector<hg_dev::LoadRec> lrec;
    lrec.reserve(bench_.loads.size());
    for (const auto& ld : bench_.loads) lrec.push_back({static_cast<int64_t>(ld.edge), ld.addr, ld.code});
    hg_dev::write_file(outdir_, "loads.bin", lrec.data(), lrec.size() * sizeof(hg_dev::LoadRec));
    return 0;
}

// The safety reaction: per channel, the first load at or after the cause from which on every
// load is zero; and after the firmware latched its error, every channel zero one frame later.
void ServoRun::check_reaction() {
    bound_ = frame_ + HG_WR_CYCLES + 1;  // FRAME + WR_CYCLES + 1 (rtl/top/README.md)
    if (cause_edge_) {
        const int ch_lo = s_drop_ ? 2 * drop_axis_ : 0, ch_hi = s_drop_ ? 2 * drop_axis_ + 1 : 5;
        for (int c = ch_lo; c <= ch_hi; ++c) {
            uint64_t z = 0;
            for (const auto& ld : bench_.loads) {
                if (ld.addr != c) continue;
                if (ld.edge < cause_edge_) {
                    if (ld.edge + frame_ >= cause_edge_ && ld.code) nonzero_before_ = true;
                    continue;
                }
                if (ld.code != 0) z = 0;
                else if (!z) z = ld.edge;
            }
            reaction_ = z ? std::max<int64_t>(reaction_, static_cast<int64_t>(z - cause_edge_)) : INT64_MAX;
        }
    }
    for (size_t k = 0; k < sc_.ticks.size(); ++k)
        if (sc_.ticks[k].err != HG_ERR_NONE) { latch_edge_ = isrs_[k].end; break; }
    for (const auto& ld : bench_.loads)
        if (latch_edge_ && ld.edge > latch_edge_ + bound_ && ld.code) all_zero_after_latch_ = false;
}

// Every check's verdict: the failed ones, by name (printed as fail=...).
std::vector<std::string> ServoRun::verdict() {
    std::vector<std::string> fails;
    auto need = [&](bool ok, const char* what) { if (!ok) fails.emplace_back(what); };
    const uint32_t sticky = HG_STAT_WDOG | HG_STAT_CFG_ERR | HG_STAT_BUS_ERR | HG_STAT_PROTO_ERR;
    need(init_err_ == HG_ERR_NONE && (s_.fpga_id >> 16) == HG_ID_MAGIC, "init/ID");
    need(clk_khz_ == CLK_HZ / 1000, "CLK_KHZ");
    need(frame_timing_ok_ && !frames_.empty(), "DAC frame timing");
    need(bus_stats.not_oe == 0, "bus_data_oe low during a read");
    // the engine enables at the tick before the push start: after the sweep (3 ms before the push
    // start; cosim.load refuses a tick rate at which it would not be)
    const int64_t enable_g = scene0_us_ + std::llround(sc_.enable_t() * 1e6);
    need(sc_.is_enabled() && enable_g >= std::llround(tr_.t_home * 1e6), "homing/enable");
    need(max_terr_ratio_ <= 1.0, "torque reconstruction within budget");
    need(max_ferr_ratio_ <= 1.0, "force within budget");
    need(n_wall_ > 0 && max_depth_ > 0, "the trajectory penetrates the wall");
    double home_res = 0, home_qmax = 0;
    for (int i = 0; i < 3; ++i) {
        home_res = std::max(home_res, std::abs(home_err_[i] - home_q_[i]));
        home_qmax = std::max(home_qmax, std::abs(home_q_[i]));
    }
    need(home_res <= interp_cnt_ && home_qmax <= 256.0, "homing within one quadrant");
    if (home_qmax > 0) std::printf("warn=homing off by %.0f counts = one quadrant (interpolator index latch)\n", home_qmax);
    need(min_cos_ > 0.99, "force along the wall normal (out of the wall)");
    const uint8_t fw_err = s_.err, fw_axis = s_.err_axis;
    if (s_wall_) {
        need(fw_err == HG_ERR_NONE, "no latched firmware error");
        need((status_after_ & (sticky | HG_STAT_FAULT_ALL)) == 0, "no FPGA fault/sticky status");
        need((irq_reg_ & HG_IRQ_MISSED) == 0, "no missed tick");
        need(n_nonzero_ > 0, "motors driven");
    } else {
        need(cause_edge_ != 0, "safety cause happened");
        need(nonzero_before_, "torque non-zero just before the cause");
        need(reaction_ >= 0 && reaction_ <= static_cast<int64_t>(bound_), "zero torque within one frame");
        need(latch_edge_ != 0 && all_zero_after_latch_, "firmware latched an error and all torque is zero");
    }
    const uint64_t last_key = static_cast<uint64_t>(sc_.last_key_edge());   // the last key write that arrived
    if (s_wdog_) {
        need(fw_err == HG_ERR_WATCHDOG, "firmware error WATCHDOG");
        need((status_after_ & HG_STAT_WDOG) != 0, "STATUS.WDOG set");
        need(cause_edge_ > last_key && cause_edge_ - last_key <= 10000ULL * (CLK_HZ / 1000000) + 8,
             "expiry = last key + WDOG_TIMEOUT");
    }
    if (s_hang_) {
        need((status_after_ & HG_STAT_WDOG) != 0, "STATUS.WDOG set");
        need(fw_err != HG_ERR_NONE, "firmware refuses to drive after the hang");
    }
    if (s_drop_) {
        need(fw_err == HG_ERR_AXIS_FAULT && fw_axis == drop_axis_, "firmware error AXIS_FAULT on the dropped axis");
        need((status_after_ & HG_STAT_FAULT(drop_axis_)) != 0, "STATUS.FAULT set");
    }
    return fails;
}

// The shared summary (scene time simulated, records, firmware state, enable, watchdog key), then
// the co-simulation's own lines (cosim.py reads both), the failed checks and the result.
int ServoRun::report(const std::vector<std::string>& fails) {
    const uint64_t last_key = static_cast<uint64_t>(sc_.last_key_edge());
    hg_dev::print_summary({CLK_HZ, 7, run_.duration_s, wall_s_, cpu_s_, bench_.edge, frames_.size(), sc_.ticks.size(),
                           bench_.loads.size(), init_err_, s_.err, s_.err_axis, sc_.enable_t(), wdog_us_, last_key,
                           scene0_us_, dac_skew_, dac_frame_, kD});
    const double all_s = edge_time(bench_.edge);   // from reset: the homing sweep, then the scene
    const uint64_t tx = bus_stats.reads + bus_stats.writes;
    std::printf("scenario=%s rate_hz=%u setup=%d strobe=%d hold=%d ready=%d\n", scenario_.c_str(), run_.servo_hz,
                bus_timing.setup, bus_timing.strobe, bus_timing.hold, int(bus_timing.use_ready));
    std::printf("bus_reads=%llu bus_writes=%llu dropped=%llu tx_per_s=%.6g sim_per_wall=%.6g tq_limit=%u\n",
                static_cast<unsigned long long>(bus_stats.reads), static_cast<unsigned long long>(bus_stats.writes),
                static_cast<unsigned long long>(bus_stats.dropped), tx / wall_s_, all_s / wall_s_, tq_limit_[0]);
    std::printf("t_fault=%.9g seed=%llu powerup_deg=%.9g,%.9g,%.9g\n", s_wall_ ? 0.0 : t_fault_,
                static_cast<unsigned long long>(co_.seed), tr_.powerup[0] * 180 / kPi, tr_.powerup[1] * 180 / kPi,
                tr_.powerup[2] * 180 / kPi);
    std::printf("wall_k=%.9g wall_n=%.12g,%.12g,%.12g wall_p0=%.12g,%.12g,%.12g q_index=%.12g,%.12g,%.12g\n", wall_k_,
                nrm_[0], nrm_[1], nrm_[2], p0_[0], p0_[1], p0_[2], tr_.q_index[0], tr_.q_index[1], tr_.q_index[2]);
    std::printf("home_err_counts=%.3f,%.3f,%.3f interp_budget_counts=%.4f\n", home_err_[0], home_err_[1], home_err_[2],
                interp_cnt_);
    std::printf("torque_frames=%llu max_torque_err=%.6g max_torque_err_ratio=%.6g force_frames=%llu torn=%llu wall_frames=%llu "
                "max_force_err=%.6g max_force_err_ratio=%.6g max_free_force=%.6g max_depth=%.6g max_force=%.6g min_cos=%.9g\n",
                static_cast<unsigned long long>(n_tq_), max_terr_, max_terr_ratio_, static_cast<unsigned long long>(n_force_),
                static_cast<unsigned long long>(n_torn_), static_cast<unsigned long long>(n_wall_), max_ferr_,
                max_ferr_ratio_, max_free_, max_depth_, max_force_, min_cos_);
    std::printf("status=%u irq=%u fault_cmd_edge=%llu cause_edge=%llu reaction_clocks=%lld bound_clocks=%llu "
                "latch_edge=%llu post_hang_status_edge=%llu\n",
                status_after_, irq_reg_, static_cast<unsigned long long>(fault_edge_cmd_),
                static_cast<unsigned long long>(cause_edge_), static_cast<long long>(reaction_),
                static_cast<unsigned long long>(bound_), static_cast<unsigned long long>(latch_edge_),
                static_cast<unsigned long long>(post_hang_status_edge_));
    for (const auto& f : fails) std::printf("fail=%s\n", f.c_str());
    std::printf("result=%s\n", fails.empty() ? "PASS" : "FAIL");
    return fails.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    static hg_dev::RunCfg run;   // the scenario engine keeps a pointer to it
    std::string scenario, outdir;
    if (const int rc = configure(argc, argv, run, scenario, outdir)) return rc;
    if (run.cosim.bus_only) return bus_throughput(scenario, run.cosim.bus_pairs);
    // static: the HAL, the ISR and the scenario engine keep pointers into it until exit
    static ServoRun sr(run, scenario, outdir);
    int rc = sr.setup();
    if (rc == 0) rc = sr.simulate();
    if (rc != 0) return rc;
    sr.build_frames();
    if ((rc = sr.homing_error()) != 0) return rc;
    if ((rc = sr.check_frames()) != 0) return rc;
    if ((rc = sr.write_outputs()) != 0) return rc;
    sr.check_reaction();
    return sr.report(sr.verdict());
}
