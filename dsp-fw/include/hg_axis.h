/* SPDX-License-Identifier: Apache-2.0 */
/* Per-axis unit conversions: encoder counts -> joint angle/rate (encoder calibration) and
 * joint torque -> current -> amplifier voltage -> DAC torque-command code (motor scaling). */
#ifndef HG_AXIS_H
#define HG_AXIS_H

#include <stdint.h>
#include "hg_real.h"

/* Encoder calibration. q = dir * (counts - offset) * 2 pi / counts_per_rev; q = 0 with the
 * crank in the x-z plane (docs/design/KINEMATICS.md). */
typedef struct {
    int8_t dir;              /* +1 / -1: sign of counts against the right-handed joint angle */
    int32_t offset;          /* counts at q = 0; set by hg_enc_home()                        */
    uint32_t counts_per_rev; /* 2^20 for 1024 lines x 1024 counts/line                       */
    int32_t index_to_zero;   /* counts from the index pulse to q = 0 (one-off, per encoder)  */
} hg_enc_cal_t;

#define HG_ENC_COUNTS_PER_REV (1u << 20)

hg_real hg_enc_angle(const hg_enc_cal_t *c, int32_t counts);      /* rad   */
hg_real hg_enc_rate(const hg_enc_cal_t *c, int32_t counts_per_s); /* rad/s */
/* Counts per second for a joint rate (for the plausibility limits). */
hg_real hg_enc_counts_per_rad(const hg_enc_cal_t *c);
/* Set offset from the FPGA's index-latched position. */
void hg_enc_home(hg_enc_cal_t *c, int32_t index_latched);

/* Motor, amplifier and DAC: code = dir * tau / (kt * amp_gain * dac_fs) * 32767. */
typedef struct {
    hg_real kt;           /* N m / A  motor torque constant                          */
    hg_real amp_gain;     /* A / V    amplifier transconductance                     */
    hg_real dac_fs;       /* V        DAC output at code +32767                      */
    hg_real tau_max;      /* N m      torque clamp (also sets the FPGA code limit)   */
    int8_t dir;           /* +1 / -1: positive code gives positive joint torque      */
    uint32_t comm_offset; /* commutation offset written to the FPGA (index -> winding) */
} hg_motor_t;

/* Rounded, clamped to +-tau_max and to +-32767. tau must be finite. */
int16_t hg_motor_code(const hg_motor_t *m, hg_real tau);
/* |code| that tau_max maps to (FPGA TQ_LIMIT register). */
uint32_t hg_motor_code_limit(const hg_motor_t *m);

#endif /* HG_AXIS_H */
