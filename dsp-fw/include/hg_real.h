/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's real type. float by default (the C6713 is a single-precision float DSP);
 * -DHG_REAL_DOUBLE builds the same sources in double, which the tests use as the reference
 * for "float within ~1e-6 relative of double". HG_C() spells a constant in the right type. */
#ifndef HG_REAL_H
#define HG_REAL_H

#include <math.h>

#ifdef HG_REAL_DOUBLE
typedef double hg_real;
#define HG_C(x) (x)
#define HG_SIN sin
#define HG_COS cos
#define HG_SQRT sqrt
#define HG_ATAN2 atan2
#define HG_ACOS acos
#define HG_FABS fabs
#else
typedef float hg_real;
#define HG_C(x) (x##f)
#define HG_SIN sinf
#define HG_COS cosf
#define HG_SQRT sqrtf
#define HG_ATAN2 atan2f
#define HG_ACOS acosf
#define HG_FABS fabsf
#endif

#define HG_PI HG_C(3.14159265358979323846)

static inline hg_real hg_clamp(hg_real x, hg_real lo, hg_real hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

#endif /* HG_REAL_H */
