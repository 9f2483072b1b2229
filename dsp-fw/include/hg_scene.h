/* SPDX-License-Identifier: Apache-2.0 */
/* Scene: the Cartesian force of the active scene element at the endpoint. */
#ifndef HG_SCENE_H
#define HG_SCENE_H

#include <stdbool.h>
#include <stdint.h>
#include "hg_proto.h"
#include "hg_real.h"

/* The scene kinds (HG_SCENE_NONE ... HG_SCENE_PC_FORCE) are protocol values: hg_proto.h. */

/* Parameter ranges accepted by hg_scene_check() */
#define HG_SCENE_K_MAX  HG_C(3500.0)  /* N/m = 35 N/cm, the PHANToM-class stiffness target */
#define HG_SCENE_B_MAX  HG_C(100.0)   /* N s/m */
#define HG_SCENE_KI_MAX HG_C(1.0e5)   /* N/(m s) */
#define HG_SCENE_P_MAX  HG_C(0.2)     /* m, |p0| */
/* The k that hg_scene_check() accepts: HG_SCENE_K_MAX, the safety limit of every build, unless
 * a simulation build defines HG_SCENE_K_MAX_TEST (a separately named test limit: the Z-width
 * sweep, models/hapgate/device/zwidth.py, renders walls up to 50 000 N/m). Never on hardware. */
#ifdef HG_SCENE_K_MAX_TEST
#define HG_SCENE_K_LIMIT ((hg_real)(HG_SCENE_K_MAX_TEST))
#else
#define HG_SCENE_K_LIMIT HG_SCENE_K_MAX
#endif

typedef struct {
    uint8_t type;    /* HG_SCENE_* */
    hg_real p0[3];   /* m      wall point / spring anchor                 */
    hg_real n[3];    /* -      wall normal (normalised by hg_scene_check) */
    hg_real k;       /* N/m    stiffness                                  */
    hg_real b;       /* N s/m  damping (wall, spring) or viscosity        */
    hg_real ki;      /* N/(m s) spring integral gain                     */
} hg_scene_t;

typedef struct {
    hg_real integ[3]; /* m s, integral of the spring error */
} hg_scene_state_t;

/* Validate (type, finite, ranges, |n| in [0.5, 2]) and normalise n in place. 0 if accepted. */
int hg_scene_check(hg_scene_t *sc);

/* f = scene force, |f| clamped to f_max. The spring integral advances by dt only when
 * integrate is true and the output is not saturated, and |ki integ| stays <= fi_max per axis
 * (anti-windup: clamping plus conditional integration). */
void hg_scene_force(const hg_scene_t *sc, hg_scene_state_t *st, const hg_real p[3],
                    const hg_real v[3], const hg_real f_pc[3], hg_real dt, bool integrate,
                    hg_real f_max, hg_real fi_max, hg_real f[3]);

#endif /* HG_SCENE_H */
