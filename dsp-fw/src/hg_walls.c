/* SPDX-License-Identifier: Apache-2.0 */
/* Workspace-boundary walls in actuator-angle space. */
#include "hg_walls.h"

void hg_walls_add(const hg_walls_t *w, const hg_real q[3], const hg_real qd[3], hg_real tau[3])
{
    for (int n = 0; n < HG_NWALLS; n++) {
        const hg_real *c = w->w[n].c;
        const hg_real s = c[0] * q[0] + c[1] * q[1] + c[2] * q[2];
        const hg_real sd = c[0] * qd[0] + c[1] * qd[1] + c[2] * qd[2];
        hg_real f = HG_C(0.0);
        if (s < w->w[n].lo) {
            f = w->k * (w->w[n].lo - s) - w->b * sd;
            f = f < HG_C(0.0) ? HG_C(0.0) : f; /* push only; NaN propagates */
        } else if (s > w->w[n].hi) {
            f = w->k * (w->w[n].hi - s) - w->b * sd;
            f = f > HG_C(0.0) ? HG_C(0.0) : f;
        }
        for (int j = 0; j < 3; j++)
            tau[j] += f * c[j];
    }
}
