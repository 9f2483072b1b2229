/* SPDX-License-Identifier: Apache-2.0 */
/* Active gravity counterbalance: tau_g = +dU/dq from the paper's equations (2)-(4).
 * The linkage is passively balanced, so the default table is all zero. */
#ifndef HG_GRAVITY_H
#define HG_GRAVITY_H

#include "hg_kin.h"

typedef struct {
    hg_real k[12];  /* N m: k[n-1] = k_ny of Table 1 (k1y and k3y do not enter eqs 2-4) */
    hg_real q_ab;   /* Q_ab of eq (2), dimensionless */
    hg_real q_ac;   /* Q_ac of eq (2) */
} hg_gravity_t;

/* tau += dU/dq at the pose k (uses k's trig and d_beta, d_gamma). */
void hg_gravity_add(const hg_gravity_t *g, const hg_kin_t *k, hg_real tau[3]);

#endif /* HG_GRAVITY_H */
