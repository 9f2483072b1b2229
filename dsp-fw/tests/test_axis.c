/* SPDX-License-Identifier: Apache-2.0 */
/* Encoder calibration and motor/DAC scaling. */
#include "hal_sim.h"
#include "hg_axis.h"
#include "hg_test.h"

void test_enc_angle(void)
{
    hg_enc_cal_t c = { 1, 1000, HG_ENC_COUNTS_PER_REV, 0 };
    CHECK(hg_enc_angle(&c, 1000) == 0.0f);
    CHECK_NEAR(hg_enc_angle(&c, 1000 + (1 << 18)), PI_D / 2, 1e-6); /* quarter turn */
    c.dir = -1;
    CHECK_NEAR(hg_enc_angle(&c, 1000 + (1 << 18)), -PI_D / 2, 1e-6);
    CHECK_NEAR(hg_enc_rate(&c, 1 << 20), -2 * PI_D, 1e-5);          /* 1 rev/s */
    /* counter wrapped around 2^31 between offset and reading: still a small angle */
    c.dir = 1;
    c.offset = INT32_MAX - 10;
    CHECK_NEAR(hg_enc_angle(&c, INT32_MIN + 20), 31 * 2 * PI_D / (1 << 20), 1e-9);
}

void test_enc_home(void)
{
    hg_enc_cal_t c = { 1, 0, HG_ENC_COUNTS_PER_REV, -5000 };
    hg_enc_home(&c, 123456);
    CHECK(c.offset == 118456);
    /* q = 0 lies index_to_zero counts from the index, here 5000 below it */
    CHECK_NEAR(hg_enc_angle(&c, 123456), 5000 * 2 * PI_D / (1 << 20), 1e-7);
}

void test_motor_code(void)
{
    const hg_motor_t m = { 0.06f, 0.8f, 10.0f, 0.3f, 1, 0 };   /* 0.48 N m full scale */
    CHECK(hg_motor_code(&m, 0.0f) == 0);
    CHECK(hg_motor_code(&m, 0.12f) == 8192);   /* 8191.75 rounds to nearest */
    CHECK(hg_motor_code(&m, -0.12f) == -8192);
    CHECK(hg_motor_code(&m, 0.11f) == 7509);   /* 7509.3 */
    CHECK(hg_motor_code(&m, 1.0f) == 20479);   /* clamped at tau_max = 0.3 N m */
    CHECK(hg_motor_code(&m, -1.0f) == -20479);
    CHECK(hg_motor_code_limit(&m) == 20479);
    CHECK(hg_motor_code(&m, NAN) == 0);
    CHECK(hg_motor_code(&m, INFINITY) == 0);
    hg_motor_t r = m;
    r.dir = -1;
    r.tau_max = 5.0f;                            /* beyond full scale: the DAC code clamps */
    CHECK(hg_motor_code(&r, 0.12f) == -8192);
    CHECK(hg_motor_code(&r, 4.0f) == -32767);
    CHECK(hg_motor_code_limit(&r) == 32767);
}

/* Boundary (issue 29): the firmware torque clamp tau_max in both directions, at the spec's
 * numbers (dsp-fw/README.md, "Configuration structs": tau_max 0.3 N m, "clamp; also written to
 * the FPGA TQ_LIMIT"; "code = dir clamp(tau, +-tau_max) / (kt amp_gain dac_fs) 32767, rounded,
 * then clamped to +-32767. The default full scale is 0.48 N m"). One step = one code of torque
 * (0.48 / 32767 N m). The motor is the default configuration's, the numbers are the README's. */
void test_bounds_tau_max(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    const double fs_nm = 0.48, tau_max = 0.3, step = fs_nm / 32767.0;
    const long at_max = lround(tau_max / fs_nm * 32767.0);      /* 20479.375 -> 20479 */
    CHECK(at_max == 20479);
    for (int i = 0; i < 3; i++) {
        const hg_motor_t *m = &cfg.motor[i];
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            const double s = (double)sgn;
            /* last code before the clamp: unclamped; at it and one code past: the clamp */
            CHECK(hg_motor_code(m, (hg_real)(s * (tau_max - step))) == sgn * (at_max - 1));
            CHECK(hg_motor_code(m, (hg_real)(s * tau_max)) == sgn * at_max);
            CHECK(hg_motor_code(m, (hg_real)(s * (tau_max + step))) == sgn * at_max);
            CHECK(hg_motor_code(m, (hg_real)(s * (tau_max + 100.0 * step))) == sgn * at_max);
        }
        CHECK(hg_motor_code_limit(m) == (uint32_t)at_max);
    }
    /* the servo writes that limit to every axis's TQ_LIMIT at init */
    hg_servo_t s;
    fx_servo(&s, &cfg);
    for (unsigned i = 0; i < 3; i++)
        CHECK(hal_sim_regs[HG_REG_AXIS(i, HG_AX_TQ_LIMIT)] == (uint32_t)at_max);
    /* the DAC's own full scale: with tau_max above it, +-32767 at 0.48 N m and beyond */
    hg_motor_t big = cfg.motor[0];
    big.tau_max = 5.0f;
    CHECK(hg_motor_code(&big, (hg_real)(fs_nm - step)) == 32766);
    CHECK(hg_motor_code(&big, (hg_real)fs_nm) == 32767);
    CHECK(hg_motor_code(&big, (hg_real)(fs_nm + step)) == 32767);
    CHECK(hg_motor_code(&big, (hg_real)-(fs_nm + step)) == -32767);
}
