// SPDX-License-Identifier: Apache-2.0
// The plant of the virtual device: three BLDC motors behind current amplifiers, the linkage
// (docs/design/KINEMATICS.md geometry) with a hand on it, and the encoder front end. Parameters, units
// and sources: tb/native/device/README.md. C ABI so that the same code serves the closed-loop
// harness (device_harness.cpp) and Python (hapgate.device.plant, through ctypes).
#pragma once

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hg_plant hg_plant;

// Parse a configuration ("key = v1 v2 ..." lines, '#' comments; keys in README.md). Returns NULL
// and writes a one-line reason into err (size errlen) on an unknown key or a bad value.
hg_plant* hg_plant_new(const char* config_text, char* err, int errlen);
void hg_plant_free(hg_plant* p);

// Phase-current command of DAC channel ch (0..5 = m0a, m0b, m1a, m1b, m2a, m2b) from its code.
void hg_plant_set_dac(hg_plant* p, int ch, int code);
// Advance by n integrator steps (dt each). Forces on the hand follow the hand model.
void hg_plant_step(hg_plant* p, int n);
// Model fidelity's multirate plant (tb/native/device/README.md "Model fidelity"): the amplifier's
// current loop advanced by 1 us toward the DAC commands, and the mechanics by one step of n_us
// with the mean current the loop reaches over it if the commands hold (exact between DAC updates).
void hg_plant_amp_us(hg_plant* p);
// n_us of it at once (commands held: the exact solution of the 1 us recursion, up to rounding).
void hg_plant_amp(hg_plant* p, int n_us);
void hg_plant_mech(hg_plant* p, int n_us);
// While held (the homing sweep): 1 us of the current loop and of the kinematic pose, no torques.
void hg_plant_held_us(hg_plant* p);
// Hold (1) or release (0) the joints kinematically: q follows hg_plant_set_q (homing sweep).
void hg_plant_hold(hg_plant* p, int on);
void hg_plant_set_q(hg_plant* p, const double q[3], const double qd[3]);
// Move the spring hand's target to xyz [m] from now on (its path replaced by that point; the
// live view's mouse-moved target). No effect on other hand kinds.
void hg_plant_set_target(hg_plant* p, const double xyz[3]);
// Change the hand from now on (bring-up's guided move): kind 0 none, 1 spring (to path: n points
// t x y z, plant time; NULL keeps the path), 2 fixed; kind -1 restores the configured hand.
// A configured rigid grip (fixed) is never changed.
void hg_plant_set_hand(hg_plant* p, int kind, const double* path, int n);

// ADC codes of axis i for the current state (A, B int8; index bit), noise drawn per call.
void hg_plant_adc(hg_plant* p, int8_t a[3], int8_t b[3], uint8_t idx[3]);
// The same for the axes in `mask` only (bit i = axis i); the others are left untouched.
void hg_plant_adc_mask(hg_plant* p, int mask, int8_t a[3], int8_t b[3], uint8_t idx[3]);

// State read-out (SI units): time, joint angles and rates, endpoint, force on the hand, motor
// torques, phase currents (a, b per motor), kinetic + hand-spring energy.
typedef struct {
    double t;
    double q[3], qd[3], p[3], v[3];
    double f_hand[3];   // force the device exerts on the hand, N
    double tau[3];      // motor torques, N m
    double i_ab[6];     // phase currents a, b per motor, A
    double energy;      // J: 0.5 qd^T M qd (+ 0.5 k |hand stretch|^2 with a spring hand)
    double theta_e[3];  // true electrical angle per motor, rad
    double qm[3], qdm[3];   // the rotors' angles and rates (the encoders'): q, qd when rigid
} hg_plant_out;
void hg_plant_read(const hg_plant* p, hg_plant_out* o);
// hg_plant_mech with the read-out of the state before the step (shared trigonometry).
void hg_plant_mech_read(hg_plant* p, int n_us, hg_plant_out* o);
// The encoders' angles (the rotors'; the joints' unless link_k_nm_per_rad is set), cheap:
// every grid point.
void hg_plant_q(const hg_plant* p, double q[3]);

// Geometry (for tests): forward kinematics and Jacobian (row-major 3x3) at q.
void hg_plant_fk(const hg_plant* p, const double q[3], double out[3]);
void hg_plant_jac(const hg_plant* p, const double q[3], double out[9]);
// Encoder signal model alone (for the cross-check against hapgate.golden.encsig): codes of axis
// `axis` for positions in lines (n samples), noise-free (noise_lsb ignored).
void hg_plant_encode(const hg_plant* p, int axis, const double* lines, int n, int8_t* a, int8_t* b);

// One sample of axis `axis` at `lines` with the given standard-normal noise draws (scaled by the
// axis's noise_lsb), and that noise level (model fidelity draws its noise per sample index).
void hg_plant_encode1(const hg_plant* p, int axis, double lines, double za, double zb, int8_t* a, int8_t* b);
double hg_plant_noise_lsb(const hg_plant* p, int axis);

#ifdef __cplusplus
}
#endif
