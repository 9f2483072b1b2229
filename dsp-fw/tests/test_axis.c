/* SPDX-License-Identifier: Apache-2.0 */
/* Encoder calibration and motor/DAC scaling. */
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
