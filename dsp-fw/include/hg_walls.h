/* SPDX-License-Identifier: Apache-2.0 */
/* Workspace-boundary walls in actuator-angle space: each wall bounds s = c . q to [lo, hi] with
 * a one-sided spring-damper, so the user cannot drive the linkage into itself, the housing or a
 * singular set (docs/design/KINEMATICS.md: keep the walls away from cos alpha = 0, sin(beta+gamma) = 0). */
#ifndef HG_WALLS_H
#define HG_WALLS_H

#include "hg_real.h"

#define HG_NWALLS 4

typedef struct {
    hg_real c[3];   /* -    constraint row: s = c . q              */
    hg_real lo, hi; /* rad  allowed range of s                     */
} hg_qwall_t;

typedef struct {
    hg_qwall_t w[HG_NWALLS];
    hg_real k;      /* N m / rad    wall stiffness                */
    hg_real b;      /* N m s / rad  wall damping (inside the wall) */
} hg_walls_t;

/* tau += c * f for every wall, f pushing s back into [lo, hi] (never pulling). */
void hg_walls_add(const hg_walls_t *w, const hg_real q[3], const hg_real qd[3], hg_real tau[3]);

#endif /* HG_WALLS_H */
