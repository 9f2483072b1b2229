/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop, shared by every board (board_main.h). */
#include "board_main.h"
#include "hg_bringup.h"
#include "hg_link.h"
#include "hg_servo.h"

static hg_servo_t servo;
static hg_link_t link;
static hg_bringup_t bringup;

/* One pass of the background loop: a received byte to the link, else its pushes and
 * timeouts; what it answers goes out on the UART. */
static void link_pass(const hg_board_io_t *io)
{
    uint8_t tx[HG_LINK_MAX_FRAME];
    size_t n = 0;
    if (io->rx_ready())
        n = hg_link_rx_byte(&link, io->rx(), tx);
    if (n == 0)
        n = hg_link_poll(&link, true, tx);
    io->send(tx, n);
}

void hg_board_run(const hg_board_io_t *io, const hg_calib_t *stored)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    if (io->fpga_clk_hz)
        cfg.fpga_clk_hz = io->fpga_clk_hz;
    for (unsigned i = 0; i < 3u; i++) /* nothing is homed at power-up */
        cfg.cal.axis[i].flags = (uint8_t)(cfg.cal.axis[i].flags & ~HG_CAL_HOMED);
    if (hg_servo_init(&servo, &cfg) == HG_ERR_NONE)
        hg_servo_isr_ctx = &servo;
    hg_link_init(&link, &servo); /* the link answers from here on, homed or not */
    if (io->baud)
        link.cfg.baud = io->baud;
    while (*(volatile uint32_t *)&servo.steps < HG_BU_POWER_UP_TICKS && hg_servo_isr_ctx)
        link_pass(io);
    hg_bringup_cfg_t bc;
    hg_bringup_default_cfg(&bc);
    hg_bringup_init(&bringup, &servo, &bc, stored);
    if (stored)
        (void)hg_bringup_power_up(&bringup);
    hg_bringup_isr_ctx = &bringup;
    link.bu = &bringup;
    for (;;)
        link_pass(io);
}
