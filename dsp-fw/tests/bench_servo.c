/* SPDX-License-Identifier: Apache-2.0 */
/* Servo-step benchmark on the host HAL: an enabled servo with a wall scene, gravity terms and
 * a moving pose (1000 precomputed snapshots, part of them in the wall).
 *   bench_servo STEPS                       run STEPS steps (the callgrind run)
 *   bench_servo STEPS IR CG_STEPS CG_SECS   time STEPS steps and print the budget table with
 *                                           the callgrind count IR over CG_STEPS steps */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "hal_sim.h"
#include "hg_servo.h"

#define NPOSE 1000
#define C6713_HZ 225e6 /* SBC6x C6713 clock assumed for the cycle budget */

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    const long steps = argc > 1 ? atol(argv[1]) : 1000000;
    static int32_t pos[NPOSE][3], vel[NPOSE][3];
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.grav.k[6] = 0.01f; /* exercise the counterbalance arithmetic */
    cfg.grav.k[9] = 0.01f;
    hal_sim_reset();
    hg_servo_t s;
    if (hg_servo_init(&s, &cfg) != HG_ERR_NONE)
        return 1;
    const hg_scene_t wall = { HG_SCENE_WALL, { 0, 0.07f, 0 }, { 0, -1, 0 }, 3500, 5, 0 };
    hg_servo_set_scene(&s, &wall);
    hg_servo_enable(&s, true);
    const double k = (double)(1 << 20) / (2 * 3.14159265358979);
    for (int n = 0; n < NPOSE; n++) {
        const double ph = 2 * 3.14159265358979 * n / NPOSE;
        const double q[3] = { 0.3 * sin(ph), 0.785 + 0.1 * sin(2 * ph), 0.785 + 0.1 * cos(ph) };
        const double qd[3] = { 0.3 * cos(ph), 0.2 * cos(2 * ph), -0.1 * sin(ph) };
        for (int i = 0; i < 3; i++) {
            pos[n][i] = (int32_t)(q[i] * k);
            vel[n][i] = (int32_t)(qd[i] * k);
        }
    }
    const double t0 = now();
    for (long n = 0; n < steps; n++) {
        hal_sim_snapshot(pos[n % NPOSE], vel[n % NPOSE]);
        hg_servo_step(&s);
    }
    const double secs = now() - t0;
    if (s.err != HG_ERR_NONE) {
        printf("bench: servo latched error %u\n", s.err);
        return 1;
    }
    if (argc < 5)
        return 0;
    const double ns = secs * 1e9 / (double)steps;
    const double ir = atof(argv[2]) / atof(argv[3]);
    const double cg_secs = atof(argv[4]);
    printf("%-36s %12s %20s %20s %10s\n", "servo step", "per step", "1 kHz budget",
           "10 kHz budget", "run time");
    printf("%-36s %12s %20s %20s %10s\n", "", "", "(1 ms, 225k cyc)", "(100 us, 22.5k cyc)",
           "");
    char label[64];
    snprintf(label, sizeof label, "host wall clock, %ld steps", steps);
    printf("%-36s %9.1f ns %19.4f%% %19.3f%% %8.2f s\n", label, ns, ns / 1e6 * 100,
           ns / 1e5 * 100, secs);
    snprintf(label, sizeof label, "callgrind instr (Ir), %s steps", argv[3]);
    printf("%-36s %9.0f Ir %19.3f%% %19.2f%% %8.2f s\n", label, ir,
           ir / (C6713_HZ / 1e3) * 100, ir / (C6713_HZ / 1e4) * 100, cg_secs);
    printf("(Ir are x86-64 instructions inside hg_servo_step, a proxy for C6713 cycles at "
           "225 MHz.)\n");
    return 0;
}
