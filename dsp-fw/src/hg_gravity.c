/* SPDX-License-Identifier: Apache-2.0 */
/* Paper equations (2)-(4): dU/d(alpha, beta, gamma) with the coefficient table. */
#include "hg_gravity.h"

#define K(n) (g->k[(n) - 1])

void hg_gravity_add(const hg_gravity_t *g, const hg_kin_t *k, hg_real tau[3])
{
    const hg_real sa = k->sa, ca = k->ca, sb = k->sb, cb = k->cb, sg = k->sg, cg = k->cg;
    const hg_real ib3 = HG_C(1.0) / (k->db * k->db * k->db);
    const hg_real ig3 = HG_C(1.0) / (k->dg * k->dg * k->dg);
    const hg_real cb2 = cb * cb, cg2 = cg * cg, ca3 = ca * ca * ca;

    tau[0] += -K(2) * sa + K(6) * ca
            - K(7) * cb2 * cb * sa * ib3 + K(8) * ca * cb2 * ib3
            - K(9) * sa * ca * sb * (cb2 + g->q_ab * g->q_ab) * ib3
            - K(10) * cg2 * cg * sa * ig3 + K(11) * ca * cg2 * ig3
            - K(12) * sa * ca * sg * (cg2 + g->q_ac * g->q_ac) * ig3;
    tau[1] += K(4) * cb - K(7) * sb * ca3 * ib3;
    tau[2] += K(5) * cg - K(10) * sg * ca3 * ig3;
}
