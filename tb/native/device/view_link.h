// SPDX-License-Identifier: Apache-2.0
// The live view's link out of the device harness (docs/view.md): telemetry lines at a fixed
// period of simulated time on a non-blocking pipe (a line that does not fit is dropped and
// counted: the view never slows the simulation), safety events as they happen, burst captures
// of the fast signals at full rate into files, and a control pipe (pause, forces off, the
// hand's target, a burst request). Off unless run.cfg has view_fd: the harness then only
// tests a null pointer, and the records are untouched.
#ifndef VIEW_LINK_H
#define VIEW_LINK_H

#include <cstdint>
#include <string>

#include "plant.h"

struct ViewLink;

// What the harness does on a control command (read by view_link_poll).
struct ViewCtl {
    bool paused = false;      // scene runs only (can_pause)
    bool forces_off = false;  // sticky: the firmware is disabled at every tick from then on
    bool target_set = false;  // a new hand target (consumed by the harness)
    double target[3] = {0, 0, 0};
};

// The firmware's side of one telemetry line.
struct ViewFw {
    uint8_t err, err_axis, enabled, drive;
    uint32_t status;
    double f[3], tau[3];
    double pc_age_s;          // since the PC's last force (NaN without a link)
    const uint32_t* link;     // good, bad, replayed, timeouts (null without a link)
};

// out_fd: telemetry (set non-blocking here); ctl_fd: commands (-1: none); period_s of scene
// time; frame_us: the DAC frame period (telemetry and bursts sample at frame starts).
ViewLink* view_link_open(int out_fd, int ctl_fd, double period_s, double frame_us, const std::string& outdir,
                         bool can_pause);
// Is a plant sample wanted at this frame start (scene time t)? Then call view_link_frame.
bool view_link_want(const ViewLink* v, double t);
void view_link_frame(ViewLink* v, const hg_plant_out& o, const int16_t dac[6]);
// An ADC word triple while a burst captures (cheap to call: it returns at once otherwise).
bool view_link_adc_on(const ViewLink* v);
void view_link_adc(ViewLink* v, const int8_t a[3], const int8_t b[3]);
// A telemetry line is ready (taken at a frame start): send it with the firmware's state.
bool view_link_ready(const ViewLink* v);
void view_link_send(ViewLink* v, const ViewFw& fw, const ViewCtl& ctl);
// Make the last sample ready once more (a paused run's lines).
void view_link_again(ViewLink* v);
// A fault became active: its safety event is timed from cause_s (scene time) to the first DAC
// load from which every channel of the motors in motor_mask stays zero (runner.events' rule).
void view_link_fault(ViewLink* v, const char* kind, int axis, double cause_s, int motor_mask);
void view_link_load(ViewLink* v, double t_s, int ch, int code);
// Read pending commands into ctl; with wait_s > 0 block up to that long for one.
void view_link_poll(ViewLink* v, ViewCtl& ctl, double wait_s);

#endif  // VIEW_LINK_H
