/* SPDX-License-Identifier: Apache-2.0 */
/* kin-dump: read "alpha,beta,gamma,fx,fy,fz" lines (rad, N) on stdin, write CSV of the
 * firmware kinematics (default linkage) on stdout: p, J (row-major), tau = J^T F, IK(p), guard.
 * Built twice: kin-dump-f (float, the firmware) and kin-dump-d (-DHG_REAL_DOUBLE). */
#include <stdio.h>
#include "hg_kin.h"

int main(void)
{
    const hg_linkage_t lk = HG_LINKAGE_DEFAULT;
    const hg_guard_t g = HG_GUARD_DEFAULT;
    double in[6];
    printf("x,y,z,j00,j01,j02,j10,j11,j12,j20,j21,j22,ta,tb,tg,ik_ok,ika,ikb,ikg,guard\n");
    while (scanf("%lf,%lf,%lf,%lf,%lf,%lf", &in[0], &in[1], &in[2], &in[3], &in[4], &in[5])
           == 6) {
        const hg_real q[3] = { (hg_real)in[0], (hg_real)in[1], (hg_real)in[2] };
        const hg_real f[3] = { (hg_real)in[3], (hg_real)in[4], (hg_real)in[5] };
        hg_real tau[3], qi[3] = { 0, 0, 0 };
        hg_kin_t k;
        hg_kin_eval(&lk, q, &k);
        hg_kin_jt(&k, f, tau);
        const int ok = hg_kin_ik(&lk, k.p, qi) == 0;
        printf("%.17g,%.17g,%.17g", (double)k.p[0], (double)k.p[1], (double)k.p[2]);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                printf(",%.17g", (double)k.J[i][j]);
        printf(",%.17g,%.17g,%.17g,%d", (double)tau[0], (double)tau[1], (double)tau[2], ok);
        printf(",%.17g,%.17g,%.17g,%.17g\n", (double)qi[0], (double)qi[1], (double)qi[2],
               (double)hg_kin_guard(&g, &k));
    }
    return 0;
}
