/* SPDX-License-Identifier: Apache-2.0 */
/* Kinematics in the firmware's float build: the docs/design/KINEMATICS.md check point, IK round trip and
 * the guard. (Exhaustive checks against the numpy model run from tb/fw via kin-dump.) */
#include "hg_kin.h"
#include "hg_test.h"

static const hg_linkage_t LK = HG_LINKAGE_DEFAULT;

void test_kin_checkpoint(void)
{
    const hg_real q[3] = { 0, (hg_real)DEG_D(45.0), (hg_real)DEG_D(45.0) };
    const hg_real f[3] = { 0, -1, 0 };
    hg_real tau[3];
    hg_kin_t k;
    hg_kin_eval(&LK, q, &k);
    CHECK_NEAR(k.p[0], 0.0, 1e-7);
    CHECK_NEAR(k.p[1], 0.1 * sqrt(0.5), 1e-7);  /* 70.7 mm */
    CHECK_NEAR(k.p[2], 0.0, 1e-7);
    hg_kin_jt(&k, f, tau);
    CHECK_NEAR(tau[0], 0.0, 1e-7);
    CHECK_NEAR(tau[1], 0.05 * sqrt(0.5), 1e-7); /* 0.0354 N m */
    CHECK_NEAR(tau[2], 0.05 * sqrt(0.5), 1e-7);
}

void test_kin_ik_roundtrip(void)
{
    const double qs[][3] = { { 0, 45, 45 }, { 30, -20, 70 }, { -50, 60, 10 }, { 10, 80, 75 } };
    for (unsigned n = 0; n < 4; n++) {
        hg_real q[3], qi[3];
        hg_kin_t k;
        for (int i = 0; i < 3; i++)
            q[i] = (hg_real)DEG_D(qs[n][i]);
        hg_kin_eval(&LK, q, &k);
        CHECK(hg_kin_ik(&LK, k.p, qi) == 0);
        for (int i = 0; i < 3; i++)
            CHECK_NEAR(qi[i], q[i], 2e-4);
    }
    const hg_real far[3] = { 0, 0.11f, 0 }, behind[3] = { 0, -0.07f, 0 };
    hg_real qi[3];
    CHECK(hg_kin_ik(&LK, far, qi) == -1);    /* beyond L_beta + L_gamma */
    CHECK(hg_kin_ik(&LK, behind, qi) == -1); /* the -y hemisphere is off the branch */
}

/* Guard: 1 well inside, 0 at half of each threshold, linear in between. */
void test_kin_guard(void)
{
    const hg_guard_t g = HG_GUARD_DEFAULT;
    hg_kin_t k;
    const hg_real q0[3] = { 0, (hg_real)DEG_D(45.0), (hg_real)DEG_D(45.0) };
    hg_kin_eval(&LK, q0, &k);
    CHECK(hg_kin_guard(&g, &k) == 1.0f);
    /* cos(alpha) = 0.1125: 3/4 of the way from 0.075 to 0.15 -> 0.5 */
    const hg_real qa[3] = { acosf(0.1125f), (hg_real)DEG_D(45.0), (hg_real)DEG_D(45.0) };
    hg_kin_eval(&LK, qa, &k);
    CHECK_NEAR(hg_kin_guard(&g, &k), 0.5, 1e-5);
    /* stretched: beta + gamma = 0 */
    const hg_real qs[3] = { 0, 0.3f, -0.3f };
    hg_kin_eval(&LK, qs, &k);
    CHECK(hg_kin_guard(&g, &k) == 0.0f);
    /* rho = 0: both arms along z */
    const hg_real qr[3] = { 0, (hg_real)DEG_D(90.0), (hg_real)DEG_D(90.0) };
    hg_kin_eval(&LK, qr, &k);
    CHECK(hg_kin_guard(&g, &k) == 0.0f);
}
