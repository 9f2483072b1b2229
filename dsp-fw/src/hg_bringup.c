/* SPDX-License-Identifier: Apache-2.0 */
/* Bring-up state machines (hg_bringup.h). Conventions used throughout:
 *  - "field" angles and the FPGA OFFSET register are in 1/1024 electrical cycle (the commutator's
 *    angle code). In ALIGN mode the current vector stands at code OFFSET, which the sine ROM
 *    evaluates at (OFFSET + 1/2) (models/hapgate/golden/commutation.py, "Code k stands for
 *    (k + 1/2)"); in SINE mode it aims, on average over a code, at u + OFFSET with
 *    u = counts * POLE_PAIRS / 1024 (mod 1024) of POS_HOMED.
 *  - A motor driven at commutation angle c gives torque kt * I * cos(c - e), e the rotor's
 *    electrical angle (the plant's winding model, tb/native/device/plant.cpp). So in ALIGN the
 *    rotor rests where e = c + 1/4 cycle, and SINE with c = e gives the full torque.
 *  - The alignment scan measures s, the sign between field angle and count, and lambda, the
 *    field angle minus s * u at rest. A SINE offset of lambda + 256 then pushes the rotor toward
 *    increasing s * counts: for s = +1 that is the OFFSET giving torque toward increasing counts.
 *  - s = enc_dir * (phases swapped ? -1 : +1): the scan alone cannot tell the two apart; the
 *    guided move gives enc_dir (else the configured one is used, not confirmed).
 * Sums of the fits are kept in double (the C67x has double-precision hardware): counts reach
 * 2^20 and their squares summed over thousands of samples are beyond float. */
#include "hg_bringup.h"
#include "hg_capture.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"

hg_bringup_t *hg_bringup_isr_ctx;

#define CODES 1024.0        /* commutator angle codes per electrical cycle */
#define QUARTER 256.0
#define TWO_PI_D 6.283185307179586476925
#define AX(i, r) HG_REG_AXIS((i), (r))

static const struct {
    const char *name, *unit;
    bool ge;
} CHECKS[HG_BU_NCHECKS] = {
    [HG_BU_CHK_ALIGN_MOVE] = { "align_movement", "deg_elec", true },
    [HG_BU_CHK_ALIGN_CPE] = { "align_counts_per_elec_error", "%", false },
    [HG_BU_CHK_ALIGN_RESID] = { "align_offset_spread", "deg_elec", false },
    [HG_BU_CHK_ALIGN_LAG] = { "align_friction_lag", "deg_elec", false },
    [HG_BU_CHK_HOME_TRAVEL] = { "home_travel", "deg", false },
    [HG_BU_CHK_GUIDED_WAIT] = { "guided_wait", "s", false },
    [HG_BU_CHK_GUIDED_MOVE] = { "guided_movement", "deg", true },
    [HG_BU_CHK_IDENT_RESID] = { "ident_residual", "%", false },
    [HG_BU_CHK_IDENT_TRAVEL] = { "ident_excursion", "deg", false },
    [HG_BU_CHK_IDENT_HOLD] = { "ident_hold_excursion", "deg", false },
};

/* The multisine's lines (Hz): from below the viscous corner J/b (~0.6 Hz on the default plant)
 * to well above the hold's resonance, none harmonically related, so the fit sees inertia,
 * viscous and Coulomb friction at once. */
static const double ID_FREQ[6] = { 0.37, 0.83, 1.9, 4.1, 7.3, 12.7 };

void hg_bringup_default_cfg(hg_bringup_cfg_t *c)
{
    *c = (hg_bringup_cfg_t){ 0 };
    c->pole_pairs = 2;
    c->speed_max = HG_C(10.0);
    c->travel_max = HG_C(8.0); /* 2.5 electrical cycles at 2 pole pairs (7.85 rad): see README */
    c->align_tau = HG_C(0.1);
    c->align_cycles = HG_C(2.0);
    c->align_rate = HG_C(0.5);
    c->align_lock_s = HG_C(2.0);
    c->align_min_move = HG_C(3.6); /* SimpleFOC's threshold */
    c->align_cpe_tol = HG_C(0.02); /* ODrive's */
    c->align_resid_max = HG_C(10.0);
    c->align_lag_max = HG_C(20.0);
    c->home_tau = HG_C(0.1);
    c->home_speed = HG_C(0.5);
    c->home_range = HG_C(1.2);
    c->guided_min_move = HG_C(0.1);
    c->guided_timeout_s = HG_C(20.0);
    c->id_tau = HG_C(0.04);
    c->id_duration_s = HG_C(12.0);
    c->id_kp = HG_C(0.1);
    c->id_kd = HG_C(0.005);
    c->id_resid_max = HG_C(0.05);
    c->id_settle_s = HG_C(0.5);
    c->enc_lines = HG_C(8.0);
    c->enc_settle_s = HG_C(0.3);
    c->enc_damp_s = HG_C(0.03);
    c->enc_sample_hz = HG_C(1e6);
    /* the other joints' hold: ~25 Hz, damping ratio ~0.7 on a 1e-4 kg m^2 joint (README.md) */
    c->id_hold_kp = HG_C(2.5);
    c->id_hold_kd = HG_C(0.022);
    c->id_hold_tau = HG_C(0.1);
    c->id_hold_travel = HG_C(0.2);
}

/* ---------------------------------------------------------------- small helpers */

static double wrap_codes(double x) /* to [0, 1024) */
{
    x = fmod(x, CODES);
    return x < 0.0 ? x + CODES : x;
}

static double wrap_half(double x) /* to [-512, 512) */
{
    return wrap_codes(x + CODES / 2.0) - CODES / 2.0;
}

/* The commutator's angle of a count: (counts * PP mod 2^20) / 1024, exact in integers. */
static double count_angle(const hg_bringup_t *b, int32_t counts)
{
    const uint32_t u = ((uint32_t)counts * (uint32_t)b->cfg.pole_pairs)
                     & (HG_ENC_COUNTS_PER_REV - 1u);
    return (double)u / (double)(HG_ENC_COUNTS_PER_REV / 1024u);
}

/* x - y in counts, modular (no signed overflow whatever the counter did) */
static int32_t cdiff(int32_t x, int32_t y)
{
    return (int32_t)((uint32_t)x - (uint32_t)y);
}

static double counts_per_rad_ax(const hg_bringup_t *b, unsigned i)
{
    return (double)b->servo->cfg.enc[i].counts_per_rev / TWO_PI_D;
}

static double counts_per_rad(const hg_bringup_t *b)
{
    return counts_per_rad_ax(b, b->axis);
}

static double rate(const hg_bringup_t *b)
{
    return (double)b->servo->cfg.rate_hz;
}

static uint32_t secs_to_ticks(const hg_bringup_t *b, double s)
{
    return (uint32_t)(s * rate(b) + 0.5);
}

/* N m -> torque code with the nominal motor scaling (no motor.dir: bring-up drives in the
 * count direction it measured), and back. */
static double code_per_nm(const hg_motor_t *m)
{
    return (double)HG_TORQUE_FS / ((double)m->kt * (double)m->amp_gain * (double)m->dac_fs);
}

static int32_t tau_code_ax(const hg_bringup_t *b, unsigned i, double tau)
{
    double x = tau * code_per_nm(&b->servo->cfg.motor[i]);
    const double fs = (double)HG_TORQUE_FS;
    x = x > fs ? fs : (x < -fs ? -fs : x);
    return (int32_t)(x < 0.0 ? x - 0.5 : x + 0.5);
}

static int32_t tau_code(const hg_bringup_t *b, double tau)
{
    return tau_code_ax(b, b->axis, tau);
}

static void set_check(hg_bringup_t *b, unsigned axis, unsigned id, double value, double limit)
{
    hg_bu_check_t *c = &b->res[axis].chk[id];
    c->value = (float)value;
    c->limit = (float)limit;
    c->done = 1;
    c->pass = (uint8_t)(CHECKS[id].ge ? value >= limit : value <= limit); /* NaN fails */
}

/* ---------------------------------------------------------------- calibration from results */

/* The OFFSET that gives torque toward increasing s * counts in the FPGA's present POS_HOMED
 * frame (shift = POS - POS_HOMED: 0 before homing, the home after). */
static double offset_in_frame(const hg_bringup_t *b, unsigned i, int32_t shift)
{
    const hg_bu_axis_t *r = &b->res[i];
    return wrap_codes((double)r->offset_raw + (double)r->scan_sign * count_angle(b, shift));
}

/* Rebuild axis i's hg_axis_calib_t from what the steps found. The encoder direction is the
 * guided move's, else the configured one; the phase order follows from it and the scan sign;
 * comm_offset is the OFFSET for a positive code to give positive joint torque, in the frame of
 * the home the axis has (index, or the restart's virtual home). */
static void finalize_axis(hg_bringup_t *b, unsigned i)
{
    hg_axis_calib_t *c = &b->calib.axis[i];
    hg_bu_axis_t *r = &b->res[i];
    const int8_t dir = r->guided_reversed ? (int8_t)-r->dir_base : r->dir_base;
    c->enc_dir = dir;
    c->pole_pairs = b->cfg.pole_pairs;
    if (r->aligned) {
        c->phases_swapped = (uint8_t)(r->scan_sign * dir < 0);
        const int32_t shift = r->homed ? r->home_count : 0;
        double off = offset_in_frame(b, i, shift) + (c->phases_swapped ? CODES / 2.0 : 0.0);
        off = wrap_codes(off);
        c->comm_offset = (uint32_t)(off + 0.5) & 1023u;
    }
    if (r->homed) {
        const double cpr = (double)b->servo->cfg.enc[i].counts_per_rev;
        const int32_t q_counts = (int32_t)lround((double)b->cfg.q_ref[i] * cpr / TWO_PI_D);
        r->enc_offset = cdiff(r->ref_count, dir * q_counts);
        c->index_to_zero = cdiff(r->enc_offset, r->home_count);
    }
    if (r->refused)
        c->flags &= (uint8_t) ~(HG_CAL_HOMED | HG_CAL_ALIGNED); /* torque stays refused */
}

/* ---------------------------------------------------------------- FPGA outputs */

static void write_zero(void)
{
    for (uint32_t i = 0; i < HG_NAXES; i++)
        fpga_write32(AX(i, HG_AX_TORQUE), 0);
    fpga_write32(HG_REG_CTRL, 0);
}

/* Give the FPGA back to the servo as hg_servo_init left it: zero torque, SINE mode, its
 * offsets and limits, CTRL 0; the servo re-seeds its snapshot check (its SEQ is stale). */
static void hand_back(hg_bringup_t *b)
{
    hg_servo_t *s = b->servo;
    write_zero();
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        fpga_write32(AX(i, HG_AX_MODE), HG_MODE_TORQUE);
        fpga_write32(AX(i, HG_AX_OFFSET), s->cfg.motor[i].comm_offset);
        fpga_write32(AX(i, HG_AX_TQ_LIMIT), hg_motor_code_limit(&s->cfg.motor[i]));
    }
    s->ctrl = 0;
    s->have_prev = false;
    b->drive = false;
    b->torque = 0;
    b->res[b->axis].duration_s[b->step] = (float)((double)b->ticks / rate(b));
    b->state = HG_BU_IDLE;
}

/* Any fault, limit, loss or abort: zero torque now, then the FPGA back to the servo. */
static void fail(hg_bringup_t *b, uint8_t err, double value, double limit)
{
    write_zero();
    b->err = err;
    b->err_value = (float)value;
    b->err_limit = (float)limit;
    hand_back(b);
}

static void finish(hg_bringup_t *b)
{
    b->err = HG_BU_OK;
    b->err_value = b->err_limit = 0.0f;
    finalize_axis(b, b->axis);
    hand_back(b);
}

static void write_outputs(hg_bringup_t *b, uint32_t ctrl_extra)
{
    const uint32_t a = b->axis;
    uint32_t en = b->drive ? HG_CTRL_GLOBAL_EN | HG_CTRL_AXIS_EN(a) : 0u;
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        if (i == a)
            continue;
        const bool hold = b->drive && (b->held_mask & (1u << i));
        if (hold) {
            fpga_write32(AX(i, HG_AX_MODE), b->hold_mode[i]);
            fpga_write32(AX(i, HG_AX_OFFSET), b->hold_offset[i] & 1023u);
            en |= HG_CTRL_AXIS_EN(i);
        }
        fpga_write32(AX(i, HG_AX_TORQUE), hold ? (uint32_t)(uint16_t)(int16_t)b->hold_torque[i] : 0u);
    }
    fpga_write32(AX(a, HG_AX_MODE), b->mode);
    fpga_write32(AX(a, HG_AX_OFFSET), b->offset & 1023u);
    fpga_write32(AX(a, HG_AX_TORQUE), b->drive ? (uint32_t)(uint16_t)(int16_t)b->torque : 0u);
    fpga_write32(HG_REG_CTRL, en | ctrl_extra);
    fpga_write32(HG_REG_WDOG, HG_WDOG_KEY);
}

/* Put the ALIGN field where the rotor rests at `target` counts: field = lambda + s * u(target)
 * (the register holds the code whose middle is that angle). Needs a finished alignment. */
static void field_at_count(hg_bringup_t *b, double target)
{
    const hg_bu_axis_t *r = &b->res[b->axis];
    const double u = target * (double)b->cfg.pole_pairs / (double)(HG_ENC_COUNTS_PER_REV / 1024u);
    b->t_field = wrap_codes((double)r->align_lambda + (double)r->scan_sign * u - 0.5);
    b->offset = (uint32_t)wrap_codes(floor(b->t_field + 0.5));
}

/* A rotor more than a quarter cycle behind its target is blocked (or held): end the step
 * before the field can drag it further. */
static bool rotor_follows(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    const double cpe = (double)HG_ENC_COUNTS_PER_REV / (double)b->cfg.pole_pairs;
    const double pos = (double)cdiff(b->pos[a], b->p_start[a]);
    if (fabs(pos - b->target) > cpe / 4.0) {
        fail(b, HG_BU_ERR_NO_MOVE, fabs(pos - b->target) * 360.0 / cpe, 90.0);
        return false;
    }
    return true;
}

/* RETURN: the target walks to the reference pose at home_speed; the step ends when the rotor
 * is within 1/64 electrical cycle of it and at rest. */
static void return_tick(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    const double step = (double)b->cfg.home_speed * counts_per_rad(b) / rate(b);
    const double cpe = (double)HG_ENC_COUNTS_PER_REV / (double)b->cfg.pole_pairs;
    const double ref = (double)cdiff(b->res[a].ref_count, b->p_start[a]);
    const double pos = (double)cdiff(b->pos[a], b->p_start[a]);
    const double speed = fabs((double)b->vel[a]) / counts_per_rad(b);
    if (!rotor_follows(b))
        return;
    if (fabs(b->target - ref) <= step) {
        b->target = ref;
        if (fabs(pos - ref) < cpe / 64.0 && speed < 0.01 * (double)b->cfg.speed_max) {
            finish(b);
            return;
        }
    } else {
        b->target += b->target < ref ? step : -step;
    }
    field_at_count(b, (double)b->p_start[a] + b->target);
}

/* ---------------------------------------------------------------- ALIGN */
/* Lock the field at code 0, the current ramped in over 3/4 of the lock time (a step of current
 * would swing the rotor through up to half a cycle at tens of rad/s; on the stable side the ramp
 * draws it in quasi-statically, on the unstable side the governor below bounds it), then ramp
 * the field align_cycles forward and back at full current. Every tick of the ramps is one
 * sample (field, count): a line fit gives the sign and the counts per electrical cycle; the
 * circular mean of field - s * u gives lambda. Forward and back sample the same field angles,
 * so the friction lag (rotor behind the field in both directions) cancels in both fits; half
 * their difference is reported as the lag. Then the walk back to the reference pose (RETURN). */

static void align_enter(hg_bringup_t *b)
{
    b->t_field = 0.0;
    b->scan_end = (double)b->cfg.align_cycles * CODES;
    b->s_x = b->s_y = b->s_xx = b->s_xy = b->s_n = 0.0;
    for (unsigned k = 0; k < 2; k++)
        for (unsigned d = 0; d < 3; d++)
            b->align_cs[k][d][0] = b->align_cs[k][d][1] = 0.0;
    b->p_min = b->p_max = b->pos[b->axis];
    b->mode = HG_MODE_ALIGN;
    b->drive = true;
    b->state = HG_BU_ALIGN_LOCK;
    fpga_write32(AX(b->axis, HG_AX_TQ_LIMIT),
                 (uint32_t)tau_code(b, (double)b->cfg.align_tau));
}

static void align_sample(hg_bringup_t *b, bool fwd)
{
    const int32_t p = b->pos[b->axis];
    const double x = floor(b->t_field) + 0.5; /* the angle ALIGN puts the vector at */
    const double y = (double)cdiff(p, b->p_start[b->axis]);
    b->s_x += x;
    b->s_y += y;
    b->s_xx += x * x;
    b->s_xy += x * y;
    b->s_n += 1.0;
    b->p_min = p < b->p_min ? p : b->p_min;
    b->p_max = p > b->p_max ? p : b->p_max;
    /* both signs' samples are summed; the line fit's slope says which one holds */
    const double u = count_angle(b, p);
    for (unsigned k = 0; k < 2; k++) {
        const double ang = (x - (k == 0 ? u : -u)) * TWO_PI_D / CODES;
        const double cs = cos(ang), sn = sin(ang);
        b->align_cs[k][0][0] += cs;
        b->align_cs[k][0][1] += sn;
        b->align_cs[k][fwd ? 1 : 2][0] += cs;
        b->align_cs[k][fwd ? 1 : 2][1] += sn;
    }
}

static void align_fit(hg_bringup_t *b)
{
    hg_bu_axis_t *r = &b->res[b->axis];
    const double cpr = (double)b->servo->cfg.enc[b->axis].counts_per_rev;
    const double pp = (double)b->cfg.pole_pairs;
    const double n = b->s_n;
    const double den = n * b->s_xx - b->s_x * b->s_x;
    const double slope = den > 0.0 ? (n * b->s_xy - b->s_x * b->s_y) / den : 0.0; /* counts/code */
    const int8_t s = slope < 0.0 ? -1 : 1;
    const double (*cs)[2] = b->align_cs[s > 0 ? 0 : 1];
    const double sc = cs[0][0], ss = cs[0][1];               /* all samples */
    const double fc = cs[1][0], fs = cs[1][1], bc = cs[2][0], bs = cs[2][1]; /* fwd, back */
    const double lambda = wrap_codes(atan2(ss, sc) * CODES / TWO_PI_D);
    const double lag = wrap_half((atan2(fs, fc) - atan2(bs, bc)) * CODES / TWO_PI_D) / 2.0;
    const double rbar = sqrt(sc * sc + ss * ss) / (n > 0.0 ? n : 1.0);
    /* circular standard deviation sqrt(-2 ln R), in electrical degrees */
    const double spread =
        rbar > 0.0 ? sqrt(-2.0 * log(rbar > 1.0 ? 1.0 : rbar)) * 360.0 / TWO_PI_D : 360.0;
    const double move = (double)cdiff(b->p_max, b->p_min) * pp * 360.0 / cpr;
    const double cpe = fabs(slope) * CODES;
    const double cpe_cfg = cpr / pp;
    const double cpe_err = fabs(cpe / cpe_cfg - 1.0) * 100.0;

    r->scan_sign = s;
    r->counts_per_elec = (float)cpe;
    r->counts_per_elec_cfg = (float)cpe_cfg;
    r->pole_pairs_meas = (float)(cpe > 0.0 ? cpr / cpe : 0.0);
    r->align_lambda = (float)lambda;
    r->offset_raw = (float)wrap_codes(lambda + QUARTER);
    r->move_elec_deg = (float)move;
    set_check(b, b->axis, HG_BU_CHK_ALIGN_MOVE, move, (double)b->cfg.align_min_move);
    set_check(b, b->axis, HG_BU_CHK_ALIGN_CPE, cpe_err, (double)b->cfg.align_cpe_tol * 100.0);
    set_check(b, b->axis, HG_BU_CHK_ALIGN_RESID, spread, (double)b->cfg.align_resid_max);
    set_check(b, b->axis, HG_BU_CHK_ALIGN_LAG, fabs(lag) * 360.0 / CODES,
              (double)b->cfg.align_lag_max);

    /* the first failing check names the error, in the order that explains the others */
    static const struct { unsigned chk; uint8_t err; } order[] = {
        { HG_BU_CHK_ALIGN_MOVE, HG_BU_ERR_NO_MOVE },
        { HG_BU_CHK_ALIGN_CPE, HG_BU_ERR_POLE_PAIRS },
        { HG_BU_CHK_ALIGN_RESID, HG_BU_ERR_FIT },
        { HG_BU_CHK_ALIGN_LAG, HG_BU_ERR_FIT },
    };
    for (unsigned k = 0; k < sizeof order / sizeof order[0]; k++) {
        const hg_bu_check_t *c = &r->chk[order[k].chk];
        if (!c->pass) {
            b->calib.axis[b->axis].flags &= (uint8_t)~HG_CAL_ALIGNED;
            r->aligned = false;
            fail(b, order[k].err, (double)c->value, (double)c->limit);
            return;
        }
    }
    b->calib.axis[b->axis].flags |= HG_CAL_ALIGNED;
    r->aligned = true;
    /* from here the field can place the rotor: walk it back to the reference pose */
    b->target = (double)cdiff(b->pos[b->axis], b->p_start[b->axis]);
    b->state = HG_BU_RETURN;
    field_at_count(b, (double)b->p_start[b->axis] + b->target);
}

static void align_tick(hg_bringup_t *b)
{
    const double per_tick = (double)b->cfg.align_rate * CODES / rate(b);
    const uint32_t lock = secs_to_ticks(b, (double)b->cfg.align_lock_s);
    const double full = (double)tau_code(b, (double)b->cfg.align_tau);
    switch (b->state) {
    case HG_BU_ALIGN_LOCK: {
        const double ramp = (double)b->ticks / (0.75 * (double)lock + 1.0);
        /* Near the unstable rest (half a cycle away) the rotor runs away as the current grows,
         * in a direction the scan has not measured yet: a governor that takes the current off
         * between 30 % and 60 % of speed_max bounds it without knowing the sign. */
        const double w =
            fabs((double)b->vel[b->axis]) / counts_per_rad(b) / (double)b->cfg.speed_max;
        const double gov = w < 0.3 ? 1.0 : (w > 0.6 ? 0.0 : (0.6 - w) / 0.3);
        b->torque = (int32_t)(full * (ramp < 1.0 ? ramp : 1.0) * gov);
        if (b->ticks >= lock) {
            b->state = HG_BU_ALIGN_FWD;
            b->torque = (int32_t)full;
            b->p_min = b->p_max = b->pos[b->axis]; /* movement counts from the scan on */
        }
        break;
    }
    case HG_BU_ALIGN_FWD:
        align_sample(b, true);
        b->t_field += per_tick;
        if (b->t_field >= b->scan_end) {
            b->t_field = b->scan_end;
            b->state = HG_BU_ALIGN_BACK;
        }
        break;
    case HG_BU_ALIGN_BACK:
        align_sample(b, false);
        b->t_field -= per_tick;
        if (b->t_field <= 0.0) {
            align_fit(b);
            return;
        }
        break;
    default:
        return_tick(b);
        return;
    }
    b->offset = (uint32_t)wrap_codes(floor(b->t_field));
}

/* ---------------------------------------------------------------- HOME */
/* The field is moved so that the rotor's rest follows a target count (field = lambda + s * u of
 * the target): a current-bounded, speed-bounded open-loop move that needs no working
 * commutation, whatever the wiring. The search goes home_range up, then down to home_range
 * below the start; the FPGA latches the index (HOME_ARM armed at the start); then the target
 * goes to the reference pose (the alignment leaves the rotor up to half a cycle from it) and
 * the step ends there at rest. A rotor that falls more than a quarter cycle behind its target is
 * blocked: that ends the step (NO_MOVE) before the field can drag it further. */


static void home_enter(hg_bringup_t *b)
{
    b->mode = HG_MODE_ALIGN;
    b->drive = true;
    b->torque = tau_code(b, (double)b->cfg.home_tau);
    b->dir = 1;
    b->leg = 0;
    b->target = 0.0;
    b->path = 0.0;
    b->state = HG_BU_HOME_SEARCH;
    fpga_write32(AX(b->axis, HG_AX_TQ_LIMIT), (uint32_t)b->torque);
    field_at_count(b, (double)b->p_start[b->axis]);
}

static void home_tick(hg_bringup_t *b, uint32_t *ctrl_extra)
{
    const unsigned a = b->axis;
    const double step = (double)b->cfg.home_speed * counts_per_rad(b) / rate(b);
    const double range = (double)b->cfg.home_range * counts_per_rad(b);
    hg_bu_axis_t *r = &b->res[a];
    if (b->ticks == 1)
        *ctrl_extra = HG_CTRL_HOME_ARM_AXIS(a);
    if (b->state == HG_BU_RETURN) {
        return_tick(b);
        return;
    }
    if (!rotor_follows(b))
        return;
    const double limit_deg = 3.0 * (double)b->cfg.home_range * 360.0 / TWO_PI_D;
    if ((b->status & HG_STAT_HOMED(a)) && b->ticks > 2) {
        r->home_count = cdiff(b->pos[a], b->pos_homed[a]);
        r->home_travel = (float)(b->path / counts_per_rad(b));
        r->home_virtual = false;
        r->homed = true;
        set_check(b, b->axis, HG_BU_CHK_HOME_TRAVEL,
                  b->path / counts_per_rad(b) * 360.0 / TWO_PI_D, limit_deg);
        b->calib.axis[a].flags |= HG_CAL_HOMED;
        b->state = HG_BU_RETURN;
        return;
    }
    b->target += (double)b->dir * step;
    b->path += step;
    if (b->leg == 0 && b->target >= range) {
        b->dir = -1;
        b->leg = 1;
    } else if (b->leg == 1 && b->target <= -range) {
        const double covered = b->path / counts_per_rad(b);
        r->home_travel = (float)covered;
        set_check(b, b->axis, HG_BU_CHK_HOME_TRAVEL, covered * 360.0 / TWO_PI_D, limit_deg);
        r->chk[HG_BU_CHK_HOME_TRAVEL].pass = 0; /* no index: fails whatever the figure */
        fail(b, HG_BU_ERR_NO_INDEX, covered, 3.0 * (double)b->cfg.home_range);
        return;
    }
    field_at_count(b, (double)b->p_start[a] + b->target);
}

/* ---------------------------------------------------------------- GUIDED */
/* Zero torque; each watched axis must move guided_min_move along the sign the named direction
 * gives its joint. Counts that run the other way mean the encoder counts against the joint:
 * enc_dir is flipped. An axis not seen by the timeout is refused (its torque stays off). */

static void guided_tick(hg_bringup_t *b)
{
    const double waited = (double)b->ticks / rate(b);
    bool all = true;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        if (b->expect[i] == 0)
            continue;
        hg_bu_axis_t *r = &b->res[i];
        const double cpr = (double)b->servo->cfg.enc[i].counts_per_rev;
        const double d = (double)cdiff(b->pos[i], b->p_start[i]) * TWO_PI_D / cpr;
        const double along = d * (double)r->dir_base * (double)b->expect[i];
        if (!(b->seen & (1u << i)) && fabs(d) >= (double)b->cfg.guided_min_move) {
            b->seen |= (uint8_t)(1u << i);
            r->guided_move = (float)fabs(d);
            r->guided_wait_s = (float)waited;
            r->guided_reversed = along < 0.0;
            r->refused = false;
            b->calib.axis[i].flags |= HG_CAL_DIR_SEEN;
        }
        all = all && (b->seen & (1u << i));
    }
    if (all || waited >= (double)b->cfg.guided_timeout_s) {
        uint8_t err = HG_BU_OK;
        for (unsigned i = 0; i < HG_NAXES; i++) {
            if (b->expect[i] == 0)
                continue;
            hg_bu_axis_t *r = &b->res[i];
            const bool seen = b->seen & (1u << i);
            const double cpr = (double)b->servo->cfg.enc[i].counts_per_rev;
            const double d = (double)cdiff(b->pos[i], b->p_start[i]) * TWO_PI_D / cpr;
            if (!seen) {
                r->guided_move = (float)fabs(d);
                r->guided_wait_s = (float)waited;
                r->refused = true;
                b->calib.axis[i].flags &= (uint8_t)~HG_CAL_DIR_SEEN;
                err = HG_BU_ERR_GUIDED_TIMEOUT;
            }
            set_check(b, i, HG_BU_CHK_GUIDED_WAIT, (double)r->guided_wait_s,
                      (double)b->cfg.guided_timeout_s);
            set_check(b, i, HG_BU_CHK_GUIDED_MOVE, (double)r->guided_move * 360.0 / TWO_PI_D,
                      (double)b->cfg.guided_min_move * 360.0 / TWO_PI_D);
            if (!seen)
                b->res[i].chk[HG_BU_CHK_GUIDED_WAIT].pass = 0;
            finalize_axis(b, i);
        }
        if (err != HG_BU_OK)
            fail(b, err, waited, (double)b->cfg.guided_timeout_s);
        else
            finish(b);
    }
}

/* ---------------------------------------------------------------- IDENT */
/* The axis is identified with the other two held: on the linkage a free joint swings under
 * the coupling (mass matrix, centrifugal terms) and its motion would enter the identified
 * axis's torque balance. Held (a stiff PD on each one's start position, bounded in torque by
 * its TQ_LIMIT and in travel by id_hold_travel), the identified axis sees the diagonal entry
 * of the joint-space mass matrix at the pose. Every axis is driven in its own scan sign's
 * direction x = s * counts (a positive code pushes toward increasing x).
 * Model, in that direction x (rad) with the applied torque tau (N m, nominal scale):
 *     J x'' + b x' + c sgn(x') + g = tau
 * integrated over windows of W ticks so no acceleration is needed:
 *     J (v_b - v_a) + b (x_b - x_a) + c sum sgn(dx) dt + g T + L (tau_b - tau_a) = sum tau dt
 * (L: the torque's lag behind the codes, tau_b, tau_a the torques of the window's last interval
 * and of the one before it)
 * (v by central differences over +-H ticks at the window edges, tau held over each tick as the
 * FPGA holds it). Each window is one row of a 5-unknown least-squares problem whose normal
 * equations are accumulated in place and solved by Cholesky after Jacobi scaling. The axis's
 * own PD hold keeps it near the reference pose (its torque is part of tau, so it does not bias
 * the fit). The torque is the code actually written, converted back: rounding and clamping are
 * inside the model. */

#define ID_WIN 20u
#define ID_AMP 0.2 /* each line's amplitude / id_tau: the six rarely reach the clamp together */
#define ID_H HG_BU_ID_H
#define ID_NX (2u * ID_H + 1u)

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s;
}

/* The commutation of axis i for a positive code to push toward increasing s * counts. s = +1:
 * the FPGA's SINE mode, the offset in its present frame (POS - POS_HOMED: 0 or the home).
 * s = -1: the FPGA's field cannot turn against the count, so the firmware places it every tick
 * (ALIGN mode, as the servo does for such an axis): field = offset_raw + s * u(count half a tick
 * ahead), floored (the ROM evaluates code k at k + 1/2). */
static void ident_commutate(const hg_bringup_t *b, unsigned i, uint32_t *mode, uint32_t *offset)
{
    const hg_bu_axis_t *r = &b->res[i];
    if (r->scan_sign > 0) {
        const int32_t frame = cdiff(b->pos[i], b->pos_homed[i]);
        *mode = HG_MODE_TORQUE;
        *offset = (uint32_t)(offset_in_frame(b, i, frame) + 0.5) & 1023u;
    } else {
        const int32_t ahead = b->vel[i] / (int32_t)(2u * b->servo->cfg.rate_hz);
        const int32_t p = (int32_t)((uint32_t)b->pos[i] + (uint32_t)ahead);
        *mode = HG_MODE_ALIGN;
        *offset = (uint32_t)floor(wrap_codes((double)r->offset_raw - count_angle(b, p))) & 1023u;
    }
}

/* The hold's error of axis i: its distance from its setpoint (rad, in the s * counts
 * direction). */
static double hold_error(const hg_bringup_t *b, unsigned i)
{
    return (double)b->id_sign[i] * ((double)cdiff(b->pos[i], b->p_start[i]) - b->id_set[i])
         / counts_per_rad_ax(b, i);
}

/* The held axes' torques and commutation for this tick (in IDENT_MOVE every axis is held, the
 * identified one within its own limit); the largest excursion of a held one while the axis is
 * excited. */
static void ident_hold(hg_bringup_t *b)
{
    const bool move = b->state == HG_BU_IDENT_MOVE;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        if (i == b->axis ? !move : !(b->held_mask & (1u << i)))
            continue;
        const double lim = i == b->axis && b->cfg.id_tau < b->cfg.id_hold_tau
                         ? (double)b->cfg.id_tau : (double)b->cfg.id_hold_tau;
        const double x = hold_error(b, i);
        const double v = (double)b->id_sign[i] * (double)b->vel[i] / counts_per_rad_ax(b, i);
        double tau = -(double)b->cfg.id_hold_kp * x - (double)b->cfg.id_hold_kd * v;
        tau = tau > lim ? lim : (tau < -lim ? -lim : tau);
        const int32_t code = tau_code_ax(b, i, tau);
        uint32_t mode, offset;
        ident_commutate(b, i, &mode, &offset);
        if (i == b->axis) {
            b->torque = code;
            b->mode = mode;
            b->offset = offset;
            continue;
        }
        b->hold_torque[i] = code;
        b->hold_mode[i] = mode;
        b->hold_offset[i] = offset;
        const float ax = (float)fabs(x);
        if (b->step == HG_BU_STEP_IDENT && !move && ax > b->res[b->axis].id_hold_max)
            b->res[b->axis].id_hold_max = ax;
    }
}

/* IDENT_MOVE: the setpoints walk to the reference pose at home_speed; the excitation starts
 * when every joint is within 1/64 electrical cycle of it and at rest: the pose is then the same
 * whatever the earlier steps left (the truth is the mass matrix at that pose). */
static void ident_start_run(hg_bringup_t *b);

static void ident_move_tick(hg_bringup_t *b)
{
    const double cpe = (double)HG_ENC_COUNTS_PER_REV / (double)b->cfg.pole_pairs;
    bool there = true;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        const double step = (double)b->cfg.home_speed * counts_per_rad_ax(b, i) / rate(b);
        const double d = b->id_goal[i] - b->id_set[i];
        b->id_set[i] = fabs(d) <= step ? b->id_goal[i] : b->id_set[i] + (d > 0.0 ? step : -step);
        const double err = fabs((double)cdiff(b->pos[i], b->p_start[i]) - b->id_goal[i]);
        const double speed = fabs((double)b->vel[i]) / counts_per_rad_ax(b, i);
        there = there && b->id_set[i] == b->id_goal[i] && err < cpe / 64.0
             && speed < 0.01 * (double)b->cfg.speed_max;
    }
    if (there)
        ident_start_run(b);
    else
        ident_hold(b);
}

/* ALIGN and HOME hold every other axis that is aligned where it was at the step's start:
 * free, the linkage's coupling would swing it (into an interpolator overspeed, once). */
static void hold_enter(hg_bringup_t *b)
{
    b->held_mask = 0;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        if (i == b->axis || !b->res[i].aligned)
            continue;
        b->held_mask |= (uint8_t)(1u << i);
        b->id_sign[i] = b->res[i].scan_sign < 0 ? (int8_t)-1 : (int8_t)1;
        b->id_set[i] = 0.0;
        b->hold_torque[i] = 0;
        fpga_write32(AX(i, HG_AX_TQ_LIMIT), (uint32_t)tau_code_ax(b, i, (double)b->cfg.id_hold_tau));
    }
}

static void ident_enter(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    hg_bu_axis_t *r = &b->res[a];
    b->drive = true;
    b->torque = 0;
    r->id_hold_max = 0.0f;
    b->held_mask = (uint8_t)(7u & ~(1u << a));
    for (unsigned i = 0; i < HG_NAXES; i++) {
        b->id_sign[i] = b->res[i].scan_sign < 0 ? (int8_t)-1 : (int8_t)1;
        b->hold_torque[i] = 0;
        b->id_set[i] = 0.0;
        b->id_goal[i] = (double)cdiff(b->res[i].ref_count, b->p_start[i]);
        const double lim = i == a ? (double)b->cfg.id_tau : (double)b->cfg.id_hold_tau;
        fpga_write32(AX(i, HG_AX_TQ_LIMIT), (uint32_t)tau_code_ax(b, i, lim));
    }
    b->state = HG_BU_IDENT_MOVE;
    ident_hold(b);
}

static void ident_start_run(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    hg_bu_axis_t *r = &b->res[a];
    for (unsigned i = 0; i < HG_NAXES; i++) {
        /* the pose, in the joint convention the calibration gives (homed axes only) */
        const double dir = b->calib.axis[i].enc_dir == -1 ? -1.0 : 1.0;
        r->id_q[i] = b->res[i].homed
                   ? (float)(dir * (double)cdiff(b->pos[i], b->res[i].enc_offset)
                             / counts_per_rad_ax(b, i))
                   : (float)NAN;
    }
    b->id_t0 = b->ticks;
    for (unsigned i = 0; i < HG_BU_ID_N; i++) {
        b->id_aty[i] = b->id_row[i] = 0.0;
        for (unsigned j = 0; j < HG_BU_ID_N; j++)
            b->id_ata[i][j] = 0.0;
    }
    b->id_yty = b->id_y = 0.0;
    for (unsigned i = 0; i < ID_NX; i++)
        b->id_x[i] = 0.0;
    for (unsigned i = 0; i <= ID_H; i++)
        b->id_tq[i] = 0.0;
    b->id_win = 0;
    b->id_rows = 0;
    b->id_v_start = b->id_x_start = b->id_tau_w = 0.0;
    b->id_xmax = 0.0;
    uint32_t seed = b->id_seed;
    for (unsigned k = 0; k < 6; k++)
        b->id_phase[k] = (double)(lcg(&seed) >> 8) / 16777216.0 * TWO_PI_D;
    b->state = HG_BU_IDENT_RUN;
    b->torque = 0;
    ident_hold(b); /* the others: this tick's hold */
    ident_commutate(b, a, &b->mode, &b->offset);
}

static void ident_accumulate(hg_bringup_t *b, double x_new)
{
    const double dt = 1.0 / rate(b);
    for (unsigned i = 0; i + 1 < ID_NX; i++)
        b->id_x[i] = b->id_x[i + 1];
    b->id_x[ID_NX - 1] = x_new;
    if (b->ticks - b->id_t0 < ID_NX)
        return; /* 2H + 1 positions needed for the first central difference */
    /* At tick k the centre c = k - H has its velocity, and the interval (c-1 -> c) is complete:
     * its torque is the one written at tick c - 1, id_tq[H]. (The wide difference keeps the
     * encoder's interpolation error out of the velocities.) */
    const double v_mid = (b->id_x[ID_NX - 1] - b->id_x[0]) / (2.0 * ID_H * dt);
    const double x_c = b->id_x[ID_H];
    const double dx = x_c - b->id_x[ID_H - 1];
    const double tq = b->id_tq[ID_H];
    if (b->id_win == 0) { /* first boundary */
        b->id_tau_w = tq;
        b->id_v_start = v_mid;
        b->id_x_start = x_c;
        b->id_win = 1;
        return;
    }
    b->id_row[2] += (dx > 0.0 ? 1.0 : (dx < 0.0 ? -1.0 : 0.0)) * dt;
    b->id_row[3] += dt;
    b->id_y += tq * dt; /* the torque held over that interval */
    if (b->id_win++ % ID_WIN == 0) {
        b->id_row[0] = v_mid - b->id_v_start;
        b->id_row[1] = x_c - b->id_x_start;
        /* the torque acting lags the code by L: its integral over the window is the codes'
         * minus L * (the last interval's torque - the one before the window) */
        b->id_row[4] = tq - b->id_tau_w;
        b->id_tau_w = tq;
        /* Only windows that moved one way throughout: at a reversal the joint may stick, and
         * static friction is anything within +-c, not c sgn(dx) (the window is left out). */
        if (fabs(b->id_row[2]) > b->id_row[3] - 0.5 * dt) {
            for (unsigned i = 0; i < HG_BU_ID_N; i++) {
                for (unsigned j = 0; j < HG_BU_ID_N; j++)
                    b->id_ata[i][j] += b->id_row[i] * b->id_row[j];
                b->id_aty[i] += b->id_row[i] * b->id_y;
            }
            b->id_yty += b->id_y * b->id_y;
            b->id_rows++;
        }
        b->id_v_start = v_mid;
        b->id_x_start = x_c;
        for (unsigned i = 0; i < HG_BU_ID_N; i++)
            b->id_row[i] = 0.0;
        b->id_y = 0.0;
    }
}

/* Solve (A) th = y for the symmetric positive definite 4x4 A, in place: Jacobi scaling, then
 * Cholesky. Returns false if A is not positive definite (an unexcited direction). */
static bool solve_spd(double a[HG_BU_ID_N][HG_BU_ID_N], double y[HG_BU_ID_N], double th[HG_BU_ID_N])
{
    double d[HG_BU_ID_N];
    for (unsigned i = 0; i < HG_BU_ID_N; i++) {
        if (!(a[i][i] > 0.0))
            return false;
        d[i] = 1.0 / sqrt(a[i][i]);
    }
    for (unsigned i = 0; i < HG_BU_ID_N; i++) {
        y[i] *= d[i];
        for (unsigned j = 0; j < HG_BU_ID_N; j++)
            a[i][j] *= d[i] * d[j];
    }
    for (unsigned j = 0; j < HG_BU_ID_N; j++) { /* A = L L^T, L in the lower triangle */
        double s = a[j][j];
        for (unsigned k = 0; k < j; k++)
            s -= a[j][k] * a[j][k];
        if (!(s > 1e-12))
            return false;
        a[j][j] = sqrt(s);
        for (unsigned i = j + 1; i < HG_BU_ID_N; i++) {
            double t = a[i][j];
            for (unsigned k = 0; k < j; k++)
                t -= a[i][k] * a[j][k];
            a[i][j] = t / a[j][j];
        }
    }
    for (unsigned i = 0; i < HG_BU_ID_N; i++) { /* L z = y */
        double t = y[i];
        for (unsigned k = 0; k < i; k++)
            t -= a[i][k] * y[k];
        y[i] = t / a[i][i];
    }
    for (unsigned i = HG_BU_ID_N; i-- > 0;) { /* L^T w = z */
        double t = y[i];
        for (unsigned k = i + 1; k < HG_BU_ID_N; k++)
            t -= a[k][i] * y[k];
        y[i] = t / a[i][i];
    }
    for (unsigned i = 0; i < HG_BU_ID_N; i++)
        th[i] = y[i] * d[i];
    return true;
}

static void ident_fit(hg_bringup_t *b)
{
    hg_bu_axis_t *r = &b->res[b->axis];
    const hg_motor_t *m = &b->servo->cfg.motor[b->axis];
    double a[HG_BU_ID_N][HG_BU_ID_N], y[HG_BU_ID_N], th[HG_BU_ID_N];
    for (unsigned i = 0; i < HG_BU_ID_N; i++) {
        y[i] = b->id_aty[i];
        for (unsigned j = 0; j < HG_BU_ID_N; j++)
            a[i][j] = b->id_ata[i][j];
    }
    const bool ok = solve_spd(a, y, th);
    double rr = b->id_yty;
    for (unsigned i = 0; i < HG_BU_ID_N && ok; i++) {
        rr -= 2.0 * th[i] * b->id_aty[i];
        for (unsigned j = 0; j < HG_BU_ID_N; j++)
            rr += th[i] * b->id_ata[i][j] * th[j];
    }
    const double resid = ok && b->id_yty > 0.0 ? sqrt((rr > 0.0 ? rr : 0.0) / b->id_yty) : 1.0;
    const int8_t dir = (int8_t)(b->id_sign[b->axis]
                                * (b->calib.axis[b->axis].enc_dir ? b->calib.axis[b->axis].enc_dir
                                                                  : b->servo->cfg.enc[b->axis].dir));
    r->inertia = (float)(ok ? th[0] : 0.0);
    r->b_visc = (float)(ok ? th[1] : 0.0);
    r->tau_coulomb = (float)(ok ? th[2] : 0.0);
    r->tau_gravity = (float)(ok ? th[3] * (double)dir : 0.0);
    r->kt_amp = (float)((double)m->kt * (double)m->amp_gain);
    r->ident_resid = (float)resid;
    r->id_lag = (float)(ok ? th[4] : 0.0);
    /* standard errors: s^2 = rr / (rows - N), times the diagonal of (A^T A)^-1 (column i of
     * the inverse solves A z = e_i) */
    const double s2 = b->id_rows > HG_BU_ID_N ? (rr > 0.0 ? rr : 0.0)
                                                   / (double)(b->id_rows - HG_BU_ID_N) : 0.0;
    for (unsigned k = 0; k < 4; k++) {
        double e[HG_BU_ID_N], z[HG_BU_ID_N];
        for (unsigned i = 0; i < HG_BU_ID_N; i++) {
            e[i] = i == k ? 1.0 : 0.0;
            for (unsigned j = 0; j < HG_BU_ID_N; j++)
                a[i][j] = b->id_ata[i][j];
        }
        r->id_se[k] = (float)(ok && solve_spd(a, e, z) && z[k] > 0.0 ? sqrt(s2 * z[k]) : 0.0);
    }
    set_check(b, b->axis, HG_BU_CHK_IDENT_RESID, resid * 100.0,
              (double)b->cfg.id_resid_max * 100.0);
    set_check(b, b->axis, HG_BU_CHK_IDENT_TRAVEL, b->id_xmax * 360.0 / TWO_PI_D,
              (double)b->cfg.travel_max * 360.0 / TWO_PI_D);
    set_check(b, b->axis, HG_BU_CHK_IDENT_HOLD, (double)r->id_hold_max * 360.0 / TWO_PI_D,
              (double)b->cfg.id_hold_travel * 360.0 / TWO_PI_D);
    if (!ok || !(th[0] > 0.0) || !r->chk[HG_BU_CHK_IDENT_RESID].pass)
        fail(b, HG_BU_ERR_FIT, resid * 100.0, (double)b->cfg.id_resid_max * 100.0);
    else
        finish(b);
}

static void ident_tick(hg_bringup_t *b)
{
    if (b->state == HG_BU_IDENT_MOVE) {
        ident_move_tick(b);
        return;
    }
    const uint32_t n = b->ticks - b->id_t0; /* ticks into the excitation */
    const double t = (double)n / rate(b);
    const double x = hold_error(b, b->axis); /* from the reference pose */
    const double v = (x - b->id_x[ID_NX - 1]) * rate(b);
    b->id_xmax = fabs(x) > b->id_xmax ? fabs(x) : b->id_xmax;
    if (b->state == HG_BU_IDENT_RUN) {
        ident_accumulate(b, x);
    } else {
        for (unsigned i = 0; i + 1 < ID_NX; i++)
            b->id_x[i] = b->id_x[i + 1];
        b->id_x[ID_NX - 1] = x;
    }
    const double dur = (double)b->cfg.id_duration_s;
    double tau = -(double)b->cfg.id_kp * x - (double)b->cfg.id_kd * (n > 1 ? v : 0.0);
    if (b->state == HG_BU_IDENT_RUN) {
        /* raised-cosine fade in and out over 0.5 s: no step in torque */
        const double fade_t = t < 0.5 ? t : (dur - t < 0.5 ? dur - t : 0.5);
        const double fade = 0.5 - 0.5 * cos(TWO_PI_D * (fade_t > 0.0 ? fade_t : 0.0));
        double ex = 0.0;
        for (unsigned k = 0; k < 6; k++)
            ex += sin(TWO_PI_D * ID_FREQ[k] * t + b->id_phase[k]);
        tau += fade * ID_AMP * (double)b->cfg.id_tau * ex;
        if (t >= dur)
            b->state = HG_BU_IDENT_SETTLE;
    } else if (t >= dur + (double)b->cfg.id_settle_s) {
        b->torque = 0;
        ident_fit(b);
        return;
    }
    const double lim = (double)b->cfg.id_tau;
    tau = tau > lim ? lim : (tau < -lim ? -lim : tau);
    b->torque = tau_code(b, tau);
    ident_commutate(b, b->axis, &b->mode, &b->offset);
    ident_hold(b);
    /* the torques written, latest first (each held over the interval after its tick) */
    for (unsigned i = ID_H; i > 0; i--)
        b->id_tq[i] = b->id_tq[i - 1];
    b->id_tq[0] = (double)b->torque / code_per_nm(&b->servo->cfg.motor[b->axis]);
}

/* ---------------------------------------------------------------- ENCODER */
/* The rotor's rest walks toward increasing counts at home_speed (field = lambda + s * u of the
 * target, as in HOME, current home_tau). The ALIGN field alone is a spring with almost no
 * damping, and a ringing rotor does not turn at the steady speed the signal-quality fit needs
 * (hapgate.golden.encquality), so the rest point is moved back by enc_damp_s x the speed error.
 * The speed is the count's tick differences low-passed over one line period: the interpolator's
 * angle error repeats every line (harmonics, a weak channel), and a damping fed with it would
 * move the rotor in step with the line, which the fit reads as signal shape.
 * After enc_settle_s the capture buffer is armed on this axis (from the next sample, one in
 * decim + 1, decim chosen so that the full buffer spans enc_lines lines at home_speed). When the
 * buffer is full the axis's CAL_* registers are read, and the rotor walks back to the reference
 * pose (RETURN). The PC reads the entries afterwards (CAP_READ). */

static double enc_lines_per_s(const hg_bringup_t *b, unsigned axis)
{
    const double cpl = (double)HG_ENC_COUNTS_PER_REV / 1024.0; /* counts per line */
    return (double)b->cfg.home_speed * (double)b->servo->cfg.enc[axis].counts_per_rev
           / TWO_PI_D / cpl;
}

/* One sample in decim + 1 so that `entries` samples span enc_lines lines (HG_CAP ceiling: the
 * DECIM field's 16 bits, checked by the caller). */
static double enc_decim_for(const hg_bringup_t *b, unsigned axis, uint32_t entries)
{
    const double t = (double)b->cfg.enc_lines / enc_lines_per_s(b, axis);
    const double d = ceil(t * (double)b->cfg.enc_sample_hz / (double)entries) - 1.0;
    return d < 0.0 ? 0.0 : d;
}

static void encoder_enter(hg_bringup_t *b)
{
    b->mode = HG_MODE_ALIGN;
    b->drive = true;
    b->torque = tau_code(b, (double)b->cfg.home_tau);
    b->target = 0.0;
    b->enc_armed = false;
    b->enc_prev = b->pos[b->axis];
    b->enc_vf = 0.0;
    b->state = HG_BU_ENC_SWEEP;
    fpga_write32(AX(b->axis, HG_AX_TQ_LIMIT), (uint32_t)b->torque);
    field_at_count(b, (double)b->p_start[b->axis]);
}

static void encoder_tick(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    hg_bu_axis_t *r = &b->res[a];
    if (b->state == HG_BU_RETURN) {
        return_tick(b);
        return;
    }
    if (!rotor_follows(b))
        return;
    const double v = (double)b->cfg.home_speed * counts_per_rad(b); /* counts/s */
    const double tau = 1.0 / enc_lines_per_s(b, a), dt = 1.0 / rate(b);
    b->enc_vf += dt / (tau + dt) * ((double)cdiff(b->pos[a], b->enc_prev) / dt - b->enc_vf);
    b->enc_prev = b->pos[a];
    if (b->ticks > secs_to_ticks(b, (double)b->cfg.enc_settle_s)) {
        if (!b->enc_armed) {
            const hg_cap_cfg_t cc = { a, false, 0u, r->enc_decim };
            if (hg_cap_arm(&cc) != HG_CAP_OK) {
                fail(b, HG_BU_ERR_CAPTURE, 0.0, 1.0);
                return;
            }
            b->enc_armed = true;
        } else {
            uint32_t n = 0;
            const int st = hg_cap_poll(&n);
            r->enc_entries = n;
            if (st == HG_CAP_OK) {
                r->enc_captured = true;
                r->enc_cal[0] = fpga_read32(AX(a, HG_AX_CAL_CTRL));
                r->enc_cal[1] = fpga_read32(AX(a, HG_AX_CAL_STAT));
                r->enc_cal[2] = fpga_read32(AX(a, HG_AX_CAL_OFS));
                r->enc_cal[3] = fpga_read32(AX(a, HG_AX_CAL_GAIN));
                r->enc_cal[4] = fpga_read32(AX(a, HG_AX_CAL_PHASE));
                b->state = HG_BU_RETURN; /* the field stays where it is this tick */
                return;
            }
            if (st != HG_CAP_PENDING) {
                fail(b, HG_BU_ERR_CAPTURE, (double)n, (double)hg_cap_limit(a));
                return;
            }
        }
    }
    b->target += v / rate(b);
    const double lead = -(double)b->cfg.enc_damp_s * (b->enc_vf - v);
    field_at_count(b, (double)b->p_start[a] + b->target + lead);
}

/* ---------------------------------------------------------------- the tick */

static bool read_snapshot(hg_bringup_t *b)
{
    const uint32_t seq0 = fpga_read32(HG_REG_SEQ);
    b->status = fpga_read32(HG_REG_STATUS);
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        b->pos[i] = (int32_t)fpga_read32(AX(i, HG_AX_POS));
        b->vel[i] = (int32_t)fpga_read32(AX(i, HG_AX_VEL));
        b->pos_homed[i] = (int32_t)fpga_read32(AX(i, HG_AX_POS_HOMED));
    }
    const uint32_t seq1 = fpga_read32(HG_REG_SEQ);
    const uint32_t dseq = seq0 - b->seq;
    const bool ok = seq0 == seq1
                 && (!b->have_prev || (dseq >= 1u && dseq <= 1u + b->servo->cfg.max_missed));
    if (!ok) {
        fail(b, HG_BU_ERR_STALE, (double)dseq, 1.0 + (double)b->servo->cfg.max_missed);
        return false;
    }
    b->seq = seq0;
    b->have_prev = true;
    return true;
}

/* The bounds every step shares: FPGA faults and watchdog, the servo's latch, and for the steps
 * that drive, speed, travel from the step's start and time. */
static bool within_bounds(hg_bringup_t *b)
{
    const unsigned a = b->axis;
    for (unsigned i = 0; i < HG_NAXES; i++)
        if (b->status & HG_STAT_FAULT(i)) {
            fail(b, HG_BU_ERR_FAULT, (double)i, 0.0);
            return false;
        }
    if (b->status & HG_STAT_WDOG) {
        fail(b, HG_BU_ERR_WDOG, 1.0, 0.0);
        return false;
    }
    if (b->servo->err != HG_ERR_NONE) {
        fail(b, HG_BU_ERR_SERVO, (double)b->servo->err, 0.0);
        return false;
    }
    if (b->ticks > b->tick_limit) {
        fail(b, HG_BU_ERR_TIME, (double)b->ticks / rate(b), (double)b->tick_limit / rate(b));
        return false;
    }
    if (b->step == HG_BU_STEP_GUIDED)
        return true; /* no torque: the operator may move as far and as fast as the linkage goes */
    const double speed = fabs((double)b->vel[a]) / counts_per_rad(b);
    if (speed > (double)b->cfg.speed_max) {
        fail(b, HG_BU_ERR_SPEED, speed, (double)b->cfg.speed_max);
        return false;
    }
    const double travel = fabs((double)cdiff(b->pos[a], b->p_start[a]))
                        / counts_per_rad(b);
    if (travel > (double)b->cfg.travel_max) {
        fail(b, HG_BU_ERR_TRAVEL, travel, (double)b->cfg.travel_max);
        return false;
    }
    if (b->held_mask && b->ticks > 0) /* held joints: speed, hold error */
        for (unsigned i = 0; i < HG_NAXES; i++) {
            if (!(b->held_mask & (1u << i)))
                continue;
            const double sp = fabs((double)b->vel[i]) / counts_per_rad_ax(b, i);
            const double tr = fabs(hold_error(b, i)); /* from its setpoint */
            if (sp > (double)b->cfg.speed_max) {
                fail(b, HG_BU_ERR_SPEED, sp, (double)b->cfg.speed_max);
                return false;
            }
            if (tr > (double)b->cfg.id_hold_travel) {
                fail(b, HG_BU_ERR_TRAVEL, tr, (double)b->cfg.id_hold_travel);
                return false;
            }
        }
    return true;
}

void hg_bringup_step(hg_bringup_t *b)
{
    if (b->state == HG_BU_IDLE)
        return;
    if (!read_snapshot(b))
        return;
    if (b->ticks == 0) /* the step's first snapshot: its start pose */
        for (unsigned i = 0; i < HG_NAXES; i++)
            b->p_start[i] = b->pos[i];
    if (!within_bounds(b))
        return;
    uint32_t ctrl_extra = 0;
    if (b->ticks == 0) {
        switch (b->step) {
        case HG_BU_STEP_ALIGN: align_enter(b); break;
        case HG_BU_STEP_HOME: home_enter(b); break;
        case HG_BU_STEP_IDENT: ident_enter(b); break;
        case HG_BU_STEP_ENCODER: encoder_enter(b); break;
        default: b->drive = false; b->mode = HG_MODE_OFF; b->state = HG_BU_GUIDED_WAIT; break;
        }
    }
    const bool hold_others = b->step == HG_BU_STEP_ALIGN || b->step == HG_BU_STEP_HOME;
    if (b->ticks == 0 && hold_others)
        hold_enter(b);
    b->ticks++;
    switch (b->step) {
    case HG_BU_STEP_ALIGN: align_tick(b); break;
    case HG_BU_STEP_HOME: home_tick(b, &ctrl_extra); break;
    case HG_BU_STEP_IDENT: ident_tick(b); break;
    case HG_BU_STEP_ENCODER: encoder_tick(b); break;
    default: guided_tick(b); break;
    }
    if (hold_others && b->state != HG_BU_IDLE)
        ident_hold(b);
    if (b->state != HG_BU_IDLE)
        write_outputs(b, ctrl_extra);
}

void hg_bringup_isr(void)
{
    if (hg_bringup_isr_ctx && hg_bringup_active(hg_bringup_isr_ctx)) {
        hg_bringup_step(hg_bringup_isr_ctx);
        fpga_write32(HG_REG_IRQ, HG_IRQ_TICK);
    } else {
        hg_servo_isr();
    }
}

/* ---------------------------------------------------------------- background */

void hg_bringup_init(hg_bringup_t *b, hg_servo_t *s, const hg_bringup_cfg_t *cfg,
                     const hg_calib_t *known)
{
    *b = (hg_bringup_t){ 0 };
    b->servo = s;
    b->cfg = *cfg;
    if (known)
        b->calib = *known;
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        b->res[i].ref_count = (int32_t)fpga_read32(AX(i, HG_AX_POS));
        if (!known) {
            b->calib.axis[i].enc_dir = s->cfg.enc[i].dir;
            b->calib.axis[i].pole_pairs = cfg->pole_pairs;
        }
        b->res[i].dir_base = b->calib.axis[i].enc_dir == -1 ? (int8_t)-1 : (int8_t)1;
    }
    b->state = HG_BU_IDLE;
}

bool hg_bringup_active(const hg_bringup_t *b)
{
    return b->state != HG_BU_IDLE;
}

/* RESTART: the paper's power-up in the reference pose. The stored calibration gives the
 * reference pose's count from the home (index_to_zero + enc_dir * q_ref), so the home of this
 * power-up is virtual: ref_count minus that. The FPGA is not homed (POS_HOMED = POS), so the
 * commutation offset moves from the index frame into the raw frame by s * u(virtual home). */
static int restart(hg_bringup_t *b, uint8_t axis)
{
    hg_axis_calib_t *c = &b->calib.axis[axis];
    hg_bu_axis_t *r = &b->res[axis];
    const uint8_t need = HG_CAL_HOMED | HG_CAL_ALIGNED;
    if ((c->flags & need) != need || (c->enc_dir != 1 && c->enc_dir != -1))
        return HG_BU_ERR_NOT_READY;
    if (fpga_read32(HG_REG_STATUS) & HG_STAT_HOMED(axis))
        return HG_BU_ERR_ARG; /* homed already: the stored calibration applies as it is */
    const double cpr = (double)b->servo->cfg.enc[axis].counts_per_rev;
    const int32_t q_counts = (int32_t)lround((double)b->cfg.q_ref[axis] * cpr / TWO_PI_D);
    const int32_t d_ref = (int32_t)((uint32_t)c->index_to_zero + (uint32_t)(c->enc_dir * q_counts));
    const int8_t s = (int8_t)(c->phases_swapped ? -c->enc_dir : c->enc_dir);
    r->home_count = cdiff(r->ref_count, d_ref);
    r->home_virtual = true;
    r->scan_sign = s;
    r->enc_offset = (int32_t)((uint32_t)r->home_count + (uint32_t)c->index_to_zero);
    const double off =
        wrap_codes((double)c->comm_offset - (double)s * count_angle(b, r->home_count));
    c->comm_offset = (uint32_t)(off + 0.5) & 1023u;
    r->duration_s[HG_BU_STEP_RESTART] = 0.0f;
    return HG_BU_OK;
}

unsigned hg_bringup_power_up(hg_bringup_t *b)
{
    hg_servo_t *s = b->servo;
    const uint32_t status = fpga_read32(HG_REG_STATUS);
    unsigned mask = 0;
    for (uint8_t i = 0; i < HG_NAXES; i++) {
        const bool fpga_homed = (status & HG_STAT_HOMED(i)) != 0;
        if (!fpga_homed && restart(b, i) != HG_BU_OK)
            continue; /* no stored calibration: bring-up finds it */
        if (fpga_homed && (b->calib.axis[i].flags & (HG_CAL_HOMED | HG_CAL_ALIGNED))
                              != (HG_CAL_HOMED | HG_CAL_ALIGNED))
            continue;
        hg_axis_calib_t c = b->calib.axis[i];
        if (hg_servo_set_calib(s, i, &c) != 0) /* homes on IDX_POS when the FPGA has homed */
            continue;
        if (!fpga_homed) { /* the restart's virtual home */
            const uint32_t t = hg_hal_irq_save();
            hg_enc_home(&s->cfg.enc[i], b->res[i].home_count);
            hg_hal_irq_restore(t);
        }
        mask |= 1u << i;
    }
    return mask;
}

int hg_bringup_start(hg_bringup_t *b, uint8_t step, uint8_t axis, const int8_t expect[3],
                     uint32_t seed)
{
    const hg_bringup_cfg_t *c = &b->cfg;
    if (b->state != HG_BU_IDLE || b->servo->enabled)
        return HG_BU_ERR_BUSY;
    if (b->servo->err != HG_ERR_NONE)
        return HG_BU_ERR_SERVO;
    if (axis >= HG_NAXES || step == HG_BU_STEP_NONE || step > HG_BU_STEP_ENCODER)
        return HG_BU_ERR_ARG;
    if (c->pole_pairs == 0)
        return HG_BU_ERR_CONFIG;
    uint32_t limit_s = 0; /* time bound, s (ceiling) */
    switch (step) {
    case HG_BU_STEP_ALIGN: {
        /* worst travel: half a cycle to the first rest, then the scan */
        const double plan = ((double)c->align_cycles + 0.5) / (double)c->pole_pairs * TWO_PI_D;
        if (!(c->align_cycles > HG_C(0.0) && c->align_rate > HG_C(0.0) && c->align_tau > HG_C(0.0)))
            return HG_BU_ERR_ARG;
        if (plan > (double)c->travel_max) {
            b->err_value = (float)plan;
            b->err_limit = (float)c->travel_max;
            return HG_BU_ERR_CONFIG;
        }
        /* lock, the scan both ways, the walk back (at most half a cycle) */
        limit_s = (uint32_t)((double)c->align_lock_s
                             + 2.0 * (double)c->align_cycles / (double)c->align_rate
                             + TWO_PI_D / 2.0 / (double)c->pole_pairs / (double)c->home_speed) + 3u;
        for (unsigned k = HG_BU_CHK_ALIGN_MOVE; k <= HG_BU_CHK_ALIGN_LAG; k++)
            b->res[axis].chk[k].done = 0;
        b->res[axis].aligned = b->res[axis].homed = false; /* a new scan: the old frame is gone */
        break;
    }
    case HG_BU_STEP_HOME:
        if (!b->res[axis].aligned) /* the field must be placed: lambda of this power-up */
            return HG_BU_ERR_NOT_READY;
        b->res[axis].homed = false;
        if (!(c->home_speed > HG_C(0.0) && c->home_range > HG_C(0.0)))
            return HG_BU_ERR_ARG;
        const double plan = (double)c->home_range + TWO_PI_D / 4.0 / (double)c->pole_pairs;
        if (plan > (double)c->travel_max) {
            b->err_value = (float)c->home_range;
            b->err_limit = (float)c->travel_max;
            return HG_BU_ERR_CONFIG;
        }
        limit_s = (uint32_t)(5.0 * (double)c->home_range / (double)c->home_speed) + 3u;
        b->res[axis].chk[HG_BU_CHK_HOME_TRAVEL].done = 0;
        break;
    case HG_BU_STEP_RESTART: {
        const int rc = restart(b, axis);
        b->err = (uint8_t)rc;
        return rc;
    }
    case HG_BU_STEP_GUIDED: {
        bool any = false;
        for (unsigned i = 0; i < HG_NAXES; i++) {
            if (!expect || expect[i] < -1 || expect[i] > 1)
                return HG_BU_ERR_ARG;
            b->expect[i] = expect[i];
            any = any || expect[i] != 0;
            if (expect[i] != 0) {
                b->res[i].chk[HG_BU_CHK_GUIDED_WAIT].done = 0;
                b->res[i].chk[HG_BU_CHK_GUIDED_MOVE].done = 0;
            }
        }
        if (!any)
            return HG_BU_ERR_ARG;
        b->seen = 0;
        limit_s = (uint32_t)c->guided_timeout_s + 2u;
        break;
    }
    case HG_BU_STEP_ENCODER: {
        hg_bu_axis_t *r = &b->res[axis];
        if (!r->aligned) /* the field must be placed: lambda of this power-up */
            return HG_BU_ERR_NOT_READY;
        if (!(c->home_speed > HG_C(0.0) && c->home_tau > HG_C(0.0) && c->enc_lines > HG_C(0.0)
              && c->enc_settle_s >= HG_C(0.0) && c->enc_damp_s >= HG_C(0.0)
              && c->enc_sample_hz > HG_C(0.0)))
            return HG_BU_ERR_ARG;
        const uint32_t entries = hg_cap_limit(axis);
        if (entries == 0) { /* an FPGA built without the capture buffer */
            b->err_value = 0.0f;
            b->err_limit = 1.0f;
            return HG_BU_ERR_CAPTURE;
        }
        const double decim = enc_decim_for(b, axis, entries);
        const double cap_s = (double)entries * (decim + 1.0) / (double)c->enc_sample_hz;
        /* the sweep until the buffer is full (two ticks of polling), a quarter cycle of lag */
        const double sweep_s = (double)c->enc_settle_s + cap_s + 2.0 / (double)b->servo->cfg.rate_hz;
        const double sweep_plan = (double)c->home_speed * sweep_s
                          + TWO_PI_D / 4.0 / (double)c->pole_pairs;
        if (decim > 65535.0 || sweep_plan > (double)c->travel_max) {
            b->err_value = (float)(decim > 65535.0 ? decim : sweep_plan);
            b->err_limit = (float)(decim > 65535.0 ? 65535.0 : (double)c->travel_max);
            return HG_BU_ERR_CONFIG;
        }
        /* the sweep, then the walk back over the same travel */
        limit_s = (uint32_t)(2.0 * sweep_s + TWO_PI_D / 4.0 / (double)c->pole_pairs
                                                 / (double)c->home_speed) + 3u;
        r->enc_decim = (uint32_t)decim;
        r->enc_entries = 0;
        r->enc_captured = false;
        r->enc_speed = (float)c->home_speed;
        for (unsigned k = 0; k < 5; k++)
            r->enc_cal[k] = 0;
        break;
    }
    default: /* IDENT */
        /* every axis is driven: the identified one, and the others held */
        for (unsigned i = 0; i < HG_NAXES; i++)
            if (!b->res[i].aligned) {
                b->err_value = (float)i; /* the first axis not aligned */
                b->err_limit = 0.0f;
                return HG_BU_ERR_NOT_READY;
            }
        if (!(c->id_tau > HG_C(0.0) && c->id_duration_s > HG_C(1.0) && c->id_hold_tau > HG_C(0.0)
              && c->id_hold_kp >= HG_C(0.0) && c->id_hold_kd >= HG_C(0.0)
              && c->id_hold_travel > HG_C(0.0) && c->id_hold_travel <= c->travel_max))
            return HG_BU_ERR_ARG;
        /* the walk back to the reference pose (at most travel_max), the excitation, the hold */
        limit_s = (uint32_t)((double)c->travel_max / (double)c->home_speed + 2.0
                             + (double)c->id_duration_s + (double)c->id_settle_s) + 2u;
        b->id_seed = seed;
        b->res[axis].chk[HG_BU_CHK_IDENT_RESID].done = 0;
        b->res[axis].chk[HG_BU_CHK_IDENT_TRAVEL].done = 0;
        b->res[axis].chk[HG_BU_CHK_IDENT_HOLD].done = 0;
        break;
    }
    const uint32_t t = hg_hal_irq_save();
    b->step = step;
    b->axis = axis;
    b->err = HG_BU_OK;
    b->err_value = b->err_limit = 0.0f;
    b->ticks = 0;
    b->held_mask = 0;
    b->tick_limit = limit_s * b->servo->cfg.rate_hz;
    b->have_prev = false;
    b->drive = false;
    b->torque = 0;
    b->mode = HG_MODE_ALIGN;
    b->offset = 0;
    b->state = step == HG_BU_STEP_ALIGN ? HG_BU_ALIGN_LOCK
             : step == HG_BU_STEP_HOME ? HG_BU_HOME_SEARCH
             : step == HG_BU_STEP_GUIDED ? HG_BU_GUIDED_WAIT
             : step == HG_BU_STEP_ENCODER ? HG_BU_ENC_SWEEP : HG_BU_IDENT_MOVE;
    hg_hal_irq_restore(t);
    return HG_BU_OK;
}

void hg_bringup_abort(hg_bringup_t *b, uint8_t reason)
{
    const uint32_t t = hg_hal_irq_save();
    if (b->state != HG_BU_IDLE)
        fail(b, reason == HG_BU_ERR_LINK ? HG_BU_ERR_LINK : HG_BU_ERR_ABORT, 0.0, 0.0);
    else
        write_zero();
    hg_hal_irq_restore(t);
}

hg_bu_check_info_t hg_bringup_check(const hg_bringup_t *b, uint8_t axis, unsigned id)
{
    hg_bu_check_info_t r = { 0 };
    if (axis >= HG_NAXES || id >= HG_BU_NCHECKS)
        return r;
    const hg_bu_check_t *c = &b->res[axis].chk[id];
    r.name = CHECKS[id].name;
    r.unit = CHECKS[id].unit;
    r.ge = CHECKS[id].ge;
    r.value = c->value;
    r.limit = c->limit;
    r.done = c->done != 0;
    r.pass = c->pass != 0;
    return r;
}

hg_real hg_bringup_offset_deg(uint32_t comm_offset)
{
    return (hg_real)(comm_offset & 1023u) * HG_C(360.0) / HG_C(1024.0);
}
