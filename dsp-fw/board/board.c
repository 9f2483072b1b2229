/* SPDX-License-Identifier: Apache-2.0 */
/* A stub board for the freestanding Cortex-M4F build (make cross): the HAL on a memory-mapped
 * FPGA bus window, interrupt masking with PRIMASK, a UART as two registers, and the firmware's
 * main loop. A real board replaces this file (its bus address, UART and tick interrupt) and
 * startup.c / cortex-m4.ld (its memory). Nothing here runs in a test: the build proves that
 * the firmware links against its HAL and libm alone. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_bringup.h"
#include "hg_hal.h"
#include "hg_link.h"
#include "hg_servo.h"

#define FPGA_BASE 0x60000000u /* the external-bus (FSMC-like) window the FPGA decodes */
#define UART_BASE 0x40011000u /* data register at +4, status at +0 (bit 5 rx full, 7 tx empty) */

static volatile uint32_t *const fpga = (volatile uint32_t *)FPGA_BASE;
static volatile uint32_t *const uart = (volatile uint32_t *)UART_BASE;

uint32_t fpga_read32(uint32_t addr)
{
    return fpga[addr];
}

void fpga_write32(uint32_t addr, uint32_t v)
{
    fpga[addr] = v;
}

uint32_t hg_hal_irq_save(void)
{
    uint32_t primask;
    __asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask) : : "memory");
    return primask;
}

void hg_hal_irq_restore(uint32_t token)
{
    __asm__ volatile("msr primask, %0" : : "r"(token) : "memory");
}

static hg_servo_t servo;
static hg_link_t link;
static hg_bringup_t bringup;

/* The FPGA's servo-tick interrupt line (an external interrupt on a real board): the bring-up
 * step while one runs, else the servo step. */
void board_tick_irq(void);
void board_tick_irq(void)
{
    hg_bringup_isr();
}

static void uart_send(const uint8_t *d, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        while (!(uart[0] & (1u << 7)))
            ;
        uart[1] = d[i];
    }
}

/* One pass of the background loop: a received byte to the link, else its pushes and
 * timeouts; what it answers goes out on the UART. */
static void link_pass(void)
{
    uint8_t tx[HG_LINK_MAX_FRAME];
    size_t n = 0;
    if (uart[0] & (1u << 5))
        n = hg_link_rx_byte(&link, (uint8_t)uart[1], tx);
    if (n == 0)
        n = hg_link_poll(&link, true, tx);
    uart_send(tx, n);
}

int main(void);
int main(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    /* nothing is homed at power-up: ENABLE and forces stay refused until the restart below
     * (or bring-up's HOME) homes each axis */
    for (unsigned i = 0; i < 3u; i++)
        cfg.cal.axis[i].flags = (uint8_t)(cfg.cal.axis[i].flags & ~HG_CAL_HOMED);
    if (hg_servo_init(&servo, &cfg) == HG_ERR_NONE)
        hg_servo_isr_ctx = &servo;
    /* the link answers from the first line, homed or not (bring-up until the power-up below) */
    hg_link_init(&link, &servo);
    /* the power-up pose is the reference pose (a fixture holds the handle there); a real
     * board sets q_ref and the bounds from its linkage. Once the snapshot has settled, a stored
     * calibration (flash; none on this stub) is restarted without motion: the paper's power-up.
     * Without one the PC's bring-up (ALIGN, HOME) finds it. */
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
