/* SPDX-License-Identifier: Apache-2.0 */
/* Linkage kinematics of docs/design/KINEMATICS.md: forward kinematics, Jacobian, inverse
 * kinematics and the singularity guard. q = (alpha, beta, gamma) in rad, p = (x, y, z) in m. */
#ifndef HG_KIN_H
#define HG_KIN_H

#include <stdint.h>
#include "hg_real.h"

/* Link lengths and signs: calibration parameters, all of them here. */
typedef struct {
    hg_real l_beta;   /* m, arm 4 (B side) from the n axis to the endpoint joint      */
    hg_real l_gamma;  /* m, arm 6 (Gamma side)                                        */
    hg_real h;        /* m, offset of the parallelogram plane along n (0 in the model) */
    int8_t elbow;     /* IK branch: +1 for delta = phi_gamma - phi_beta > 0, else -1   */
} hg_linkage_t;

#define HG_LINKAGE_DEFAULT { HG_C(0.05), HG_C(0.05), HG_C(0.0), 1 }

/* Singularity guard thresholds: full torque at or above each, linear fade to zero at half. */
typedef struct {
    hg_real cos_alpha;  /* |cos alpha|        (motor plane y = 0)  */
    hg_real sin_bg;     /* |sin(beta+gamma)|  (arms stretched / folded) */
    hg_real rho;        /* m, rho             (endpoint on the A axis) */
} hg_guard_t;

#define HG_GUARD_DEFAULT { HG_C(0.15), HG_C(0.1), HG_C(0.005) }

/* Everything the servo needs at one pose, computed once (trig shared with gravity). */
typedef struct {
    hg_real sa, ca, sb, cb, sg, cg;  /* sin/cos of alpha, beta, gamma     */
    hg_real db, dg;                  /* d_beta, d_gamma (paper eqs 5, 6)  */
    hg_real rho;                     /* m, in-plane distance from the A axis */
    hg_real sin_bg;                  /* sin(beta + gamma)                 */
    hg_real p[3];                    /* m, endpoint                       */
    hg_real J[3][3];                 /* J[i][j] = dp_i / dq_j             */
} hg_kin_t;

void hg_kin_eval(const hg_linkage_t *lk, const hg_real q[3], hg_kin_t *k);
/* Branch cos(alpha) > 0, rho > 0. Returns 0, or -1 if p is out of reach / off the branch. */
int hg_kin_ik(const hg_linkage_t *lk, const hg_real p[3], hg_real q[3]);
void hg_kin_jt(const hg_kin_t *k, const hg_real f[3], hg_real tau[3]); /* tau = J^T f  */
void hg_kin_jv(const hg_kin_t *k, const hg_real qd[3], hg_real v[3]);  /* v = J qd     */
hg_real hg_kin_guard(const hg_guard_t *g, const hg_kin_t *k);          /* 0..1 factor  */

#endif /* HG_KIN_H */
