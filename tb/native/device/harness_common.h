// SPDX-License-Identifier: Apache-2.0
// What the closed-loop harnesses share (device_harness.cpp: the Verilated gateware;
// model_harness.cpp: the golden models in its place; and the co-simulation,
// tb/native/cosim/cosim_harness.cpp): the run configuration and its parser, the
// fault kinds, the record layouts (hapgate.runners.records), the scenario engine
// (faults, the DSP's hang, ISR records, enable at scene time 0, progress, summary), the
// firmware's bring-up and its background steps, and the output files. Description: README.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

extern "C" {
#include "hg_bringup.h"
#include "hg_fpga_regs.h"
#include "hg_servo.h"
}
#include "plant.h"

namespace hg_dev {

constexpr double kPi = 3.14159265358979323846;

// ------------------------------------------------------------------ fault kinds
// The scene's [[fault]] kinds a harness simulates, by the scene's own names: the run
// configuration names them (`fault = AT_S NAME AXIS`), the live view reports them by name, and
// tb/device/test_record_layout.py checks this list against hapgate.device.harness.HARNESS_FAULTS.
enum class FaultKind : int { dropout, hang, watchdog, seu, stuck };
struct FaultKindName { FaultKind kind; const char* name; };
constexpr FaultKindName kFaultKinds[] = {
    {FaultKind::dropout, "dropout"},     // the axis's ADC codes are 0 from at_s on
    {FaultKind::hang, "hang"},           // the DSP stops calling its ISR (README "Faults")
    {FaultKind::watchdog, "watchdog"},   // every watchdog key write is lost
    // injections into the gateware's own flip-flops (fault_inject.h; only the device harness
    // built on the saboteur netlist, HG_FI, simulates them): `fault = AT_S seu SITE` flips
    // site SITE's flip-flop once; `fault = AT_S stuck SITE VALUE FRAMES` holds its output at
    // VALUE (0, 1) for FRAMES DAC frames
    {FaultKind::seu, "seu"},
    {FaultKind::stuck, "stuck"},
};
// An injection into a flip-flop (seu, stuck) rather than a fault of the world around the FPGA.
constexpr bool is_injection(FaultKind k) { return k == FaultKind::seu || k == FaultKind::stuck; }
inline const char* fault_name(FaultKind k) {
    for (const auto& f : kFaultKinds)
        if (f.kind == k) return f.name;
    return "?";
}
// The kind named `name`; false if there is none.
inline bool fault_kind_of(const std::string& name, FaultKind* k) {
    for (const auto& f : kFaultKinds)
        if (name == f.name) {
            *k = f.kind;
            return true;
        }
    return false;
}

// ------------------------------------------------------------------ run configuration
struct RunCfg {
    double duration_s = 0.1;
    uint32_t servo_hz = 1000;
    int env_kind = 0;
    double env_p[3] = {0, 0, 0}, env_n[3] = {0, 0, 0}, env_k = 0, env_b = 0, env_ki = 0;
    double q0[3] = {0, 0, 0};
    double qd0[3] = {0, 0, 0};              // rad/s at release (scene time 0)
    double q_index[3] = {0, 0, 0};
    // power-up: from reset to scene time 0 a fixture holds the handle in the start pose q0 (the
    // firmware's reference pose); the firmware powers up there (RESTART with a stored
    // calibration, none without one: README "Power-up")
    double t_hold_s = 9.1e-3;
    int comm_err[3] = {0, 0, 0};
    // the firmware's calibration (scene.calib): per axis flags, enc_dir, phases_swapped,
    // pole_pairs, index_to_zero, comm_offset (hg_axis_calib_t); without it (calib_seen 0) the
    // truth of a forward encoder at q_index, as before
    int64_t calib[18] = {0};
    int calib_seen = 0;
    int64_t pc_force_timeout_ticks = -1;    // -1: the firmware's default
    // bring-up's guided move (scene hand.guided): t dx dy dz per point, from the start of a
    // GUIDED step and the endpoint there; empty: the hand stays as configured during bring-up
    std::vector<double> guided;
    uint32_t hold_pos_homed[3] = {0, 0, 0}, hold_index_pos[3] = {0, 0, 0}, hold_index_count[3] = {0, 0, 0};
    uint32_t record = 0xFF;                 // bit 0 plant (q,p,f_hand,tau,current), bit 1 dac, bit 2 adc
    double progress_s = 0.05;               // progress line every this much simulated time
    int view_fd = -1, ctl_fd = -1;          // the live view's pipes (view_link.h; device harness only)
    double view_period_s = 0.02;            // its telemetry period, simulated time
    struct Fault {
        double at_s; FaultKind kind; int axis;
        int site = -1, value = 0, frames = 0;   // seu, stuck: the flip-flop site, stuck value, frames
    };
    std::vector<Fault> faults;              // (the axis matters for a dropout only)
    // soc fidelity only (device_harness.cpp built with HG_SOC): the RAM addresses of the
    // firmware's tick observation, its link counters and its handler's longest cycle count
    // (dsp-fw/board/riscv/soc.h soc_tick_obs, hg_board_link_stats, soc_isr_cycles_max)
    uint32_t soc_obs[3] = {0, 0, 0};
    int soc_obs_seen = 0;
    // model fidelity only (model_harness.cpp); the Verilated harness refuses them
    int mech_us = 0;                        // mechanics step, us (0: the plant's own dt_s)
    int axis_mask = 7;                      // axes built (the RTL's AXIS_MASK)
    uint32_t clk_hz = 0;                    // the clock the records' edges count
    double dac_load[2] = {-1, -1};          // frame start -> channel 0 load edge, write strobe clocks
    int dac_load_seen = 0;                  // (model key dac_load = LOAD_CLOCKS WR_CYCLES)
    std::vector<double> asin_lut, sine_rom; // interpolator and commutation tables
    std::vector<double> regs;               // word, reset, write mask, range min, max (-1: none) per register
    int vel_log2w = 8, amp_min = 40, amp_max = 170, loss_samples = 16, lut_bits = 7;
    int coarse = 0;
    // co-simulation only (cosim_harness.cpp, keys cosim_*; the others refuse them): its scripted
    // hand, its check's reference wall and bus master (tb/native/cosim/README.md "Scenes"). There,
    // scene time 0 is the start of the push, q0 the free pose, env_* the firmware's wall.
    struct Cosim {
        int bus_only = 0;                       // cosim_kind: 0 the servo run, 1 bus throughput
        uint32_t bus_pairs = 200000;            // cosim_bus_pairs: SCRATCH write/read-back pairs
        int bus[4] = {1, 5, 2, 0};              // cosim_bus: setup strobe hold use_ready (clocks)
        double q_deep[3] = {0, 0, 0};           // cosim_q_deep: the pose pushed to, rad
        double t_in = 0.1, t_hold = 0.02;       // cosim_push: raised cosine in (and back), held, s
        double wall_at = 0.45;                  // cosim_wall_at: the check's wall plane from free (0) to deep (1)
        double wall_k = 0;                      // cosim_wall_k: the check's wall stiffness, N/m (the firmware's: env_*)
        uint64_t seed = 1;                      // cosim_seed: the power-up positions
    } cosim;
};

// Which keys a harness accepts besides the common ones.
enum class Keys { device, model, cosim };

// Parse "key = v1 v2 ..." lines; false and a reason on an unknown key or a wrong count.
// `keys`: also accept the model-fidelity (or the co-simulation's) keys.
bool parse_run(const std::string& text, RunCfg& c, std::string& err, Keys keys);
inline bool parse_run(const std::string& text, RunCfg& c, std::string& err, bool model_keys) {
    return parse_run(text, c, err, model_keys ? Keys::model : Keys::device);
}
std::string slurp(const char* path);

// ------------------------------------------------------------------ records
// Read by numpy as hapgate.runners.records FRAME_DT / TICK_DT / LOAD_DT; tb/device/test_record_layout.py
// compares the two field by field (record_layout.cpp prints this side).
struct FrameRec {         // one per DAC frame (16 us), sampled at the frame's grid start
    double t;             // scene time, s
    double q[3], p[3], f_hand[3], tau[3], i_ab[6];
    double energy;        // J: kinetic (+ hand spring)
    int16_t dac[6];       // the codes loaded in this frame
    int16_t pad;
    uint32_t pad2;
};
struct TickRec {          // one per ISR call
    double t;             // scene time of the tick (irq), s
    double q_fw[3];       // firmware joint angles (its snapshot)
    double q_true[3];     // true joint angles of the sample the snapshot holds
    double p_fw[3], f_fw[3], tau_fw[3];
    int32_t pos_err[3];   // snapshot counts minus true counts (homed frame)
    int32_t pos[3];       // the snapshot's positions (POS registers), counts
    uint32_t status;
    uint8_t err, err_axis, drive, pad;
};
struct LoadRec { int64_t edge; int32_t ch; int32_t code; };

// The firmware's record of one ISR call at scene time t; q_true: the snapshot's true angles.
TickRec tick_record(const hg_servo_t& s, double t, const double q_true[3]);

// The plant's record of the DAC frame starting at scene time t (the plant fields only with record
// bit 0; the codes are added when the frame's last channel loads).
FrameRec frame_record(const hg_plant_out& o, double t, uint32_t record);

// Write one file into outdir (exit 3 if it cannot be written).
void write_file(const std::string& outdir, const std::string& name, const void* data, size_t bytes);

// A record file written as the run goes, through a fixed buffer: growing whole-run vectors cost
// ~15 % of a run in page faults and copies on this machine. back() is the newest record (kept in
// the buffer: a flush happens before a push, never after).
template <typename T>
class RecordFile {
public:
    void open(const std::string& path) {
        f_ = std::fopen(path.c_str(), "wb");
        if (!f_) { std::fprintf(stderr, "error: cannot write %s\n", path.c_str()); std::exit(3); }
        buf_.reserve(kChunk);
    }
    void push(const T& r) {
        if (buf_.size() == kChunk) flush();
        buf_.push_back(r);
        ++n_;
    }
    T& back() { return buf_.back(); }
    bool empty() const { return n_ == 0; }
    size_t size() const { return n_; }
    void close() {
        flush();
        if (f_ && std::fclose(f_) != 0) { std::fprintf(stderr, "error: writing a record file failed\n"); std::exit(3); }
        f_ = nullptr;
    }
private:
    static constexpr size_t kChunk = 4096;
    void flush() {
        if (f_ && !buf_.empty()) std::fwrite(buf_.data(), sizeof(T), buf_.size(), f_);
        buf_.clear();
    }
    FILE* f_ = nullptr;
    std::vector<T> buf_;
    size_t n_ = 0;
};

// A progress line on stderr (runner._progress_reader): scene time t, s.
void progress_line(double t);

// ------------------------------------------------------------------ the scenario engine
// What a run does besides simulating the device, shared by both harnesses, each calling it at its
// own granularity (the Verilated harness after clock edges, the model harness at the events
// next_edge() names): the scene's faults, the DSP's hang and resumption, the lost watchdog key,
// the ISR records, the firmware's background enable at scene time 0, progress lines and the
// summary. Times are grid points (1 us) and clock edges since reset (d clocks per grid point).
class Scenario {
public:
    void start(const RunCfg& cfg, int64_t scene0_us, int64_t d, bool wait_homed = false);
    int64_t scene0() const { return scene0_; }
    double scene_t(int64_t g) const { return (static_cast<double>(g) - static_cast<double>(scene0_)) * 1e-6; }

    // At grid point g: a progress line when due, and every fault due that was not yet: the
    // engine applies hang and watchdog itself, then calls apply(fault) (a dropout's signal, the
    // live view's event).
    template <typename F>
    void at_grid(int64_t g, F&& apply) {
        if (g >= next_progress_) {
            progress_line(scene_t(g));
            next_progress_ += static_cast<int64_t>(cfg_->progress_s * 1e6);
        }
        for (size_t k = 0; k < faults_.size(); ++k) {
            if (faults_[k].on || g < faults_[k].g) continue;
            faults_[k].on = true;
            const RunCfg::Fault& f = faults_[k].f;
            if (f.kind == FaultKind::hang) hang_ = true;
            if (f.kind == FaultKind::watchdog) drop_wdog_ = true;
            apply(f);
        }
    }
    // The earliest edge, after none, at which at_grid() or isr_due() has something to do.
    int64_t next_edge() const {
        int64_t c = next_progress_ * d_;
        for (const auto& f : faults_)
            if (!f.on) c = std::min(c, f.g * d_);
        if (hang_ && !resumed_ && hang_expiry_edge_) c = std::min(c, hang_expiry_edge_ + kResumeUs * d_);
        return c;
    }

    // The HAL's side: a write the scene's watchdog fault loses, and the edge of each key write.
    bool write_lost(uint32_t addr) const { return drop_wdog_ && addr == HG_REG_WDOG; }
    void key_written(int64_t edge) { last_key_edge_ = edge; }
    int64_t last_key_edge() const { return last_key_edge_; }
    bool hanging() const { return hang_; }
    bool resumed() const { return resumed_; }

    // Does the firmware's ISR run at this edge? rose: the interrupt rose since the last call;
    // irq: its level now. While the DSP hangs nothing runs; kResumeUs after the watchdog's
    // expiry it comes back and services the pending interrupt (the firmware must refuse to drive).
    bool isr_due(bool rose, int64_t edge, bool irq, uint32_t wdog_us) {
        if (!hang_ || resumed_) return rose;
        if (!hang_expiry_edge_) hang_expiry_edge_ = last_key_edge_ + static_cast<int64_t>(wdog_us) * d_;
        if (edge >= hang_expiry_edge_ + kResumeUs * d_) {
            resumed_ = true;
            return irq;
        }
        return false;
    }

    // What the background loop does after an ISR call (after_isr).
    enum class Bg { none, power_up, scene };
    // After an ISR call at grid point tick_g (the snapshot's true angles q_true): its record, and
    // the background loop's next step, each once: power_up when the servo has taken
    // HG_BU_POWER_UP_TICKS ticks (board.c's main loop: the snapshot has settled; the harness
    // then runs hg_dev::fw_power_up), scene at the tick before scene time 0 (the scene's start:
    // its enable unless a PC link enables). The co-simulation (wait_homed in start()) instead
    // waits for every axis to show homed after its scripted sweep, and has no power_up step.
    Bg after_isr(const hg_servo_t& s, int64_t tick_g, const double q_true[3]) {
        ticks.push_back(tick_record(s, scene_t(tick_g), q_true));
        if (enabled_) return Bg::none;
        if (!powered_) {
            const uint32_t homed = HG_STAT_HOMED(0) | HG_STAT_HOMED(1) | HG_STAT_HOMED(2);
            powered_ = wait_homed_ ? (s.status & homed) == homed : s.steps >= HG_BU_POWER_UP_TICKS;
            return powered_ && !wait_homed_ ? Bg::power_up : Bg::none;
        }
        return tick_g >= scene0_ - 1000000 / static_cast<int64_t>(cfg_->servo_hz) ? Bg::scene : Bg::none;
    }
    void enabled(double t) { enabled_ = true; enable_t_ = t; }
    bool is_enabled() const { return enabled_; }
    double enable_t() const { return enable_t_; }

    std::vector<TickRec> ticks;             // ticks.bin (finish())
    void finish(const std::string& outdir) const;

private:
    static constexpr int64_t kResumeUs = 2000;   // the hung DSP resumes 2 ms after the expiry
    static constexpr int64_t kNoProgress = int64_t(1) << 50;   // grid point (progress_s <= 0: none)
    struct Due { int64_t g; RunCfg::Fault f; bool on; };
    const RunCfg* cfg_ = nullptr;
    int64_t d_ = 6, scene0_ = 0, next_progress_ = 0;
    std::vector<Due> faults_;
    bool hang_ = false, resumed_ = false, drop_wdog_ = false, powered_ = false, enabled_ = false,
         wait_homed_ = false;
    int64_t hang_expiry_edge_ = 0, last_key_edge_ = 0;
    double enable_t_ = NAN;
};

// The run's summary lines on stdout (key=value, read by runner.simulate); cpu_s: the process's
// CPU time of the run (std::clock, the machine is shared: the real-time factor on a free core).
struct Summary {
    uint32_t clk_hz; int axis_mask; double sim_s, wall_s, cpu_s; uint64_t clocks;
    size_t frames, ticks, loads;
    unsigned init_err, fw_err, fw_err_axis; double enabled_t; uint32_t wdog_us;
    uint64_t last_key_edge; int64_t scene0_us; uint32_t skew, frame; uint64_t d;
};
void print_summary(const Summary& s);

// ------------------------------------------------------------------ the firmware
// Its configuration for this run (rate, clock, encoder zero at the index, commutation offset
// errors, PC-force timeout).
void fw_config(const RunCfg& cfg, uint32_t clk_hz, hg_servo_cfg_t* fw);
// Bring-up on the virtual device: the reference pose is the scene's start pose (where the
// fixture holds the handle from reset), the bounds those of the linkage (dsp-fw/README.md,
// "Bring-up": a partial alignment scan inside the walls).
void fw_bringup_config(const RunCfg& cfg, hg_bringup_cfg_t* bc);
// The background loop's power-up, as board.c's main loop does it once the snapshot has settled
// (Scenario::Bg::power_up): bring-up bound to the servo with the stored calibration (the run
// configuration's, if the servo starts calibrated), hg_bringup_power_up (RESTART in the
// reference pose: no motion, no index; without a calibration nothing, bring-up homes), the
// scene's environment (env_* keys). 0, or the harness's exit code 3.
int fw_power_up(hg_servo_t* s, hg_bringup_t* bu, const RunCfg& cfg, const hg_calib_t* stored);
// Before hg_servo_init: the calibration fw_config put in fw becomes the stored one (the
// board's flash: true if every axis of it is homed and aligned), and the servo starts
// unhomed (HG_CAL_HOMED cleared: ENABLE and forces refused until the power-up homes it).
bool fw_store_calib(hg_servo_cfg_t* fw, hg_calib_t* stored);
// The co-simulation's background step after its scripted homing sweep: home every axis on
// IDX_POS, set the scene's environment, enable. 0, or the harness's exit code 3.
int fw_home_scene_enable(hg_servo_t* s, const RunCfg& cfg, bool enable);

}  // namespace hg_dev
