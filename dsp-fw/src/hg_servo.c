/* SPDX-License-Identifier: Apache-2.0 */
/* Servo step, safety latch, command interface. */
#include "hg_servo.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"

hg_servo_t *hg_servo_isr_ctx;

#define DEG(x) ((x) * HG_PI / HG_C(180.0))

void hg_servo_default_cfg(hg_servo_cfg_t *cfg)
{
    static const hg_linkage_t link = HG_LINKAGE_DEFAULT;
    static const hg_guard_t guard = HG_GUARD_DEFAULT;
    /* walls keep |cos alpha| >= 0.5 and |sin(beta+gamma)| >= 0.34, away from every guard */
    static const hg_walls_t walls = {
        .w = { { { 1, 0, 0 }, DEG(HG_C(-60.0)), DEG(HG_C(60.0)) },
               { { 0, 1, 0 }, DEG(HG_C(-60.0)), DEG(HG_C(85.0)) },
               { { 0, 0, 1 }, DEG(HG_C(-60.0)), DEG(HG_C(85.0)) },
               { { 0, 1, 1 }, DEG(HG_C(20.0)), DEG(HG_C(160.0)) } },
        .k = HG_C(2.0),
        .b = HG_C(0.01),
    };
    /* 8 A / 10 V amplifier (paper: S16A8), 0.06 N m/A: 0.48 N m full scale */
    static const hg_motor_t motor = { HG_C(0.06), HG_C(0.8), HG_C(10.0), HG_C(0.3), 1, 0 };
    static const hg_enc_cal_t enc = { 1, 0, HG_ENC_COUNTS_PER_REV, 0 };

    *cfg = (hg_servo_cfg_t){ 0 };
    cfg->rate_hz = 1000;
    cfg->fpga_clk_hz = 48000000;
    cfg->link = link;
    cfg->guard = guard;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        cfg->enc[i] = enc;
        cfg->motor[i] = motor;
    }
    cfg->walls = walls;
    for (unsigned i = 0; i < HG_NAXES; i++) {
        const hg_axis_calib_t cal = { HG_CAL_HOMED | HG_CAL_ALIGNED, 1, 0, HG_FPGA_POLE_PAIRS, 0,
                                      0 };
        cfg->cal.axis[i] = cal;
    }
    cfg->f_max = HG_C(10.0);         /* N, the paper's peak endpoint force  */
    cfg->fi_max = HG_C(2.0);
    cfg->qd_max = HG_C(100.0);       /* rad/s: 10 m/s at the 0.1 m reach   */
    cfg->pc_force_timeout = 100;     /* ticks (100 ms at 1 kHz)            */
    cfg->max_missed = 2;
}

static bool cfg_ok(const hg_servo_cfg_t *c)
{
    bool ok = c->rate_hz >= HG_RATE_MIN && c->rate_hz <= HG_RATE_MAX
           && c->fpga_clk_hz >= c->rate_hz && c->link.l_beta > HG_C(0.0)
           && c->link.l_gamma > HG_C(0.0) && isfinite(c->link.h)
           && c->f_max > HG_C(0.0) && c->fi_max >= HG_C(0.0) && c->qd_max > HG_C(0.0);
    for (unsigned i = 0; i < HG_NAXES; i++) {
        const hg_motor_t *m = &c->motor[i];
        ok = ok && c->enc[i].counts_per_rev > 0 && (c->enc[i].dir == 1 || c->enc[i].dir == -1)
          && (m->dir == 1 || m->dir == -1) && m->kt > HG_C(0.0) && m->amp_gain > HG_C(0.0)
          && m->dac_fs > HG_C(0.0) && m->tau_max >= HG_C(0.0) && isfinite(m->tau_max)
          && hg_calib_axis_ok(&c->cal.axis[i]);
    }
    return ok;
}

bool hg_calib_axis_ok(const hg_axis_calib_t *c)
{
    return (c->flags & ~(uint32_t)(HG_CAL_HOMED | HG_CAL_ALIGNED | HG_CAL_DIR_SEEN)) == 0
        && (c->enc_dir == 1 || c->enc_dir == -1) && c->phases_swapped <= 1
        && c->comm_offset < HG_OFFSET_CODES
        && (!(c->flags & HG_CAL_ALIGNED) || c->pole_pairs == HG_FPGA_POLE_PAIRS);
}

int hg_calib_comm_dir(const hg_axis_calib_t *c)
{
    return (c->enc_dir == -1) != (c->phases_swapped != 0) ? -1 : 1;
}

bool hg_servo_axis_calibrated(const hg_servo_t *s, unsigned axis)
{
    const unsigned need = HG_CAL_HOMED | HG_CAL_ALIGNED;
    return (s->cfg.cal.axis[axis].flags & need) == need;
}

bool hg_servo_calibrated(const hg_servo_t *s)
{
    for (unsigned i = 0; i < HG_NAXES; i++)
        if (!hg_servo_axis_calibrated(s, i))
            return false;
    return true;
}

/* The firmware-commutated axis (hg_calib_comm_dir = -1, aligned): MODE = ALIGN. */
static bool fw_commutated(const hg_servo_t *s, unsigned axis)
{
    const hg_axis_calib_t *c = &s->cfg.cal.axis[axis];
    return (c->flags & HG_CAL_ALIGNED) && hg_calib_comm_dir(c) < 0;
}

/* The calibration onto the working fields and OFFSET of one axis (write_mode: its MODE). */
static void apply_calib(hg_servo_t *s, uint32_t i)
{
    const hg_axis_calib_t *c = &s->cfg.cal.axis[i];
    s->cfg.enc[i].dir = c->enc_dir;
    s->cfg.enc[i].index_to_zero = c->index_to_zero;
    s->cfg.motor[i].comm_offset = c->comm_offset;
    fpga_write32(HG_REG_AXIS(i, HG_AX_OFFSET), c->comm_offset);
}

static void write_mode(const hg_servo_t *s, uint32_t i)
{
    fpga_write32(HG_REG_AXIS(i, HG_AX_MODE), fw_commutated(s, i) ? HG_MODE_ALIGN : HG_MODE_TORQUE);
}

/* The field angle of a firmware-commutated axis (OFFSET in ALIGN mode), as the FPGA's sine mode
 * would form it with the count reversed: the position from the home (the IDX_POS that
 * hg_enc_home took), predicted half a tick ahead, times the pole pairs, negated, its top 10 of
 * 20 bits, plus the calibration's offset. (Negating before the floor keeps the ROM's mid-bin
 * convention unbiased.) */
static uint32_t fw_field_code(const hg_servo_t *s, uint32_t i, int32_t pos, int32_t vel)
{
    const hg_enc_cal_t *e = &s->cfg.enc[i];
    const uint32_t home = (uint32_t)e->offset - (uint32_t)e->index_to_zero;
    const int32_t ahead = vel / (int32_t)(2u * s->cfg.rate_hz);
    const uint32_t x = 0u - ((uint32_t)pos - home + (uint32_t)ahead);
    const uint32_t u = (x * s->cfg.cal.axis[i].pole_pairs) & 0xFFFFFu;
    return (s->cfg.cal.axis[i].comm_offset + (u >> 10)) & (HG_OFFSET_CODES - 1u);
}

static void latch(hg_servo_t *s, uint8_t err, uint8_t axis)
{
    if (s->err == HG_ERR_NONE) {
        s->err = err;
        s->err_axis = axis;
    }
    s->enabled = false;
}

static void write_ctrl(hg_servo_t *s, uint32_t v)
{
    if (v != s->ctrl) {
        fpga_write32(HG_REG_CTRL, v);
        s->ctrl = v;
    }
}

static void zero_torque(void)
{
    for (uint32_t i = 0; i < HG_NAXES; i++)
        fpga_write32(HG_REG_AXIS(i, HG_AX_TORQUE), 0);
}

uint8_t hg_servo_init(hg_servo_t *s, const hg_servo_cfg_t *cfg)
{
    *s = (hg_servo_t){ 0 };
    s->cfg = *cfg;
    s->f_pc_age = cfg->pc_force_timeout; /* no PC force until one arrives */
    zero_torque();
    fpga_write32(HG_REG_CTRL, 0);
    s->fpga_id = fpga_read32(HG_REG_ID);
    if ((s->fpga_id >> HG_ID_MAGIC_SHIFT) != HG_ID_MAGIC ||
        HG_ID_MAJOR(HG_ID_VERSION_OF(s->fpga_id)) != HG_ID_MAJOR(HG_ID_VERSION)) {
        latch(s, HG_ERR_FPGA_ID, 0);
        return s->err;
    }
    if (!cfg_ok(cfg)) {
        latch(s, HG_ERR_CONFIG, 0);
        return s->err;
    }
    fpga_write32(HG_REG_TICK_DIV, cfg->fpga_clk_hz / cfg->rate_hz);
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        const hg_real cpr = hg_enc_counts_per_rad(&cfg->enc[i]);
        s->max_vel[i] = (int32_t)(cfg->qd_max * cpr);
        s->max_step[i] = (int32_t)(cfg->qd_max * cpr / (hg_real)cfg->rate_hz) + 1;
        apply_calib(s, i);
        fpga_write32(HG_REG_AXIS(i, HG_AX_TQ_LIMIT), hg_motor_code_limit(&s->cfg.motor[i]));
        write_mode(s, i);
    }
    fpga_write32(HG_REG_CTRL, HG_CTRL_FAULT_CLR);
    fpga_write32(HG_REG_WDOG, HG_WDOG_KEY);
    return HG_ERR_NONE;
}

static uint32_t abs32(int32_t x)
{
    return x < 0 ? 0u - (uint32_t)x : (uint32_t)x;
}

static bool finite3(const hg_real x[3])
{
    return isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]);
}

/* Safety checks on a snapshot. Returns an error code; *axis names the axis where it applies. */
static uint8_t check_snapshot(const hg_servo_t *s, uint32_t seq0, uint32_t seq1,
                              const int32_t pos[3], const int32_t vel[3], uint8_t *axis)
{
    const uint32_t dseq = seq0 - s->seq;
    if (seq0 != seq1 || (s->have_prev && dseq == 0))
        return HG_ERR_STALE;
    if (s->have_prev && dseq > 1u + s->cfg.max_missed)
        return HG_ERR_OVERRUN;
    for (uint8_t i = 0; i < HG_NAXES; i++) {
        *axis = i;
        if (s->status & HG_STAT_FAULT(i))
            return HG_ERR_AXIS_FAULT;
    }
    *axis = 0;
    if (s->status & HG_STAT_WDOG)
        return HG_ERR_WATCHDOG;
    for (uint8_t i = 0; i < HG_NAXES; i++) {
        *axis = i;
        const uint32_t step = abs32((int32_t)((uint32_t)pos[i] - (uint32_t)s->pos[i]));
        if ((s->have_prev && step > (uint32_t)s->max_step[i] * dseq)
            || abs32(vel[i]) > (uint32_t)s->max_vel[i])
            return HG_ERR_ENCODER;
    }
    *axis = 0;
    return HG_ERR_NONE;
}

/* Snapshot -> torque codes. Returns HG_ERR_NONFINITE or HG_ERR_NONE. */
static uint8_t compute(hg_servo_t *s, const int32_t pos[3], const int32_t vel[3], hg_real dt)
{
    const hg_servo_cfg_t *c = &s->cfg;
    static const hg_real zero[3] = { 0 };
    const bool drive = s->enabled && s->err == HG_ERR_NONE;
    hg_kin_t k;

    for (unsigned i = 0; i < HG_NAXES; i++) {
        s->q[i] = hg_enc_angle(&c->enc[i], pos[i]);
        s->qd[i] = hg_enc_rate(&c->enc[i], vel[i]);
    }
    hg_kin_eval(&c->link, s->q, &k);
    hg_kin_jv(&k, s->qd, s->v);
    for (unsigned i = 0; i < 3; i++)
        s->p[i] = k.p[i];
    const bool pc_live = s->f_pc_age < c->pc_force_timeout;
    if (pc_live)
        s->f_pc_age++;
    hg_scene_force(&s->scene, &s->scene_st, s->p, s->v, pc_live ? s->f_pc : zero, dt, drive,
                   c->f_max, c->fi_max, s->f);
    s->guard = hg_kin_guard(&c->guard, &k);
    hg_kin_jt(&k, s->f, s->tau);
    for (unsigned i = 0; i < 3; i++)
        s->tau[i] *= s->guard;
    hg_gravity_add(&c->grav, &k, s->tau);
    hg_walls_add(&c->walls, s->q, s->qd, s->tau);
    if (!(finite3(s->p) && finite3(s->v) && finite3(s->f) && finite3(s->tau)))
        return HG_ERR_NONFINITE;
    for (unsigned i = 0; i < HG_NAXES; i++)
        s->code[i] = hg_motor_code(&c->motor[i], s->tau[i]);
    return HG_ERR_NONE;
}

void hg_servo_step(hg_servo_t *s)
{
    int32_t pos[3], vel[3];
    const uint32_t seq0 = fpga_read32(HG_REG_SEQ);
    const uint32_t status = fpga_read32(HG_REG_STATUS);
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        pos[i] = (int32_t)fpga_read32(HG_REG_AXIS(i, HG_AX_POS));
        vel[i] = (int32_t)fpga_read32(HG_REG_AXIS(i, HG_AX_VEL));
    }
    const uint32_t seq1 = fpga_read32(HG_REG_SEQ);
    s->status = status;

    uint8_t axis = 0;
    uint8_t err;
    if (status & HG_STAT_HW_FAULT) {
        /* the FPGA's own logic failed a check and zeroes the DACs: latch with its cause */
        err = HG_ERR_FPGA_FAULT;
        axis = (uint8_t)(fpga_read32(HG_REG_HW_FAULT) & HG_HWF_CAUSES);
    } else {
        err = check_snapshot(s, seq0, seq1, pos, vel, &axis);
    }
    if (err == HG_ERR_NONE) {
        const uint32_t dseq = s->have_prev ? seq0 - s->seq : 1u;
        err = compute(s, pos, vel, (hg_real)dseq / (hg_real)s->cfg.rate_hz);
    }
    if (seq0 == seq1) {
        s->seq = seq0;
        for (unsigned i = 0; i < HG_NAXES; i++)
            s->pos[i] = pos[i];
        s->have_prev = true;
    }
    if (err != HG_ERR_NONE)
        latch(s, err, axis);

    const bool drive = s->enabled && s->err == HG_ERR_NONE;
    uint32_t ctrl = 0;
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        if (!drive || !hg_servo_axis_calibrated(s, i))
            s->code[i] = 0;
        if (fw_commutated(s, i))
            fpga_write32(HG_REG_AXIS(i, HG_AX_OFFSET), fw_field_code(s, i, pos[i], vel[i]));
        fpga_write32(HG_REG_AXIS(i, HG_AX_TORQUE), (uint32_t)(uint16_t)s->code[i]);
        ctrl |= HG_CTRL_AXIS_EN(i);
    }
    write_ctrl(s, drive ? ctrl | HG_CTRL_GLOBAL_EN : 0u);
    /* in error the watchdog is left to expire: the FPGA zeroes the DACs on its own as well */
    if (s->err == HG_ERR_NONE)
        fpga_write32(HG_REG_WDOG, HG_WDOG_KEY);
    s->steps++;
}

void hg_servo_isr(void)
{
    if (hg_servo_isr_ctx)
        hg_servo_step(hg_servo_isr_ctx);
    fpga_write32(HG_REG_IRQ, HG_IRQ_TICK);
}

int hg_servo_enable(hg_servo_t *s, bool on)
{
    int rc = 0;
    const uint32_t t = hg_hal_irq_save();
    if (on && s->err != HG_ERR_NONE) {
        rc = HG_SERVO_E_RANGE;
    } else if (on && !hg_servo_calibrated(s)) {
        rc = HG_SERVO_E_UNCAL;
    } else {
        if (on && !s->enabled)
            s->scene_st = (hg_scene_state_t){ { 0 } };
        s->enabled = on;
    }
    hg_hal_irq_restore(t);
    return rc;
}

void hg_servo_clear_error(hg_servo_t *s)
{
    const uint32_t t = hg_hal_irq_save();
    s->err = HG_ERR_NONE;
    s->err_axis = 0;
    s->enabled = false;
    s->have_prev = false; /* the last snapshot may be the bad one: re-seed */
    s->scene_st = (hg_scene_state_t){ { 0 } };
    fpga_write32(HG_REG_CTRL, HG_CTRL_FAULT_CLR);
    s->ctrl = HG_CTRL_FAULT_CLR;
    hg_hal_irq_restore(t);
}

int hg_servo_set_scene(hg_servo_t *s, const hg_scene_t *sc)
{
    hg_scene_t n = *sc;
    if (hg_scene_check(&n) != 0)
        return -1;
    const uint32_t t = hg_hal_irq_save();
    if (n.type != s->scene.type)
        s->scene_st = (hg_scene_state_t){ { 0 } };
    s->scene = n;
    hg_hal_irq_restore(t);
    return 0;
}

int hg_servo_set_force(hg_servo_t *s, const hg_real f[3])
{
    const hg_real m2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
    if (!hg_servo_calibrated(s))
        return HG_SERVO_E_UNCAL;
    if (!(m2 <= s->cfg.f_max * s->cfg.f_max)) /* also rejects NaN and Inf */
        return HG_SERVO_E_RANGE;
    const uint32_t t = hg_hal_irq_save();
    for (unsigned i = 0; i < 3; i++)
        s->f_pc[i] = f[i];
    s->f_pc_age = 0;
    hg_hal_irq_restore(t);
    return 0;
}

int hg_servo_set_calib(hg_servo_t *s, unsigned axis, const hg_axis_calib_t *c)
{
    if (axis >= HG_NAXES || !hg_calib_axis_ok(c))
        return HG_SERVO_E_RANGE;
    int rc = 0;
    const uint32_t t = hg_hal_irq_save();
    if (s->enabled) {
        rc = HG_SERVO_E_ENABLED;
    } else {
        s->cfg.cal.axis[axis] = *c;
        apply_calib(s, axis);
        write_mode(s, axis);
        if ((c->flags & HG_CAL_HOMED) && (s->status & HG_STAT_HOMED(axis)))
            hg_enc_home(&s->cfg.enc[axis],
                        (int32_t)fpga_read32(HG_REG_AXIS(axis, HG_AX_IDX_POS)));
    }
    hg_hal_irq_restore(t);
    return rc;
}
