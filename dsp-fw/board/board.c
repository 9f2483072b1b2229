/* SPDX-License-Identifier: Apache-2.0 */
/* A stub board for the freestanding Cortex-M4F build (make cross): the HAL on a memory-mapped
 * FPGA bus window, interrupt masking with PRIMASK, a UART as two registers, and the firmware's
 * main loop. A real board replaces this file (its bus address, UART and tick interrupt) and
 * startup.c / cortex-m4.ld (its memory). Nothing here runs in a test: the build proves that
 * the firmware links against its HAL and libm alone. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "board_main.h"
#include "hg_bringup.h"
#include "hg_hal.h"

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

/* The FPGA's servo-tick interrupt line (an external interrupt on a real board): the bring-up
 * step while one runs, else the servo step. */
void board_tick_irq(void);
void board_tick_irq(void)
{
    hg_bringup_isr();
}

static bool uart_rx_ready(void)
{
    return (uart[0] & (1u << 5)) != 0;
}

static uint8_t uart_rx(void)
{
    return (uint8_t)uart[1];
}

static void uart_send(const uint8_t *d, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        while (!(uart[0] & (1u << 7)))
            ;
        uart[1] = d[i];
    }
}

int main(void);
int main(void)
{
    /* a real board sets q_ref and the bounds from its linkage, and passes the calibration it
     * keeps in flash (none on this stub) */
    static const hg_board_io_t io = { uart_rx_ready, uart_rx, uart_send, 0u, 0u };
    hg_board_run(&io, NULL);
}
