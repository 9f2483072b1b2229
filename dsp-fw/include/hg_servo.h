/* SPDX-License-Identifier: Apache-2.0 */
/* The servo step run at the FPGA tick interrupt (1 kHz default, up to 10 kHz): snapshot ->
 * joint angles -> endpoint -> scene force -> tau = guard * J^T F + gravity + walls -> DAC codes
 * -> FPGA, with the safety checks that latch an error and hold zero torque. */
#ifndef HG_SERVO_H
#define HG_SERVO_H

#include <stdbool.h>
#include <stdint.h>
#include "hg_axis.h"
#include "hg_calib.h"
#include "hg_gravity.h"
#include "hg_kin.h"
#include "hg_scene.h"
#include "hg_walls.h"

#define HG_FW_VERSION 0x0100u /* major.minor */
#define HG_RATE_MIN 100u      /* Hz */
#define HG_RATE_MAX 10000u    /* Hz */

/* Latched error codes (first one wins; cleared only by hg_servo_clear_error()). */
enum {
    HG_ERR_NONE = 0,
    HG_ERR_NONFINITE = 1,  /* NaN/Inf in position, velocity, force or torque          */
    HG_ERR_AXIS_FAULT = 2, /* FPGA STATUS fault bit (signal lost, overspeed)          */
    HG_ERR_ENCODER = 3,    /* position step or velocity beyond qd_max                 */
    HG_ERR_STALE = 4,      /* snapshot SEQ unchanged since the last step, or torn     */
    HG_ERR_OVERRUN = 5,    /* SEQ advanced by more than 1 + max_missed                */
    HG_ERR_WATCHDOG = 6,   /* FPGA reports its watchdog expired                       */
    HG_ERR_FPGA_ID = 7,    /* ID register magic or major map version mismatch at init */
    HG_ERR_CONFIG = 8,     /* configuration rejected at init                          */
    HG_ERR_FPGA_FAULT = 9, /* FPGA integrity alarm (STATUS.HW_FAULT); err_axis = its   */
                           /* cause bits, HW_FAULT[4:0] (REGS, COMM, DAC, TICK, POS)  */
};

typedef struct {
    uint32_t rate_hz;          /* servo tick rate, HG_RATE_MIN..HG_RATE_MAX            */
    uint32_t fpga_clk_hz;      /* FPGA clock, for TICK_DIV                             */
    hg_linkage_t link;         /* link lengths and signs                               */
    hg_guard_t guard;          /* singularity fade thresholds                          */
    hg_enc_cal_t enc[3];       /* encoder calibration per axis (alpha, beta, gamma)    */
    hg_motor_t motor[3];       /* motor / amplifier / DAC scaling per axis             */
    hg_gravity_t grav;         /* counterbalance coefficients (default zero)           */
    hg_walls_t walls;          /* workspace boundary in actuator-angle space           */
    hg_real f_max;             /* N    clamp on |scene force| and on PC forces         */
    hg_real fi_max;            /* N    integral force limit per axis (anti-windup)     */
    hg_real qd_max;            /* rad/s fastest physically possible joint speed        */
    uint32_t pc_force_timeout; /* ticks a PC force stays valid without a new one       */
    uint32_t max_missed;       /* ticks the ISR may miss before HG_ERR_OVERRUN         */
    hg_calib_t cal;            /* the calibration it carries (hg_calib.h); hg_servo_init  */
                               /* sets enc[i].dir, enc[i].index_to_zero, motor[i].comm_offset */
                               /* from it. Default: homed and aligned, the values above      */
} hg_servo_cfg_t;

/* hg_servo_enable / hg_servo_set_force / hg_servo_set_calib refusals (0 = accepted). */
enum {
    HG_SERVO_E_RANGE = -1,   /* a value out of range (set_force, set_calib), or (enable) an  */
                             /* error is latched                                            */
    HG_SERVO_E_UNCAL = -2,   /* an axis lacks HG_CAL_HOMED | HG_CAL_ALIGNED                  */
    HG_SERVO_E_ENABLED = -3, /* set_calib while the forces are enabled                      */
};

typedef struct {
    hg_servo_cfg_t cfg;
    /* commands (written outside the ISR with the interrupt masked) */
    hg_scene_t scene;
    hg_real f_pc[3];          /* N, last PC force        */
    uint32_t f_pc_age;        /* ticks since it arrived  */
    bool enabled;
    /* latched error */
    uint8_t err, err_axis;
    /* snapshot bookkeeping */
    bool have_prev;
    uint32_t seq;             /* SEQ of the last consistent snapshot */
    int32_t pos[3];           /* its positions (counts)              */
    uint32_t status;          /* its STATUS word                     */
    int32_t max_step[3];      /* counts per tick allowed (from qd_max) */
    int32_t max_vel[3];       /* counts per second allowed           */
    uint32_t ctrl;            /* shadow of CTRL                       */
    uint32_t fpga_id;         /* ID register read at init             */
    /* results of the last step (published for the PC link) */
    hg_scene_state_t scene_st;
    hg_real q[3], qd[3], p[3], v[3], f[3], tau[3], guard;
    int16_t code[3];          /* torque codes written                */
    uint32_t steps;
} hg_servo_t;

void hg_servo_default_cfg(hg_servo_cfg_t *cfg);
/* Check the FPGA ID and the configuration, program TICK_DIV, offsets, modes and limits, clear
 * FPGA faults, write zero torque. Returns HG_ERR_NONE or the error it latched. */
uint8_t hg_servo_init(hg_servo_t *s, const hg_servo_cfg_t *cfg);
void hg_servo_step(hg_servo_t *s);

/* Interrupt entry: steps hg_servo_isr_ctx (if set) and acknowledges the tick. */
extern hg_servo_t *hg_servo_isr_ctx;
void hg_servo_isr(void);

/* Commands from outside the ISR (they mask the interrupt themselves). 0 = accepted. */
int hg_servo_enable(hg_servo_t *s, bool on);      /* refused while an error is latched */
void hg_servo_clear_error(hg_servo_t *s);         /* also disables; re-enable explicitly */
int hg_servo_set_scene(hg_servo_t *s, const hg_scene_t *sc);
int hg_servo_set_force(hg_servo_t *s, const hg_real f[3]);

/* Torque gating (issue 26): an axis is calibrated when its calibration has HG_CAL_HOMED and
 * HG_CAL_ALIGNED. Unless all three are, ENABLE and every force are refused (HG_SERVO_E_UNCAL)
 * and an uncalibrated axis's torque code is always 0. */
bool hg_servo_axis_calibrated(const hg_servo_t *s, unsigned axis);
bool hg_servo_calibrated(const hg_servo_t *s);
/* Check one axis's calibration (enc_dir +-1, phases_swapped 0/1, flags within HG_CAL_*,
 * comm_offset < 1024; an aligned axis's pole_pairs must be the FPGA's HG_FPGA_POLE_PAIRS). */
bool hg_calib_axis_ok(const hg_axis_calib_t *c);
/* Replace one axis's calibration (while disabled): applied at once to the encoder direction,
 * index_to_zero (re-homed on IDX_POS if the FPGA has homed the axis), OFFSET and MODE. */
int hg_servo_set_calib(hg_servo_t *s, unsigned axis, const hg_axis_calib_t *c);
/* The field's direction against the count: -1 when exactly one of enc_dir = -1 and
 * phases_swapped holds. The FPGA's sine mode turns the field with the count (+1 only), so
 * such an axis is commutated by the firmware: MODE = ALIGN, OFFSET written every tick. */
int hg_calib_comm_dir(const hg_axis_calib_t *c);

#endif /* HG_SERVO_H */
