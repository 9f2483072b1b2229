/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop on the hapgate SoC: the boards' shared loop (board/board_main.c)
 * with the SoC's UART, and the FPGA clock read from the register file (CLK_KHZ), so that the
 * servo's TICK_DIV is right at any SoC clock. The tick interrupt (trap.c) runs the servo; this
 * loop serves the PC link. The board's stored setup (its calibration, rate, power-up pose,
 * environment: board_main.h) is the configuration sector hg_board_setup, a region of the image
 * that the build leaves empty (no setup: nothing stored, the PC's bring-up finds it) and that a
 * flashing tool (or the simulation, hapgate.device.soc) fills in the image it loads. */
#include <stdint.h>
#include "board_main.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "soc.h"
#include "uart.h"

/* read-only data, so that the image holds it (a word-aligned region at a
 * symbol's address), read through volatile loads: its contents are the image's, never the
 * compiler's zeros */
__attribute__((used, aligned(4)))
const hg_board_setup_t hg_board_setup = { 0 };

static uint32_t mtime_us(void)   /* the machine timer: microseconds since reset */
{
    return ((volatile uint32_t *)SOC_TIMER_BASE)[0];
}

int main(void);
int main(void)
{
    const hg_board_io_t io = { uart_rx_ready, uart_rx, uart_send,
                               fpga_read32(HG_REG_CLK_KHZ) * 1000u, uart_baud() };
    static hg_board_setup_t setup;   /* a copy: the loop reads it as plain memory */
    const volatile uint32_t *src = (const volatile uint32_t *)&hg_board_setup;
    uint32_t *dst = (uint32_t *)&setup;
    for (unsigned i = 0; i < sizeof setup / 4u; i++)
        dst[i] = src[i];
    hg_board_run_setup(&io, &setup, mtime_us);
}
