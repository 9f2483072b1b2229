/* SPDX-License-Identifier: Apache-2.0 */
/* Gravity counterbalance (paper eqs 2-4) against physics it must reproduce. */
#include "hg_gravity.h"
#include "hg_test.h"

static const hg_real QS[][3] = { { 0.3f, 0.5f, 0.7f }, { -0.8f, 1.1f, -0.4f }, { 0.1f, -0.6f, 1.2f } };

void test_gravity_default_zero(void)
{
    const hg_gravity_t g = { { 0 }, 0, 0 };
    const hg_linkage_t lk = HG_LINKAGE_DEFAULT;
    for (unsigned n = 0; n < 3; n++) {
        hg_kin_t k;
        hg_real tau[3] = { 0.25f, -0.5f, 0.125f };
        hg_kin_eval(&lk, QS[n], &k);
        hg_gravity_add(&g, &k, tau);
        CHECK(tau[0] == 0.25f && tau[1] == -0.5f && tau[2] == 0.125f);
    }
}

/* A point mass m at the endpoint has U = m g y(q). Its k6 = m g h, k7 = m g L_beta,
 * k10 = m g L_gamma, and holding it needs tau = J^T (0, m g, 0). */
void test_gravity_point_mass(void)
{
    const hg_real mg = 0.5f;
    const hg_linkage_t lk = { 0.05f, 0.04f, 0.01f, 1 };
    hg_gravity_t g = { { 0 }, 0, 0 };
    g.k[6 - 1] = mg * lk.h;
    g.k[7 - 1] = mg * lk.l_beta;
    g.k[10 - 1] = mg * lk.l_gamma;
    for (unsigned n = 0; n < 3; n++) {
        hg_kin_t k;
        hg_real tau[3] = { 0 }, hold[3];
        const hg_real up[3] = { 0, mg, 0 };
        hg_kin_eval(&lk, QS[n], &k);
        hg_gravity_add(&g, &k, tau);
        hg_kin_jt(&k, up, hold);
        for (int i = 0; i < 3; i++)
            CHECK_NEAR(tau[i], hold[i], 1e-6);
    }
}

/* A mass on crank B at radius r along its 90-degree arm axis (0, sin b, cos b) has
 * U = m g r sin(beta): k4 = m g r gives tau_beta = m g r cos(beta), and k2 = m g r on the
 * A crank (axis arm at angle alpha + 90 deg) gives tau_alpha = -m g r sin(alpha). */
void test_gravity_cranks(void)
{
    const hg_linkage_t lk = HG_LINKAGE_DEFAULT;
    hg_gravity_t g = { { 0 }, 0, 0 };
    g.k[4 - 1] = 0.2f;
    g.k[5 - 1] = -0.1f;
    g.k[2 - 1] = 0.3f;
    for (unsigned n = 0; n < 3; n++) {
        hg_kin_t k;
        hg_real tau[3] = { 0 };
        hg_kin_eval(&lk, QS[n], &k);
        hg_gravity_add(&g, &k, tau);
        CHECK_NEAR(tau[0], -0.3 * sin((double)QS[n][0]), 1e-6);
        CHECK_NEAR(tau[1], 0.2 * cos((double)QS[n][1]), 1e-6);
        CHECK_NEAR(tau[2], -0.1 * cos((double)QS[n][2]), 1e-6);
    }
}
