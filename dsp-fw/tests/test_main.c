/* SPDX-License-Identifier: Apache-2.0 */
/* Test runner: runs every test (or those whose name starts with an argument) and prints
 * "N passed, M failed" as its last line; exit status 1 on any failure, 2 if nothing matched. */
#include <stdio.h>
#include <string.h>
#include "hal_sim.h"
#include "hg_test.h"

static const struct {
    const char *name;
    void (*fn)(void);
} tests[] = {
#define T(n) { #n, test_##n },
#include "tests.def"
#undef T
};

static int fails;
static const char *current;

void hg_test_fail(const char *file, int line, const char *what, double a, double b)
{
    if (fails++ < 5)
        printf("FAIL %s: %s:%d: %s (%.9g vs %.9g)\n", current, file, line, what, a, b);
}

void fx_servo(hg_servo_t *s, const hg_servo_cfg_t *cfg)
{
    hal_sim_reset();
    hg_servo_init(s, cfg);
}

void fx_pose(const hg_servo_t *s, const double q[3], const double qd[3])
{
    int32_t pos[3], vel[3];
    for (int i = 0; i < 3; i++) {
        const hg_enc_cal_t *c = &s->cfg.enc[i];
        const double k = (double)c->counts_per_rev / (2.0 * PI_D) * (double)c->dir;
        pos[i] = c->offset + (int32_t)lround(q[i] * k);
        vel[i] = (int32_t)lround(qd[i] * k);
    }
    hal_sim_snapshot(pos, vel);
}

double fx_code_to_tau(const hg_motor_t *m, int16_t code)
{
    return (double)code / 32767.0 * (double)m->dac_fs * (double)m->amp_gain * (double)m->kt
         * (double)m->dir;
}

int main(int argc, char **argv)
{
    int passed = 0, failed = 0;
    for (size_t t = 0; t < sizeof tests / sizeof tests[0]; t++) {
        int match = argc < 2;
        for (int a = 1; a < argc; a++)
            match |= strncmp(tests[t].name, argv[a], strlen(argv[a])) == 0;
        if (!match)
            continue;
        current = tests[t].name;
        fails = 0;
        hal_sim_reset();
        tests[t].fn();
        if (hal_sim_bad_access) {
            printf("FAIL %s: %u register accesses outside the map\n", current,
                   (unsigned)hal_sim_bad_access);
            fails++;
        }
        if (fails)
            failed++;
        else
            passed++;
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : (passed ? 0 : 2);
}
