/* SPDX-License-Identifier: Apache-2.0 */
/* Scene force: virtual wall, spring/PID to a point, viscous field, PC-commanded force. */
#include "hg_scene.h"

static hg_real dot3(const hg_real a[3], const hg_real b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static bool in_range(hg_real x, hg_real hi)
{
    return x >= HG_C(0.0) && x <= hi; /* false for NaN */
}

int hg_scene_check(hg_scene_t *sc)
{
    if (sc->type >= HG_SCENE_COUNT)
        return -1;
    if (!in_range(sc->k, HG_SCENE_K_LIMIT) || !in_range(sc->b, HG_SCENE_B_MAX)
        || !in_range(sc->ki, HG_SCENE_KI_MAX)
        || !in_range(dot3(sc->p0, sc->p0), HG_SCENE_P_MAX * HG_SCENE_P_MAX))
        return -1;
    const hg_real nn = dot3(sc->n, sc->n);
    if (sc->type == HG_SCENE_WALL) {
        if (!(nn >= HG_C(0.25) && nn <= HG_C(4.0)))
            return -1;
        const hg_real inv = HG_C(1.0) / HG_SQRT(nn);
        for (int i = 0; i < 3; i++)
            sc->n[i] *= inv;
    } else if (!isfinite(nn)) {
        return -1;
    }
    return 0;
}

void hg_scene_force(const hg_scene_t *sc, hg_scene_state_t *st, const hg_real p[3],
                    const hg_real v[3], const hg_real f_pc[3], hg_real dt, bool integrate,
                    hg_real f_max, hg_real fi_max, hg_real f[3])
{
    hg_real e[3] = { 0 };
    f[0] = f[1] = f[2] = HG_C(0.0);
    switch (sc->type) {
    case HG_SCENE_WALL: {
        hg_real d[3];
        for (int i = 0; i < 3; i++)
            d[i] = sc->p0[i] - p[i];
        const hg_real depth = dot3(d, sc->n);
        if (depth > HG_C(0.0)) {
            hg_real mag = sc->k * depth - sc->b * dot3(v, sc->n);
            mag = mag < HG_C(0.0) ? HG_C(0.0) : mag; /* a wall pushes, never pulls; NaN stays NaN */
            for (int i = 0; i < 3; i++)
                f[i] = mag * sc->n[i];
        }
        break;
    }
    case HG_SCENE_SPRING:
        for (int i = 0; i < 3; i++) {
            e[i] = p[i] - sc->p0[i];
            f[i] = -sc->k * e[i] - sc->b * v[i] - sc->ki * st->integ[i];
        }
        break;
    case HG_SCENE_VISCOUS:
        for (int i = 0; i < 3; i++)
            f[i] = -sc->b * v[i];
        break;
    case HG_SCENE_PC_FORCE:
        for (int i = 0; i < 3; i++)
            f[i] = f_pc[i];
        break;
    default:
        break;
    }
    const hg_real mag2 = dot3(f, f);
    const bool saturated = mag2 > f_max * f_max;
    if (saturated) {
        const hg_real s = f_max / HG_SQRT(mag2);
        for (int i = 0; i < 3; i++)
            f[i] *= s;
    }
    if (sc->type == HG_SCENE_SPRING && integrate && !saturated && sc->ki > HG_C(0.0)) {
        const hg_real lim = fi_max / sc->ki;
        for (int i = 0; i < 3; i++)
            st->integ[i] = hg_clamp(st->integ[i] + e[i] * dt, -lim, lim);
    }
}
