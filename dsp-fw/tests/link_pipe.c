/* SPDX-License-Identifier: Apache-2.0 */
/* link-pipe: the PC link on stdin/stdout over the host HAL, for host-side tools and tests
 * (tb/fw drives it with models/hapgate/golden/pclink.py). The servo is stepped once per received
 * byte with the pose q = (0, 45, 45) deg, so GET_STATE reports p = (0, 70.7 mm, 0). */
#include <stdio.h>
#include "hal_sim.h"
#include "hg_link.h"

int main(void)
{
    static const int32_t pos[3] = { 0, 1 << 17, 1 << 17 }, vel[3] = { 0, 0, 0 };
    hg_servo_cfg_t cfg;
    hg_servo_t s;
    hg_link_t l;
    hg_servo_default_cfg(&cfg);
    hal_sim_reset();
    hg_servo_init(&s, &cfg);
    hg_link_init(&l, &s);
    int c;
    while ((c = getchar()) != EOF) {
        uint8_t tx[HG_LINK_MAX_FRAME];
        hal_sim_snapshot(pos, vel);
        hg_servo_step(&s);
        const size_t n = hg_link_rx_byte(&l, (uint8_t)c, tx);
        if (n && fwrite(tx, 1, n, stdout) != n)
            return 1;
    }
    return 0;
}
