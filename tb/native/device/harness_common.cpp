// SPDX-License-Identifier: Apache-2.0
// Shared by device_harness.cpp and model_harness.cpp: run configuration, records, firmware
// bring-up (harness_common.h).
#include "harness_common.h"

#ifndef HG_SOC
#define HG_SOC 0
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

extern "C" {
#include "hg_fpga_regs.h"
#include "hg_hal.h"
}

namespace hg_dev {

// "fault = AT_S KIND AXIS" (KIND by name, kFaultKinds); the injections (device harness only):
// "fault = AT_S seu SITE", "fault = AT_S stuck SITE VALUE FRAMES"
static bool parse_fault(const std::string& rest, RunCfg& c, std::string& err, bool injections) {
    std::istringstream vs(rest);
    double at = 0;
    std::string name, extra;
    int axis = 0;
    FaultKind k{};
    if (!(vs >> at >> name)) err = "fault: expected AT_S KIND ...";
    else if (!fault_kind_of(name, &k)) err = "fault: unknown kind " + name;
    else if (is_injection(k)) {
        RunCfg::Fault f{at, k, 0};
        const bool stuck = k == FaultKind::stuck;
        if (!injections) err = "fault: " + name + " needs the device harness";
        else if (!(vs >> f.site) || (stuck && !(vs >> f.value >> f.frames)) || (vs >> extra))
            err = stuck ? "fault: expected AT_S stuck SITE VALUE FRAMES" : "fault: expected AT_S seu SITE";
        else if (f.site < 0 || (stuck && (f.value < 0 || f.value > 1 || f.frames < 1)))
            err = "fault: " + name + ": site >= 0, value 0 or 1, frames >= 1";
        else c.faults.push_back(f);
    }
    else if (!(vs >> axis) || (vs >> extra)) err = "fault: expected AT_S KIND AXIS";
    else if (axis < 0 || axis > 2) err = "fault: axis must be 0, 1 or 2";
    else c.faults.push_back({at, k, axis});
    return err.empty();
}

bool parse_run(const std::string& text, RunCfg& c, std::string& err, Keys keys) {
    const bool model_keys = keys == Keys::model, cosim_keys = keys == Keys::cosim;
    RunCfg::Cosim& co = c.cosim;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        const auto eq = line.find('=');
        if (line.empty() || line[0] == '#' || eq == std::string::npos) continue;
        std::string key = line.substr(0, eq);
        key.erase(key.find_last_not_of(" \t") + 1);
        if (key == "fault") {
            if (!parse_fault(line.substr(eq + 1), c, err, keys == Keys::device)) return false;
            continue;
        }
        std::istringstream vs(line.substr(eq + 1));
        std::vector<double> v;
        double x;
        while (vs >> x) v.push_back(x);
        auto need = [&](size_t n) {
            if (v.size() != n) err = key + ": expected " + std::to_string(n) + " values";
            return v.size() == n;
        };
        if (key == "duration_s" && need(1)) c.duration_s = v[0];
        else if (key == "servo_hz" && need(1)) c.servo_hz = static_cast<uint32_t>(v[0]);
        else if (key == "env_kind" && need(1)) c.env_kind = static_cast<int>(v[0]);
        else if (key == "env_point" && need(3)) std::copy(v.begin(), v.end(), c.env_p);
        else if (key == "env_normal" && need(3)) std::copy(v.begin(), v.end(), c.env_n);
        else if (key == "env_k" && need(1)) c.env_k = v[0];
        else if (key == "env_b" && need(1)) c.env_b = v[0];
        else if (key == "env_ki" && need(1)) c.env_ki = v[0];
        else if (key == "q0" && need(3)) std::copy(v.begin(), v.end(), c.q0);
        else if (key == "qd0" && need(3)) std::copy(v.begin(), v.end(), c.qd0);
        else if (key == "q_index" && need(3)) std::copy(v.begin(), v.end(), c.q_index);
        else if (key == "t_hold_s" && need(1)) c.t_hold_s = v[0];
        else if (key == "pc_force_timeout_ticks" && need(1)) c.pc_force_timeout_ticks = static_cast<int64_t>(v[0]);
        else if (key == "comm_err" && need(3)) for (int i = 0; i < 3; ++i) c.comm_err[i] = static_cast<int>(v[i]);
        else if (key == "calib" && need(18)) {
            for (int i = 0; i < 18; ++i) c.calib[i] = static_cast<int64_t>(v[i]);
            c.calib_seen = 1;
        }
        else if (key == "hold_pos_homed" && need(3)) for (int i = 0; i < 3; ++i) c.hold_pos_homed[i] = static_cast<uint32_t>(static_cast<int64_t>(v[i]));
        else if (key == "hold_index_pos" && need(3)) for (int i = 0; i < 3; ++i) c.hold_index_pos[i] = static_cast<uint32_t>(static_cast<int64_t>(v[i]));
        else if (key == "hold_index_count" && need(3)) for (int i = 0; i < 3; ++i) c.hold_index_count[i] = static_cast<uint32_t>(v[i]);
        else if (key == "guided") {
            if (v.empty() || v.size() % 4 != 0) err = key + ": expected groups of 4 values (t dx dy dz)";
            else c.guided = v;
        }
        else if (key == "record" && need(1)) c.record = static_cast<uint32_t>(v[0]);
        else if (key == "progress_s" && need(1)) c.progress_s = v[0];
        else if (key == "view_fd" && need(1)) c.view_fd = static_cast<int>(v[0]);
        else if (key == "ctl_fd" && need(1)) c.ctl_fd = static_cast<int>(v[0]);
        else if (key == "view_period_s" && need(1)) c.view_period_s = v[0];
        else if (keys == Keys::device && key == "soc_obs" && need(3)) {
            for (int i = 0; i < 3; ++i) c.soc_obs[i] = static_cast<uint32_t>(v[i]);
            c.soc_obs_seen = 1;
        }
        else if (model_keys && key == "mech_us" && need(1)) c.mech_us = static_cast<int>(v[0]);
        else if (model_keys && key == "axis_mask" && need(1)) c.axis_mask = static_cast<int>(v[0]);
        else if (model_keys && key == "clk_hz" && need(1)) c.clk_hz = static_cast<uint32_t>(v[0]);
        else if (model_keys && key == "dac_load" && need(2)) {
            c.dac_load[0] = v[0]; c.dac_load[1] = v[1]; ++c.dac_load_seen;
        }
        else if (model_keys && key == "asin_lut") c.asin_lut = v;
        else if (model_keys && key == "sine_rom") c.sine_rom = v;
        else if (model_keys && key == "reg" && need(5)) c.regs.insert(c.regs.end(), v.begin(), v.end());
        else if (model_keys && key == "interp" && need(6)) {
            c.lut_bits = static_cast<int>(v[0]); c.vel_log2w = static_cast<int>(v[1]);
            c.amp_min = static_cast<int>(v[2]); c.amp_max = static_cast<int>(v[3]);
            c.loss_samples = static_cast<int>(v[4]); c.coarse = static_cast<int>(v[5]);
        }
        else if (cosim_keys && key == "cosim_kind" && need(1)) co.bus_only = static_cast<int>(v[0]);
        else if (cosim_keys && key == "cosim_bus_pairs" && need(1)) co.bus_pairs = static_cast<uint32_t>(v[0]);
        else if (cosim_keys && key == "cosim_bus" && need(4)) for (int i = 0; i < 4; ++i) co.bus[i] = static_cast<int>(v[i]);
        else if (cosim_keys && key == "cosim_q_deep" && need(3)) std::copy(v.begin(), v.end(), co.q_deep);
        else if (cosim_keys && key == "cosim_push" && need(2)) { co.t_in = v[0]; co.t_hold = v[1]; }
        else if (cosim_keys && key == "cosim_wall_at" && need(1)) co.wall_at = v[0];
        else if (cosim_keys && key == "cosim_wall_k" && need(1)) co.wall_k = v[0];
        else if (cosim_keys && key == "cosim_seed" && need(1)) co.seed = static_cast<uint64_t>(v[0]);
        else if (err.empty()) err = "unknown key " + key;
        if (!err.empty()) return false;
    }
    return true;
}

std::string slurp(const char* path) {
    std::ifstream f(path);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

TickRec tick_record(const hg_servo_t& s, double t, const double q_true[3]) {
    TickRec r{};
    r.t = t;
    r.status = s.status;
    r.err = s.err;
    r.err_axis = s.err_axis;
    r.drive = s.enabled && s.err == HG_ERR_NONE;
    for (int i = 0; i < 3; ++i) {
        r.q_fw[i] = s.q[i];
        r.q_true[i] = q_true[i];
        r.p_fw[i] = s.p[i];
        r.f_fw[i] = s.f[i];
        r.tau_fw[i] = s.tau[i];
        const double cpr = HG_ENC_COUNTS_PER_REV;
        r.pos_err[i] = static_cast<int32_t>(std::lround((s.q[i] - r.q_true[i]) / (2 * kPi) * cpr));
        r.pos[i] = s.pos[i];
    }
    return r;
}

FrameRec frame_record(const hg_plant_out& o, double t, uint32_t record) {
    FrameRec r{};
    r.t = t;
    if (record & 1) {
        for (int i = 0; i < 3; ++i) {
            r.q[i] = o.q[i]; r.p[i] = o.p[i]; r.f_hand[i] = o.f_hand[i]; r.tau[i] = o.tau[i];
        }
        for (int i = 0; i < 6; ++i) r.i_ab[i] = o.i_ab[i];
        r.energy = o.energy;
    }
    return r;
}

void Scenario::start(const RunCfg& cfg, int64_t scene0_us, int64_t d, bool wait_homed) {
    cfg_ = &cfg;
    wait_homed_ = wait_homed;
    d_ = d;
    scene0_ = scene0_us;
    next_progress_ = cfg.progress_s > 0 ? scene0_us : kNoProgress;
    for (const auto& f : cfg.faults) faults_.push_back({scene0_us + std::llround(f.at_s * 1e6), f, false});
    ticks.reserve(static_cast<size_t>(std::min(cfg.duration_s * cfg.servo_hz, 1048576.0)) + 64);   // (served: a cap)
}

void Scenario::finish(const std::string& outdir) const {
    write_file(outdir, "ticks.bin", ticks.data(), ticks.size() * sizeof(TickRec));
}

void write_file(const std::string& outdir, const std::string& name, const void* data, size_t bytes) {
    FILE* f = std::fopen((outdir + "/" + name).c_str(), "wb");
    if (!f) { std::fprintf(stderr, "error: cannot write %s/%s\n", outdir.c_str(), name.c_str()); std::exit(3); }
    if (bytes) std::fwrite(data, 1, bytes, f);
    if (std::fclose(f) != 0) { std::fprintf(stderr, "error: writing %s/%s failed\n", outdir.c_str(), name.c_str()); std::exit(3); }
}

void print_summary(const Summary& s) {
    std::printf("clk_hz=%u axis_mask=%d sim_s=%.9g wall_s=%.6g cpu_s=%.6g clocks=%llu frames=%zu ticks=%zu loads=%zu\n",
                s.clk_hz, s.axis_mask, s.sim_s, s.wall_s, s.cpu_s, static_cast<unsigned long long>(s.clocks), s.frames,
                s.ticks, s.loads);
    std::printf("init_err=%u fw_err=%u fw_err_axis=%u enabled_t=%.9g wdog_us=%u last_key_edge=%llu scene0_us=%lld "
                "skew=%u frame=%u d=%llu\n",
                s.init_err, s.fw_err, s.fw_err_axis, s.enabled_t, s.wdog_us,
                static_cast<unsigned long long>(s.last_key_edge), static_cast<long long>(s.scene0_us), s.skew,
                s.frame, static_cast<unsigned long long>(s.d));
    std::printf("frame_bytes=%zu tick_bytes=%zu\n", sizeof(FrameRec), sizeof(TickRec));
}

void progress_line(double t) {
    std::fprintf(stderr, "progress %.6f\n", t);
    std::fflush(stderr);
}

#if !HG_SOC   // the soc fidelity runs the firmware on its CPU: none of it here
void fw_config(const RunCfg& cfg, uint32_t clk_hz, hg_servo_cfg_t* fw) {
    hg_servo_default_cfg(fw);
    fw->rate_hz = cfg.servo_hz;
    fw->fpga_clk_hz = clk_hz;
    for (int i = 0; i < 3; ++i) {
        hg_axis_calib_t& a = fw->cal.axis[i];
        if (cfg.calib_seen) {
            const int64_t* w = cfg.calib + 6 * i;
            a.flags = static_cast<uint8_t>(w[0]);
            a.enc_dir = static_cast<int8_t>(w[1]);
            a.phases_swapped = static_cast<uint8_t>(w[2]);
            a.pole_pairs = static_cast<uint8_t>(w[3]);
            a.index_to_zero = static_cast<int32_t>(w[4]);
            a.comm_offset = static_cast<uint32_t>(w[5]);
        } else {
            a.index_to_zero = static_cast<int32_t>(std::lround(-cfg.q_index[i] / (2 * kPi) * HG_ENC_COUNTS_PER_REV));
        }
        // the scene's deliberate commutation error (firmware.comm_offset_error_counts)
        if (a.flags & HG_CAL_ALIGNED) a.comm_offset = static_cast<uint32_t>(a.comm_offset + cfg.comm_err[i]) & 1023u;
    }
    if (cfg.pc_force_timeout_ticks >= 0) fw->pc_force_timeout = static_cast<uint32_t>(cfg.pc_force_timeout_ticks);
}

void fw_bringup_config(const RunCfg& cfg, hg_bringup_cfg_t* bc) {
    hg_bringup_default_cfg(bc);
    for (int i = 0; i < 3; ++i) bc->q_ref[i] = static_cast<hg_real>(cfg.q0[i]);
    bc->align_cycles = HG_C(0.5);    // (0.5 + 0.5) cycles at 2 pole pairs: pi rad planned
    bc->align_rate = HG_C(0.25);     // slow: the linkage's coupled joints lag less
    bc->travel_max = HG_C(3.2);
}

namespace {
int set_scene(hg_servo_t* s, const RunCfg& cfg) {
    hg_scene_t sc{};
    sc.type = static_cast<uint8_t>(cfg.env_kind);
    for (int i = 0; i < 3; ++i) {
        sc.p0[i] = static_cast<hg_real>(cfg.env_p[i]);
        sc.n[i] = static_cast<hg_real>(cfg.env_n[i]);
    }
    sc.k = static_cast<hg_real>(cfg.env_k);
    sc.b = static_cast<hg_real>(cfg.env_b);
    sc.ki = static_cast<hg_real>(cfg.env_ki);
    return hg_servo_set_scene(s, &sc);
}
}  // namespace

bool fw_store_calib(hg_servo_cfg_t* fw, hg_calib_t* stored) {
    *stored = fw->cal;
    bool all = true;
    for (auto& a : fw->cal.axis) {
        all = all && (a.flags & (HG_CAL_HOMED | HG_CAL_ALIGNED)) == (HG_CAL_HOMED | HG_CAL_ALIGNED);
        a.flags = static_cast<uint8_t>(a.flags & ~HG_CAL_HOMED);
    }
    return all;
}

int fw_power_up(hg_servo_t* s, hg_bringup_t* bu, const RunCfg& cfg, const hg_calib_t* stored) {
    hg_bringup_cfg_t bc;
    fw_bringup_config(cfg, &bc);
    hg_bringup_init(bu, s, &bc, stored);
    if (stored) (void)hg_bringup_power_up(bu);   // (an axis it could not restart stays refused)
    if (set_scene(s, cfg) != 0) {
        std::fprintf(stderr, "error: the firmware refused the scene\n");
        return 3;
    }
    return 0;
}

int fw_home_scene_enable(hg_servo_t* s, const RunCfg& cfg, bool enable) {
    for (uint32_t i = 0; i < 3; ++i)
        hg_enc_home(&s->cfg.enc[i], static_cast<int32_t>(fpga_read32(HG_REG_AXIS(i, HG_AX_IDX_POS))));
    const int sr = set_scene(s, cfg);
    const int en = enable && hg_servo_calibrated(s) ? hg_servo_enable(s, true) : 0;
    if (sr != 0 || en != 0) {
        std::fprintf(stderr, "error: the firmware refused the scene (%d) or enable (%d)\n", sr, en);
        return 3;
    }
    return 0;
}

#endif

}  // namespace hg_dev
