/* SPDX-License-Identifier: Apache-2.0 */
/* Scene forces and the joint-space workspace walls. */
#include "hg_scene.h"
#include "hg_test.h"
#include "hg_walls.h"

static const hg_real Z[3] = { 0, 0, 0 };

static void force(const hg_scene_t *sc, hg_scene_state_t *st, const hg_real p[3],
                  const hg_real v[3], hg_real f[3])
{
    hg_scene_force(sc, st, p, v, Z, 0.001f, true, 10.0f, 2.0f, f);
}

void test_scene_wall(void)
{
    /* wall at y = 0.07 m, free space below (normal -y), 35 N/cm */
    hg_scene_t sc = { HG_SCENE_WALL, { 0, 0.07f, 0 }, { 0, -2.0f, 0 }, 3500, 20, 0 };
    hg_scene_state_t st = { { 0 } };
    hg_real f[3];
    CHECK(hg_scene_check(&sc) == 0 && sc.n[1] == -1.0f);
    const hg_real in[3] = { 0.01f, 0.072f, -0.02f }, out[3] = { 0, 0.069f, 0 };
    force(&sc, &st, in, Z, f);
    CHECK_NEAR(f[1], -3500 * 0.002, 1e-3); /* 7 N pushing back out, k * depth */
    CHECK(f[0] == 0.0f && f[2] == 0.0f);
    force(&sc, &st, out, Z, f);
    CHECK(f[0] == 0.0f && f[1] == 0.0f && f[2] == 0.0f);
    /* damping opposes the velocity inside the wall: moving in -> more, moving out -> less */
    const hg_real vin[3] = { 0, 0.05f, 0 }, vout[3] = { 0, -0.05f, 0 };
    force(&sc, &st, in, vin, f);
    CHECK_NEAR(f[1], -(7.0 + 20 * 0.05), 1e-3);
    force(&sc, &st, in, vout, f);
    CHECK_NEAR(f[1], -(7.0 - 20 * 0.05), 1e-3);
    /* fast exit: damping would pull; a wall never pulls */
    const hg_real vfast[3] = { 0, -1.0f, 0 };
    force(&sc, &st, in, vfast, f);
    CHECK(f[1] == 0.0f);
    /* deep: |F| is clamped at f_max, direction kept */
    const hg_real deep[3] = { 0, 0.09f, 0 };
    force(&sc, &st, deep, Z, f);
    CHECK_NEAR(f[1], -10.0, 1e-5);
}

void test_scene_spring_viscous_pc(void)
{
    hg_scene_t sc = { HG_SCENE_SPRING, { 0, 0.07f, 0 }, { 0, 0, 0 }, 500, 5, 0 };
    hg_scene_state_t st = { { 0 } };
    hg_real f[3];
    const hg_real p[3] = { 0.002f, 0.07f, -0.004f }, v[3] = { 0.1f, 0, 0 };
    force(&sc, &st, p, v, f);
    CHECK_NEAR(f[0], -500 * 0.002 - 5 * 0.1, 1e-5);
    CHECK_NEAR(f[1], 0.0, 1e-5);
    CHECK_NEAR(f[2], 500 * 0.004, 1e-5);
    sc.type = HG_SCENE_VISCOUS;
    force(&sc, &st, p, v, f);
    CHECK_NEAR(f[0], -0.5, 1e-6);
    CHECK(f[1] == 0.0f && f[2] == 0.0f);
    sc.type = HG_SCENE_PC_FORCE;
    const hg_real fpc[3] = { 1, -2, 3 };
    hg_scene_force(&sc, &st, p, v, fpc, 0.001f, true, 10.0f, 2.0f, f);
    CHECK(f[0] == 1.0f && f[1] == -2.0f && f[2] == 3.0f);
    sc.type = HG_SCENE_NONE;
    force(&sc, &st, p, v, f);
    CHECK(f[0] == 0.0f && f[1] == 0.0f && f[2] == 0.0f);
}

/* Integral action: removes a steady error; clamped at fi_max; frozen while saturated. */
void test_scene_antiwindup(void)
{
    hg_scene_t sc = { HG_SCENE_SPRING, { 0, 0, 0 }, { 0, 0, 0 }, 100, 0, 1000 };
    hg_scene_state_t st = { { 0 } };
    hg_real f[3];
    const hg_real p[3] = { 0.001f, 0, 0 };
    for (int i = 0; i < 10000; i++) /* 10 s of a 1 mm error */
        force(&sc, &st, p, Z, f);
    CHECK_NEAR(st.integ[0] * 1000, 2.0, 1e-4); /* |ki integ| stopped at fi_max = 2 N */
    CHECK_NEAR(f[0], -0.1 - 2.0, 1e-4);
    /* error reversed: the integral unwinds at once instead of after 10 s */
    const hg_real pn[3] = { -0.001f, 0, 0 };
    for (int i = 0; i < 4000; i++)
        force(&sc, &st, pn, Z, f);
    CHECK(f[0] > 0.0f);
    /* output saturated (10 N at 0.2 m): no integration */
    hg_scene_state_t st2 = { { 0 } };
    const hg_real big[3] = { 0.2f, 0, 0 };
    for (int i = 0; i < 100; i++)
        force(&sc, &st2, big, Z, f);
    CHECK(st2.integ[0] == 0.0f);
    /* not driving (integrate = false): no integration either */
    hg_scene_force(&sc, &st2, p, Z, Z, 0.001f, false, 10.0f, 2.0f, f);
    CHECK(st2.integ[0] == 0.0f);
}

void test_scene_check(void)
{
    const hg_scene_t ok = { HG_SCENE_WALL, { 0, 0.07f, 0 }, { 0, -1, 0 }, 3500, 0, 0 };
    hg_scene_t sc = ok;
    CHECK(hg_scene_check(&sc) == 0);
    sc = ok; sc.k = 3501;         CHECK(hg_scene_check(&sc) != 0); /* > 35 N/cm */
    sc = ok; sc.k = -1;           CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.b = NAN;          CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.ki = INFINITY;    CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.type = 5;         CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.n[1] = -0.1f;     CHECK(hg_scene_check(&sc) != 0); /* not a unit normal */
    sc = ok; sc.p0[0] = NAN;      CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.p0[1] = 0.3f;     CHECK(hg_scene_check(&sc) != 0);
    sc = ok; sc.type = HG_SCENE_VISCOUS; sc.n[1] = 0;
    CHECK(hg_scene_check(&sc) == 0);                                /* n unused */
}

void test_walls(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    const hg_walls_t *w = &cfg.walls;
    hg_real tau[3] = { 0 };
    const hg_real inside[3] = { 0, 0.8f, 0.8f };
    hg_walls_add(w, inside, Z, tau);
    CHECK(tau[0] == 0.0f && tau[1] == 0.0f && tau[2] == 0.0f);
    /* alpha 0.1 rad past +60 deg: pushed back with k * 0.1 */
    const hg_real a_out[3] = { (hg_real)DEG_D(60.0) + 0.1f, 0.8f, 0.8f };
    hg_walls_add(w, a_out, Z, tau);
    CHECK_NEAR(tau[0], -(double)cfg.walls.k * 0.1, 1e-6);
    CHECK(tau[1] == 0.0f && tau[2] == 0.0f);
    /* beta + gamma 0.05 rad below 20 deg: both B and Gamma pushed to open the arms */
    hg_real t2[3] = { 0 };
    const hg_real fold[3] = { 0, (hg_real)DEG_D(10.0) - 0.025f, (hg_real)DEG_D(10.0) - 0.025f };
    hg_walls_add(w, fold, Z, t2);
    CHECK_NEAR(t2[1], (double)cfg.walls.k * 0.05, 1e-6);
    CHECK_NEAR(t2[2], (double)cfg.walls.k * 0.05, 1e-6);
    /* leaving the wall fast: damping would pull inward; walls never pull */
    hg_real t3[3] = { 0 };
    const hg_real qd_out[3] = { -100, 0, 0 };
    hg_walls_add(w, a_out, qd_out, t3);
    CHECK(t3[0] == 0.0f);
}
