/* SPDX-License-Identifier: Apache-2.0 */
/* Forward kinematics, Jacobian, inverse kinematics and singularity guard (docs/design/KINEMATICS.md). */
#include "hg_kin.h"

void hg_kin_eval(const hg_linkage_t *lk, const hg_real q[3], hg_kin_t *k)
{
    const hg_real sa = HG_SIN(q[0]), ca = HG_COS(q[0]);
    const hg_real sb = HG_SIN(q[1]), cb = HG_COS(q[1]);
    const hg_real sg = HG_SIN(q[2]), cg = HG_COS(q[2]);
    /* d = sqrt(cos^2 + cos^2(alpha) sin^2): the cancellation-free form of sqrt(1 - s^2a s^2b) */
    const hg_real db = HG_SQRT(cb * cb + ca * ca * sb * sb);
    const hg_real dg = HG_SQRT(cg * cg + ca * ca * sg * sg);
    const hg_real lb = lk->l_beta / db, lg = lk->l_gamma / dg;
    const hg_real rho = lb * cb + lg * cg;
    const hg_real zeta = ca * (lg * sg - lb * sb);
    /* L/d^3 factors of the Jacobian */
    const hg_real lb3 = lb / (db * db), lg3 = lg / (dg * dg);

    k->sa = sa; k->ca = ca; k->sb = sb; k->cb = cb; k->sg = sg; k->cg = cg;
    k->db = db; k->dg = dg; k->rho = rho;
    k->sin_bg = sb * cg + cb * sg;

    k->p[0] = lk->h * ca - rho * sa;
    k->p[1] = lk->h * sa + rho * ca;
    k->p[2] = zeta;

    /* column alpha */
    k->J[0][0] = -ca * (lb3 * cb + lg3 * cg) - lk->h * sa;
    k->J[1][0] = -sa * (lb3 * cb * cb * cb + lg3 * cg * cg * cg) + lk->h * ca;
    k->J[2][0] = sa * (lb3 * sb * cb * cb - lg3 * sg * cg * cg);
    /* column beta */
    k->J[0][1] = lb3 * ca * sa * ca * sb;
    k->J[1][1] = -lb3 * ca * ca * ca * sb;
    k->J[2][1] = -lb3 * ca * cb;
    /* column gamma */
    k->J[0][2] = lg3 * ca * sa * ca * sg;
    k->J[1][2] = -lg3 * ca * ca * ca * sg;
    k->J[2][2] = lg3 * ca * cg;
}

int hg_kin_ik(const hg_linkage_t *lk, const hg_real p[3], hg_real q[3])
{
    const hg_real lb = lk->l_beta, lg = lk->l_gamma;
    const hg_real rr = p[0] * p[0] + p[1] * p[1] - lk->h * lk->h;
    if (!(rr > HG_C(0.0)))
        return -1;
    const hg_real rho = HG_SQRT(rr);
    /* (x, y) = Rz(alpha) (h, rho): alpha = angle(x, y) - angle(h, rho) */
    const hg_real alpha = HG_ATAN2(lk->h * p[1] - rho * p[0], lk->h * p[0] + rho * p[1]);
    const hg_real c = (rr + p[2] * p[2] - lb * lb - lg * lg) / (HG_C(2.0) * lb * lg);
    if (!(c >= HG_C(-1.0) && c <= HG_C(1.0)))
        return -1;
    const hg_real delta = (hg_real)lk->elbow * HG_ACOS(c);
    const hg_real sd = HG_SIN(delta), cd = HG_COS(delta);
    const hg_real phib = HG_ATAN2(p[2], rho) - HG_ATAN2(lg * sd, lb + lg * cd);
    const hg_real phig = phib + delta;
    const hg_real ca = HG_COS(alpha);
    if (!(ca > HG_C(0.0)))
        return -1;
    q[0] = alpha;
    q[1] = HG_ATAN2(-ca * HG_SIN(phib), ca * ca * HG_COS(phib));
    q[2] = HG_ATAN2(ca * HG_SIN(phig), ca * ca * HG_COS(phig));
    return 0;
}

void hg_kin_jt(const hg_kin_t *k, const hg_real f[3], hg_real tau[3])
{
    for (int j = 0; j < 3; j++)
        tau[j] = k->J[0][j] * f[0] + k->J[1][j] * f[1] + k->J[2][j] * f[2];
}

void hg_kin_jv(const hg_kin_t *k, const hg_real qd[3], hg_real v[3])
{
    for (int i = 0; i < 3; i++)
        v[i] = k->J[i][0] * qd[0] + k->J[i][1] * qd[1] + k->J[i][2] * qd[2];
}

/* 1 at m >= thr, 0 at m <= thr/2, linear between */
static hg_real fade(hg_real m, hg_real thr)
{
    return hg_clamp(HG_C(2.0) * m / thr - HG_C(1.0), HG_C(0.0), HG_C(1.0));
}

hg_real hg_kin_guard(const hg_guard_t *g, const hg_kin_t *k)
{
    return fade(HG_FABS(k->ca), g->cos_alpha) * fade(HG_FABS(k->sin_bg), g->sin_bg)
         * fade(k->rho, g->rho);
}
