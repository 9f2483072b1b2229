/* SPDX-License-Identifier: Apache-2.0 */
/* A minimal unit-test harness: CHECK macros, a test list (tests.def), shared fixtures. */
#ifndef HG_TEST_H
#define HG_TEST_H

#include <math.h>
#include <stdint.h>
#include "hg_link.h"
#include "hg_servo.h"

void hg_test_fail(const char *file, int line, const char *what, double a, double b);

#define CHECK(c) \
    do { if (!(c)) hg_test_fail(__FILE__, __LINE__, #c, NAN, NAN); } while (0)
#define CHECK_NEAR(a, b, tol) \
    do { const double a_ = (double)(a), b_ = (double)(b); \
         if (!(fabs(a_ - b_) <= (double)(tol))) \
             hg_test_fail(__FILE__, __LINE__, #a " ~ " #b, a_, b_); } while (0)

#define T(n) void test_##n(void);
#include "tests.def"
#undef T

#define PI_D 3.14159265358979323846
#define DEG_D(x) ((x) * PI_D / 180.0)

/* Fixtures */
void fx_servo(hg_servo_t *s, const hg_servo_cfg_t *cfg);   /* reset the sim, init the servo */
/* New snapshot with joint angles q (rad) and rates qd (rad/s), converted with s->cfg.enc. */
void fx_pose(const hg_servo_t *s, const double q[3], const double qd[3]);
/* Torque that a written code stands for (N m), from the motor struct arithmetic. */
double fx_code_to_tau(const hg_motor_t *m, int16_t code);

#endif /* HG_TEST_H */
