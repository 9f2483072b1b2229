/* SPDX-License-Identifier: Apache-2.0 */
/* Encoder calibration and motor/amplifier/DAC scaling. */
#include "hg_axis.h"
#include "hg_fpga_regs.h"

hg_real hg_enc_counts_per_rad(const hg_enc_cal_t *c)
{
    return (hg_real)c->counts_per_rev / (HG_C(2.0) * HG_PI);
}

hg_real hg_enc_angle(const hg_enc_cal_t *c, int32_t counts)
{
    /* modular difference: no signed overflow whatever the counter did */
    const int32_t d = (int32_t)((uint32_t)counts - (uint32_t)c->offset);
    return (hg_real)c->dir * (hg_real)d / hg_enc_counts_per_rad(c);
}

hg_real hg_enc_rate(const hg_enc_cal_t *c, int32_t counts_per_s)
{
    return (hg_real)c->dir * (hg_real)counts_per_s / hg_enc_counts_per_rad(c);
}

void hg_enc_home(hg_enc_cal_t *c, int32_t index_latched)
{
    c->offset = (int32_t)((uint32_t)index_latched + (uint32_t)c->index_to_zero);
}

static hg_real code_per_nm(const hg_motor_t *m)
{
    return (hg_real)HG_TORQUE_FS / (m->kt * m->amp_gain * m->dac_fs);
}

int16_t hg_motor_code(const hg_motor_t *m, hg_real tau)
{
    const hg_real fs = (hg_real)HG_TORQUE_FS;
    if (!isfinite(tau))
        return 0; /* the servo latches HG_ERR_NONFINITE first; this is the last line */
    hg_real x = hg_clamp(tau, -m->tau_max, m->tau_max) * (hg_real)m->dir * code_per_nm(m);
    x = hg_clamp(x, -fs, fs);
    return (int16_t)(x < HG_C(0.0) ? x - HG_C(0.5) : x + HG_C(0.5));
}

uint32_t hg_motor_code_limit(const hg_motor_t *m)
{
    const hg_real x = hg_clamp(m->tau_max * code_per_nm(m), HG_C(0.0), (hg_real)HG_TORQUE_FS);
    return (uint32_t)(x + HG_C(0.5));
}
