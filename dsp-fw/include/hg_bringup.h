/* SPDX-License-Identifier: Apache-2.0 */
/* Bring-up (issue 26): the state machines that find what a fresh device must know about itself,
 * one axis and one step at a time, each bounded in current, speed, travel and time:
 *   ALIGN   commutation alignment in raw counts with the FPGA's ALIGN mode (no position needed)
 *   HOME    index search by stepping the ALIGN field (current-bounded), back to the start pose
 *   RESTART the paper's restart in the reference pose: no search, angles from the calibration
 *   GUIDED  the operator moves the handle along a named direction: the encoder's direction
 *   IDENT   dynamics identification: back to the reference pose, the other joints held,
 *           multisine excitation, least-squares fit
 *   ENCODER a slow bounded sweep while the FPGA's capture buffer records the axis's raw A/B
 *           words (the PC reads them with CAP_READ and computes the signal quality)
 * The background loop starts a step (hg_bringup_start) and reads progress and results; the servo
 * ISR (hg_bringup_isr) steps the machine once per tick while it is active, in place of
 * hg_servo_step, and hands the FPGA back to the servo when the step ends. README.md, "Bring-up". */
#ifndef HG_BRINGUP_H
#define HG_BRINGUP_H

#include <stdbool.h>
#include <stdint.h>
#include "hg_calib.h"
#include "hg_real.h"
#include "hg_servo.h"

/* Steps (hg_bringup_start). */
enum {
    HG_BU_STEP_NONE = 0,
    HG_BU_STEP_ALIGN = 1,
    HG_BU_STEP_HOME = 2,
    HG_BU_STEP_RESTART = 3,
    HG_BU_STEP_GUIDED = 4,
    HG_BU_STEP_IDENT = 5,
    HG_BU_STEP_ENCODER = 6,
};
#define HG_BU_NSTEPS 7

/* Named states of the machine (hg_bringup_t.state). */
typedef enum {
    HG_BU_IDLE = 0,       /* nothing running; results of the last step are readable      */
    HG_BU_ALIGN_LOCK,     /* field held at the first angle while the rotor settles         */
    HG_BU_ALIGN_FWD,      /* field ramped forward through the scan                         */
    HG_BU_ALIGN_BACK,     /* and back to where it started                                   */
    HG_BU_HOME_SEARCH,    /* field ramped through the search window until the index latches */
    HG_BU_RETURN,         /* ALIGN / HOME done: field walks the rotor back to the reference
                           * pose; the step ends there at rest                              */
    HG_BU_GUIDED_WAIT,    /* zero torque, waiting for the operator's move                   */
    HG_BU_IDENT_RUN,      /* excitation running, normal equations accumulating              */
    HG_BU_IDENT_SETTLE,   /* excitation off, position hold until at rest                    */
    HG_BU_IDENT_MOVE,     /* IDENT first: every joint walked back to the reference pose (the
                           * others drifted while earlier steps moved one axis)            */
    HG_BU_ENC_SWEEP,      /* ENCODER: the rotor's rest walks at home_speed; the capture is
                           * armed after enc_settle_s and runs until the buffer is full     */
} hg_bu_state_t;

/* Why a step ended (hg_bringup_t.err); err_value / err_limit carry the figures. */
enum {
    HG_BU_OK = 0,
    HG_BU_ERR_ARG = 1,        /* bad step, axis or argument (nothing started)                */
    HG_BU_ERR_BUSY = 2,       /* a step is running, or the servo is enabled                  */
    HG_BU_ERR_NOT_READY = 3,  /* prerequisite missing (value: the HG_CAL_* flags needed)     */
    HG_BU_ERR_SERVO = 4,      /* servo error latched (value: its code)                       */
    HG_BU_ERR_FAULT = 5,      /* FPGA STATUS fault bit (value: axis)                         */
    HG_BU_ERR_WDOG = 6,       /* FPGA watchdog expired                                       */
    HG_BU_ERR_STALE = 7,      /* snapshot stale, torn or overrun (value: SEQ advance)        */
    HG_BU_ERR_SPEED = 8,      /* |joint speed| beyond the bound (rad/s)                      */
    HG_BU_ERR_TRAVEL = 9,     /* travel from the step's start beyond the bound (rad)         */
    HG_BU_ERR_TIME = 10,      /* step took longer than its bound (s)                         */
    HG_BU_ERR_ABORT = 11,     /* hg_bringup_abort: disable, operator                         */
    HG_BU_ERR_LINK = 12,      /* hg_bringup_abort: PC link lost                              */
    HG_BU_ERR_NO_MOVE = 13,   /* ALIGN: movement below the threshold (electrical degrees)    */
    HG_BU_ERR_POLE_PAIRS = 14,/* ALIGN: counts per electrical cycle off by more than the limit */
    HG_BU_ERR_FIT = 15,       /* ALIGN residual or IDENT fit beyond its limit                */
    HG_BU_ERR_NO_INDEX = 16,  /* HOME: no index within the range (value: travel covered, rad) */
    HG_BU_ERR_GUIDED_TIMEOUT = 17, /* GUIDED: move not seen (value: waited s, limit: timeout) */
    HG_BU_ERR_CONFIG = 18,    /* the step's plan exceeds a bound (value: planned, limit)     */
    HG_BU_ERR_CAPTURE = 19,   /* ENCODER: no capture buffer (value 0, limit 1), or the buffer
                               * not full within the sweep (value: entries, limit: needed)   */
};

/* Checks: every measured figure beside its limit. pass = (value <= limit) for HG_BU_LE checks,
 * (value >= limit) for HG_BU_GE ones. Names and units: hg_bringup_check(). */
enum {
    HG_BU_CHK_ALIGN_MOVE,     /* deg elec, GE: rotor movement over the scan                   */
    HG_BU_CHK_ALIGN_CPE,      /* %, LE: |counts per elec. cycle / configured - 1|              */
    HG_BU_CHK_ALIGN_RESID,    /* deg elec, LE: rms of the offset samples about their mean      */
    HG_BU_CHK_ALIGN_LAG,      /* deg elec, LE: friction lag (half the forward-back difference) */
    HG_BU_CHK_HOME_TRAVEL,    /* deg mech, LE: travel covered before the index latched         */
    HG_BU_CHK_GUIDED_WAIT,    /* s, LE: time waited for the operator's move                    */
    HG_BU_CHK_GUIDED_MOVE,    /* deg mech, GE: movement seen along the named direction         */
    HG_BU_CHK_IDENT_RESID,    /* %, LE: rms fit residual / rms torque                          */
    HG_BU_CHK_IDENT_TRAVEL,   /* deg mech, LE: largest excursion during the excitation         */
    HG_BU_CHK_IDENT_HOLD,     /* deg mech, LE: largest excursion of a held joint (IDENT)        */
    HG_BU_NCHECKS
};

typedef struct {
    float value, limit;
    uint8_t done; /* evaluated in the last run of its step */
    uint8_t pass;
} hg_bu_check_t;

/* One check as the report shows it. */
typedef struct {
    const char *name;
    const char *unit;
    float value, limit;
    bool ge;   /* pass means value >= limit (else value <= limit) */
    bool done;
    bool pass;
} hg_bu_check_info_t;

/* What bring-up measured on one axis (for the report; hg_calib_t holds what the firmware uses). */
typedef struct {
    bool aligned, homed;     /* ALIGN / HOME succeeded in this power-up (the fields below hold) */
    /* ALIGN */
    int8_t scan_sign;        /* +1: counts increase as the field angle advances             */
    float counts_per_elec;   /* measured counts per electrical cycle                         */
    float counts_per_elec_cfg; /* 2^20 / configured pole pairs                               */
    float pole_pairs_meas;   /* 2^20 / counts_per_elec                                        */
    float align_lambda;      /* field angle - sign * count angle at rest, 1/1024 elec. cycle  */
    float offset_raw;        /* OFFSET for the raw-count frame (before homing), 1/1024 cycle  */
    float move_elec_deg;     /* rotor movement over the scan                                  */
    /* HOME / RESTART */
    int32_t home_count;      /* raw count of the home (index, or the restart's virtual one)  */
    int32_t ref_count;       /* raw count in the reference pose (at hg_bringup_init)          */
    int32_t enc_offset;      /* hg_enc_cal_t.offset: count at q = 0 (enc_dir as in hg_calib)   */
    float home_travel;       /* rad covered by the search                                      */
    bool home_virtual;       /* RESTART: no index search, home from the reference pose         */
    /* GUIDED */
    int8_t dir_base;         /* enc_dir before the guided move: stored calibration or configured */
    float guided_move;       /* rad along the named direction (joint sign applied)            */
    float guided_wait_s;
    bool guided_reversed;    /* counts ran against dir_base: enc_dir flipped                  */
    bool refused;            /* guided move not seen: the axis stays disabled                  */
    /* IDENT (SI, in the nominal torque scale kt * amp_gain * dac_fs of hg_motor_t) */
    float inertia;           /* kg m^2                       */
    float b_visc;            /* N m s / rad                  */
    float tau_coulomb;       /* N m                          */
    float tau_gravity;       /* N m at the pose, joint sign  */
    float kt_amp;            /* N m per V of DAC: the nominal kt * amp_gain the fit is scaled by */
    float ident_resid;       /* relative rms residual        */
    /* ENCODER: the capture (the PC reads its entries with CAP_READ) and the FPGA's online
     * calibration registers of the axis at its end */
    bool enc_captured;       /* the buffer filled during the sweep                          */
    uint32_t enc_decim;      /* CAP_CTRL.DECIM: one ADC sample in decim + 1                  */
    uint32_t enc_entries;    /* entries recorded (the axis alone: one per sample)            */
    float enc_speed;         /* rad/s the rest point walked at                                */
    uint32_t enc_cal[5];     /* CAL_CTRL, CAL_STAT, CAL_OFS, CAL_GAIN, CAL_PHASE as read       */
    float id_q[3];           /* rad: joint angles at the identification's start (NaN: an axis
                              * not homed), enc_dir and the reference pose as finalize gives */
    float id_hold_max;       /* rad: largest excursion of a held joint during IDENT          */
    float id_lag;            /* s: the torque's lag behind the code written (fitted)          */
    float id_se[4];          /* standard errors of J, b, c, g (units as the values): the fit's
                              * residual variance times the diagonal of (A^T A)^-1            */
    float duration_s[HG_BU_NSTEPS]; /* device time each step took, by HG_BU_STEP_*   */
    hg_bu_check_t chk[HG_BU_NCHECKS];
} hg_bu_axis_t;

typedef struct {
    hg_real q_ref[3];        /* rad   reference pose: the fixture's pose at power-up            */
    uint8_t pole_pairs;      /* the FPGA's POLE_PAIRS (electrical cycles per revolution)        */
    /* bounds shared by every moving step */
    hg_real speed_max;       /* rad/s |joint speed| (FPGA VEL)                                  */
    hg_real travel_max;      /* rad   |travel| from the step's start                            */
    /* ALIGN */
    hg_real align_tau;       /* N m   current vector, as the torque it would give (TQ_LIMIT)     */
    hg_real align_cycles;    /* electrical cycles swept each way (>= 2 by default)              */
    hg_real align_rate;      /* electrical cycles per second                                    */
    hg_real align_lock_s;    /* s     lock-in at the first angle                                */
    hg_real align_min_move;  /* deg electrical: less is "no movement"                           */
    hg_real align_cpe_tol;   /* relative tolerance of counts per electrical cycle (0.02)         */
    hg_real align_resid_max; /* deg electrical                                                  */
    hg_real align_lag_max;   /* deg electrical                                                  */
    /* HOME */
    hg_real home_tau;        /* N m   current vector while searching                            */
    hg_real home_speed;      /* rad/s search speed                                              */
    hg_real home_range;      /* rad   searched on each side of the start pose                    */
    /* GUIDED */
    hg_real guided_min_move; /* rad   movement that counts as seen                              */
    hg_real guided_timeout_s;
    /* IDENT */
    hg_real id_tau;          /* N m   |excitation + hold| bound (TQ_LIMIT)                       */
    hg_real id_duration_s;   /* s     excitation                                                */
    hg_real id_kp, id_kd;    /* N m/rad, N m s/rad: the weak hold that keeps the axis in place */
    hg_real id_resid_max;    /* relative rms residual                                           */
    hg_real id_settle_s;     /* s     hold after the excitation                                 */
    /* ENCODER (at home_speed, home_tau) */
    hg_real enc_lines;       /* encoder lines the capture spans (>= 4: hapgate.golden.encquality) */
    hg_real enc_settle_s;    /* s     of sweep before the capture is armed (the rotor settles)   */
    hg_real enc_damp_s;      /* s     the rest point moves by -enc_damp_s x the speed error (damping;
                              *       the speed low-passed over one line period)               */
    hg_real enc_sample_hz;   /* Hz    the FPGA's ADC sample rate (the paper's 1 MSPS)            */
    hg_real id_hold_kp, id_hold_kd; /* N m/rad, N m s/rad: the stiff hold of the other joints  */
    hg_real id_hold_tau;     /* N m   |hold torque| bound of the other joints (their TQ_LIMIT)  */
    hg_real id_hold_travel;  /* rad   a held joint's excursion bound (else TRAVEL)              */
} hg_bringup_cfg_t;

/* unknowns: inertia, viscous, Coulomb, constant (gravity residual), and the torque's lag behind
 * the code written (the amplifier's current loop, the DAC's timing: a nuisance parameter that
 * would otherwise bias b by -lag * the hold's stiffness) */
#define HG_BU_ID_N 5

typedef struct {
    hg_servo_t *servo;       /* its cfg gives the motor scaling, rate and qd_max; handed back */
    hg_bringup_cfg_t cfg;
    hg_calib_t calib;        /* what the firmware uses (flags say what is known)             */
    hg_bu_axis_t res[3];
    /* progress (read by the background loop) */
    volatile hg_bu_state_t state;
    uint8_t step, axis;
    uint8_t err;             /* HG_BU_* of the last step                                      */
    float err_value, err_limit;
    uint32_t ticks;          /* ticks into the step                                           */
    uint32_t tick_limit;     /* its time bound                                                */
    /* snapshot bookkeeping */
    bool have_prev;
    uint32_t seq;
    int32_t pos[3], pos_homed[3], vel[3];
    uint32_t status;
    int32_t p_start[3];      /* counts at the step's start                                    */
    /* output of the current tick */
    uint32_t mode, offset;
    int32_t torque;          /* code for the active axis                                      */
    bool drive;
    /* per-step working state */
    double t_field;          /* ALIGN field angle, 1/1024 elec. cycle, unwrapped              */
    double scan_end;         /* ALIGN: where the forward ramp turns                           */
    double target;           /* HOME / RETURN: the rotor's target, counts from the step start */
    double path;             /* HOME: path the target covered, counts                         */
    double s_x, s_y, s_xx, s_xy, s_n;     /* ALIGN: count vs field line fit sums          */
    /* ALIGN: circular sums of (field - s * u), [s = +1, s = -1][all, forward, back][cos, sin] */
    double align_cs[2][3][2];
    int32_t p_min, p_max;
    int8_t dir;              /* HOME: present search direction (+1 counts up, -1 down)      */
    uint8_t leg;             /* HOME: 0 first side, 1 second side                           */
    int8_t expect[3];        /* GUIDED: expected joint sign per axis (0: not watched)       */
    uint8_t seen;            /* GUIDED: axes whose move was seen                             */
    double id_ata[HG_BU_ID_N][HG_BU_ID_N], id_aty[HG_BU_ID_N], id_yty;
    double id_row[HG_BU_ID_N], id_y;      /* IDENT: the window being integrated            */
#define HG_BU_ID_H 3 /* IDENT: velocity by central differences over +-H ticks */
    double id_x[2 * HG_BU_ID_H + 1];      /* IDENT: the last 2H + 1 positions, oldest first (rad) */
    double id_tq[HG_BU_ID_H + 1];         /* IDENT: torques written, [0] the latest (N m)  */
    double id_v_start, id_x_start;        /* IDENT: v and x at the window start          */
    uint32_t id_win;                      /* IDENT: intervals since the first boundary   */
    uint32_t id_rows;                     /* IDENT: windows kept in the fit                */
    double id_phase[6];                   /* IDENT: multisine phases (from the seed)     */
    double id_tau_w;                      /* IDENT: torque of the interval before the window */
    double id_xmax;                       /* IDENT: largest |x| seen (rad)               */
    uint32_t id_seed;                     /* IDENT: hg_bringup_start's seed              */
    bool enc_armed;                       /* ENCODER: the capture was armed              */
    int32_t enc_prev;                     /* ENCODER: last tick's count                   */
    double enc_vf;                        /* ENCODER: low-passed speed, counts/s         */
    int8_t id_sign[3];                    /* IDENT: each axis's scan sign s                */
    uint32_t hold_mode[3], hold_offset[3];/* IDENT: the held axes' MODE and OFFSET        */
    int32_t hold_torque[3];               /* IDENT: the held axes' torque codes           */
    double id_set[3], id_goal[3];         /* IDENT: hold setpoints and the reference pose,
                                           * counts from the step's start                 */
    uint32_t id_t0;                       /* IDENT: tick the excitation started           */
    uint8_t held_mask;                    /* axes held this step (bit i): IDENT the other two,
                                           * ALIGN and HOME the other aligned ones          */
} hg_bringup_t;

void hg_bringup_default_cfg(hg_bringup_cfg_t *c);
/* Bind to an initialised servo and record the reference pose's counts (the joints must be in
 * the reference pose: this is the power-up snapshot). known: a stored calibration or NULL. */
void hg_bringup_init(hg_bringup_t *b, hg_servo_t *s, const hg_bringup_cfg_t *cfg,
                     const hg_calib_t *known);
/* Start a step on axis (ALIGN, HOME, RESTART, IDENT, ENCODER) or on the axes expect[] names
 * (GUIDED, expect[i] = +1/-1 the joint sign the named direction gives, 0 not watched). seed: IDENT's
 * excitation phases. Returns HG_BU_OK or the refusal (nothing started, torque untouched). */
int hg_bringup_start(hg_bringup_t *b, uint8_t step, uint8_t axis, const int8_t expect[3],
                     uint32_t seed);
/* Background: stop at once (zero torque written before returning). reason: HG_BU_ERR_ABORT
 * or HG_BU_ERR_LINK. */
void hg_bringup_abort(hg_bringup_t *b, uint8_t reason);
bool hg_bringup_active(const hg_bringup_t *b);
/* The power-up in the reference pose, after hg_bringup_init with the stored calibration (the
 * board's main loop, and the virtual device's, call it once the servo has taken
 * HG_BU_POWER_UP_TICKS ticks, so that the snapshot it records is the interpolator's settled
 * count). Every axis whose stored calibration is homed and aligned becomes the servo's: an axis
 * the FPGA has homed already takes it as it is (homed on IDX_POS); any other axis RESTARTs
 * (no motion, its home virtual) and the servo homes on that virtual home. An axis without a
 * calibration is left to bring-up (ALIGN, HOME). No torque is written. Returns the mask of
 * axes the servo now has calibrated (bit i: axis i). */
#define HG_BU_POWER_UP_TICKS 2u
unsigned hg_bringup_power_up(hg_bringup_t *b);
/* One servo tick of the active step (from the ISR). */
void hg_bringup_step(hg_bringup_t *b);
/* Interrupt entry while bring-up may run: steps hg_bringup_isr_ctx if active, else the servo. */
extern hg_bringup_t *hg_bringup_isr_ctx;
void hg_bringup_isr(void);
/* A check of an axis with its name and unit. */
hg_bu_check_info_t hg_bringup_check(const hg_bringup_t *b, uint8_t axis, unsigned id);
/* comm_offset in electrical degrees (the FPGA OFFSET register's unit is 1/1024 cycle). */
hg_real hg_bringup_offset_deg(uint32_t comm_offset);

#endif /* HG_BRINGUP_H */
