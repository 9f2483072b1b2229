// SPDX-License-Identifier: Apache-2.0
// The live view's link out of the device harness (view_link.h; the line format is parsed by
// models/hapgate/device/telemetry.py, described in docs/view.md).
#include "view_link.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {
constexpr int kBurstFrames = 1024;   // 16.4 ms of DAC frames (62.5 kHz)
constexpr int kBurstAdc = 4096;      // 4.1 ms of ADC words (1 MSPS)
constexpr int kFrameDoubles = 16;    // t, dac[6], i_ab[6], tau[3]

struct Event {
    const char* kind;   // the fault kind's name (hg_dev::kFaultKinds)
    int axis, motors;
    double cause, zero;
};
}  // namespace

struct ViewLink {
    int out = -1, ctl = -1;
    double period_s = 0.02, next_t = -1e9, frame_s = 16e-6;
    std::string outdir;
    bool can_pause = false;
    // the sample of the next line
    bool ready = false;
    hg_plant_out o{};
    int16_t dac[6] = {0, 0, 0, 0, 0, 0};
    uint64_t sent = 0, dropped = 0;
    std::string pending;     // event and burst lines that must not be lost: retried first
    std::string cmd;         // partial command line
    std::vector<Event> events;
    double last_t = 0;
    // burst capture
    bool burst_armed = false, burst_frames_on = false, burst_adc_on = false;
    int burst_no = 0;
    std::vector<double> bf;
    std::vector<int8_t> ba;
};

ViewLink* view_link_open(int out_fd, int ctl_fd, double period_s, double frame_us, const std::string& outdir,
                         bool can_pause) {
    auto* v = new ViewLink;
    v->out = out_fd;
    v->ctl = ctl_fd;
    v->period_s = period_s;
    v->frame_s = frame_us * 1e-6;
    v->outdir = outdir;
    v->can_pause = can_pause;
    fcntl(out_fd, F_SETFL, fcntl(out_fd, F_GETFL) | O_NONBLOCK);
    if (ctl_fd >= 0) fcntl(ctl_fd, F_SETFL, fcntl(ctl_fd, F_GETFL) | O_NONBLOCK);
    return v;
}

static bool put(ViewLink* v, const std::string& line) {   // whole or nothing (< PIPE_BUF)
    const ssize_t n = write(v->out, line.data(), line.size());
    return n == static_cast<ssize_t>(line.size());
}

static void put_reliable(ViewLink* v, const std::string& line) {
    v->pending += line;
    while (!v->pending.empty()) {
        const size_t nl = v->pending.find('\n') + 1;
        if (!put(v, v->pending.substr(0, nl))) return;   // the reader is behind: next time
        v->pending.erase(0, nl);
    }
}

bool view_link_want(const ViewLink* v, double t) {
    return t >= v->next_t - 0.5 * v->frame_s || v->burst_armed || v->burst_frames_on;
}

static void burst_done(ViewLink* v) {
    if (v->burst_frames_on || v->burst_adc_on) return;
    const std::string name = "burst-" + std::to_string(v->burst_no) + ".bin";
    const std::string path = v->outdir + "/" + name;
    FILE* f = std::fopen((path + ".tmp").c_str(), "wb");
    if (!f) return;
    const int32_t nf = static_cast<int32_t>(v->bf.size() / kFrameDoubles), na = static_cast<int32_t>(v->ba.size() / 6);
    std::fwrite(&nf, 4, 1, f);
    std::fwrite(&na, 4, 1, f);
    std::fwrite(v->bf.data(), sizeof(double), v->bf.size(), f);
    std::fwrite(v->ba.data(), 1, v->ba.size(), f);
    std::fclose(f);
    std::rename((path + ".tmp").c_str(), path.c_str());
    char line[160];
    std::snprintf(line, sizeof line, "B n=%d file=%s frames=%d adc=%d\n", v->burst_no, name.c_str(), nf, na);
    put_reliable(v, line);
    ++v->burst_no;
}

void view_link_frame(ViewLink* v, const hg_plant_out& o, const int16_t dac[6]) {
    if (v->burst_armed) {
        v->burst_armed = false;
        v->burst_frames_on = v->burst_adc_on = true;
        v->bf.clear();
        v->ba.clear();
    }
    if (v->burst_frames_on) {
        double r[kFrameDoubles];
        r[0] = o.t;
        for (int i = 0; i < 6; ++i) r[1 + i] = dac[i];
        for (int i = 0; i < 6; ++i) r[7 + i] = o.i_ab[i];
        for (int i = 0; i < 3; ++i) r[13 + i] = o.tau[i];
        v->bf.insert(v->bf.end(), r, r + kFrameDoubles);
        if (static_cast<int>(v->bf.size()) >= kBurstFrames * kFrameDoubles) {
            v->burst_frames_on = false;
            burst_done(v);
        }
    }
    if (o.t >= v->next_t - 0.5 * v->frame_s) {
        v->o = o;
        std::memcpy(v->dac, dac, sizeof v->dac);
        v->ready = true;
        // the next line's time: a whole number of periods after this one (frames are on the grid)
        v->next_t = (v->next_t < -1e8 ? o.t : v->next_t) + v->period_s;
        if (v->next_t <= o.t) v->next_t = o.t + v->period_s;
    }
}

bool view_link_adc_on(const ViewLink* v) { return v->burst_adc_on; }

void view_link_adc(ViewLink* v, const int8_t a[3], const int8_t b[3]) {
    for (int i = 0; i < 3; ++i) {
        v->ba.push_back(a[i]);
        v->ba.push_back(b[i]);
    }
    if (static_cast<int>(v->ba.size()) >= kBurstAdc * 6) {
        v->burst_adc_on = false;
        burst_done(v);
    }
}

bool view_link_ready(const ViewLink* v) { return v->ready; }

void view_link_again(ViewLink* v) { v->ready = true; }

static void vec(std::string& s, const char* key, const double* x, int n) {
    char b[64];
    s += ' ';
    s += key;
    s += '=';
    for (int i = 0; i < n; ++i) {
        std::snprintf(b, sizeof b, i ? ",%.9g" : "%.9g", x[i]);
        s += b;
    }
}

void view_link_send(ViewLink* v, const ViewFw& fw, const ViewCtl& ctl) {
    v->ready = false;
    v->last_t = v->o.t;
    if (!v->pending.empty()) put_reliable(v, "");
    std::string s;
    s.reserve(1024);
    char b[256];
    std::snprintf(b, sizeof b, "T t=%.9f", v->o.t);
    s += b;
    vec(s, "q", v->o.q, 3);
    vec(s, "p", v->o.p, 3);
    vec(s, "f", v->o.f_hand, 3);
    vec(s, "tau", v->o.tau, 3);
    vec(s, "i", v->o.i_ab, 6);
    double d[6];
    for (int i = 0; i < 6; ++i) d[i] = v->dac[i];
    vec(s, "dac", d, 6);
    vec(s, "ffw", fw.f, 3);
    vec(s, "taufw", fw.tau, 3);
    std::snprintf(b, sizeof b, " err=%u eax=%u en=%u drv=%u st=%u paused=%d off=%d drop=%llu pcage=%.6g",
                  fw.err, fw.err_axis, fw.enabled, fw.drive, fw.status, ctl.paused ? 1 : 0, ctl.forces_off ? 1 : 0,
                  static_cast<unsigned long long>(v->dropped), fw.pc_age_s);
    s += b;
    if (fw.link) {
        std::snprintf(b, sizeof b, " link=%u,%u,%u,%u", fw.link[0], fw.link[1], fw.link[2], fw.link[3]);
        s += b;
    }
    s += '\n';
    if (put(v, s)) ++v->sent;
    else ++v->dropped;
}

void view_link_fault(ViewLink* v, const char* kind, int axis, double cause_s, int motor_mask) {
    v->events.push_back({kind, axis, motor_mask, cause_s, NAN});
    if (!v->burst_frames_on && !v->burst_adc_on) v->burst_armed = true;   // triggered capture
}

void view_link_load(ViewLink* v, double t_s, int ch, int code) {
    for (size_t k = 0; k < v->events.size(); ++k) {
        Event& e = v->events[k];
        if (t_s < e.cause || !(e.motors >> (ch / 2) & 1)) continue;
        if (code != 0) {
            e.zero = NAN;          // not (yet) the load from which the torque stays zero
        } else if (std::isnan(e.zero)) {
            e.zero = t_s;
            char b[200];
            std::snprintf(b, sizeof b, "E n=%zu kind=%s axis=%d cause=%.9f zero=%.9f react_us=%.4f\n", k, e.kind,
                          e.axis, e.cause, e.zero, (e.zero - e.cause) * 1e6);
            put_reliable(v, b);
        }
    }
}

void view_link_poll(ViewLink* v, ViewCtl& ctl, double wait_s) {
    if (v->ctl < 0) return;
    if (wait_s > 0) {
        pollfd p{v->ctl, POLLIN, 0};
        poll(&p, 1, static_cast<int>(wait_s * 1000));
    }
    char buf[512];
    ssize_t n;
    while ((n = read(v->ctl, buf, sizeof buf)) > 0) v->cmd.append(buf, static_cast<size_t>(n));
    size_t nl;
    while ((nl = v->cmd.find('\n')) != std::string::npos) {
        const std::string c = v->cmd.substr(0, nl);
        v->cmd.erase(0, nl + 1);
        double x, y, z;
        if (c == "pause" && v->can_pause) ctl.paused = true;
        else if (c == "resume") ctl.paused = false;
        else if (c == "forces_off") ctl.forces_off = true;     // there is no command that undoes it
        else if (c == "burst") {
            if (!v->burst_frames_on && !v->burst_adc_on) v->burst_armed = true;
        } else if (std::sscanf(c.c_str(), "target %lf %lf %lf", &x, &y, &z) == 3 && std::isfinite(x) &&
                   std::isfinite(y) && std::isfinite(z) && std::fabs(x) < 0.2 && std::fabs(y) < 0.2 &&
                   std::fabs(z) < 0.2) {
            ctl.target_set = true;
            ctl.target[0] = x;
            ctl.target[1] = y;
            ctl.target[2] = z;
        }
    }
}
