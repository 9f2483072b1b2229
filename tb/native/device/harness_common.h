// SPDX-License-Identifier: Apache-2.0
// What the two closed-loop harnesses share (device_harness.cpp: the Verilated gateware;
// model_harness.cpp: the golden models in its place): the run configuration and its parser, the
// record layouts (runner.FRAME_DT / TICK_DT / LOAD_DT), the firmware's bring-up and its
// background steps (homing, scene, enable), and the output files. Description: README.md.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

extern "C" {
#include "hg_bringup.h"
#include "hg_servo.h"
}

namespace hg_dev {

constexpr double kPi = 3.14159265358979323846;

// ------------------------------------------------------------------ run configuration
struct RunCfg {
    double duration_s = 0.1;
    uint32_t servo_hz = 1000;
    int env_kind = 0;
    double env_p[3] = {0, 0, 0}, env_n[3] = {0, 0, 0}, env_k = 0, env_b = 0, env_ki = 0;
    double q0[3] = {0, 0, 0};
    double qd0[3] = {0, 0, 0};              // rad/s at release (scene time 0)
    double q_index[3] = {0, 0, 0};
    double sweep_rad = 0.5 * kPi / 180.0;   // homing sweep, ends at q0, index half-way
    double t_sweep_s = 6e-3, t_settle_s = 3e-3;
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
    struct Fault { double at_s; int kind; int axis; };
    std::vector<Fault> faults;              // kind: 1 dropout, 2 hang, 3 watchdog
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
};

// Parse "key = v1 v2 ..." lines; false and a reason on an unknown key or a wrong count.
// `model_keys`: also accept the model-fidelity keys.
bool parse_run(const std::string& text, RunCfg& c, std::string& err, bool model_keys);
std::string slurp(const char* path);

// ------------------------------------------------------------------ records
// Read by numpy as hapgate.device.harness FRAME_DT / TICK_DT / LOAD_DT; tb/device/test_record_layout.py
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

// Write frames.bin, ticks.bin, loads.bin and adc.bin into outdir (exit 3 if one cannot be).
void write_records(const std::string& outdir, const std::vector<FrameRec>& frames,
                   const std::vector<TickRec>& ticks, const std::vector<LoadRec>& loads,
                   const std::vector<int8_t>& adc);

// The homing sweep (README "Homing"): every joint's pose t s after reset, a raised cosine that
// starts at t_sweep0 and ends at rest on q0.
void homing_pose(const RunCfg& cfg, double t_sweep0, double t, double q[3], double qd[3]);

// The run's summary lines on stdout (key=value, read by runner.simulate); cpu_s: the process's
// CPU time of the run (std::clock, the machine is shared: the real-time factor on a free core).
struct Summary {
    uint32_t clk_hz; int axis_mask; double sim_s, wall_s, cpu_s; uint64_t clocks;
    size_t frames, ticks, loads;
    unsigned init_err, fw_err, fw_err_axis; double enabled_t; uint32_t wdog_us;
    uint64_t last_key_edge; int64_t scene0_us; uint32_t skew, frame; uint64_t d;
};
void print_summary(const Summary& s);
// A progress line on stderr (runner._progress_reader): scene time t, s.
void progress_line(double t);

// ------------------------------------------------------------------ the firmware
// Its configuration for this run (rate, clock, encoder zero at the index, commutation offset
// errors, PC-force timeout).
void fw_config(const RunCfg& cfg, uint32_t clk_hz, hg_servo_cfg_t* fw);
// Bring-up on the virtual device: the reference pose is the scene's start pose (where the
// homing sweep ends: call this there), the bounds those of the linkage (dsp-fw/README.md,
// "Bring-up": a partial alignment scan inside the walls).
void fw_bringup_config(const RunCfg& cfg, hg_bringup_cfg_t* bc);
// The background loop's bring-up after homing: home every axis on IDX_POS (bus reads), set the
// scene's environment, enable (unless a PC link enables, or the firmware is not calibrated:
// then its forces stay off until a calibration arrives). 0, or the harness's exit code 3.
int fw_home_scene_enable(hg_servo_t* s, const RunCfg& cfg, bool enable);

}  // namespace hg_dev
