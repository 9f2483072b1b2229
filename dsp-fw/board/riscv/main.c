/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop on the hapgate SoC: dsp-fw/board/board.c's, with the SoC's UART and
 * the FPGA clock read from the register file (CLK_KHZ), so that the servo's TICK_DIV is right at
 * any SoC clock. The tick interrupt (trap.c) runs the servo; this loop serves the PC link. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_bringup.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "hg_link.h"
#include "hg_servo.h"
#include "uart.h"

static hg_servo_t servo;
static hg_link_t link;
static hg_bringup_t bringup;

/* One pass of the background loop: a received byte to the link, else its pushes and
 * timeouts; what it answers goes out on the UART. */
static void link_pass(void)
{
    uint8_t tx[HG_LINK_MAX_FRAME];
    size_t n = 0;
    if (uart_rx_ready())
        n = hg_link_rx_byte(&link, uart_rx(), tx);
    if (n == 0)
        n = hg_link_poll(&link, true, tx);
    uart_send(tx, n);
}

int main(void);
int main(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.fpga_clk_hz = fpga_read32(HG_REG_CLK_KHZ) * 1000u;
    /* nothing is homed at power-up: ENABLE and forces stay refused until the restart below
     * (or bring-up's HOME, or SET_CALIB) homes each axis (as board.c) */
    for (unsigned i = 0; i < 3u; i++)
        cfg.cal.axis[i].flags = (uint8_t)(cfg.cal.axis[i].flags & ~HG_CAL_HOMED);
    if (hg_servo_init(&servo, &cfg) == HG_ERR_NONE)
        hg_servo_isr_ctx = &servo;
    /* the link answers from the first line, homed or not (bring-up until the power-up below) */
    hg_link_init(&link, &servo);
    link.cfg.baud = uart_baud();
    /* the power-up pose is the reference pose (a fixture holds the handle there). Once the
     * snapshot has settled, a stored calibration (none yet on this board: it has no
     * non-volatile store) is restarted without motion; without one the PC's bring-up (ALIGN,
     * HOME) finds it. */
    while (*(volatile uint32_t *)&servo.steps < HG_BU_POWER_UP_TICKS && hg_servo_isr_ctx)
        link_pass();
    static const hg_calib_t *const stored = NULL;
    hg_bringup_cfg_t bc;
    hg_bringup_default_cfg(&bc);
    hg_bringup_init(&bringup, &servo, &bc, stored);
    if (stored)
        (void)hg_bringup_power_up(&bringup);
    hg_bringup_isr_ctx = &bringup;
    link.bu = &bringup;
    for (;;)
        link_pass();
}
