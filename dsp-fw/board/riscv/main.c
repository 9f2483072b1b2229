/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop on the hapgate SoC: the boards' shared loop (board/board_main.c)
 * with the SoC's UART, and the FPGA clock read from the register file (CLK_KHZ), so that the
 * servo's TICK_DIV is right at any SoC clock. The tick interrupt (trap.c) runs the servo; this
 * loop serves the PC link. This board has no non-volatile store yet: no stored calibration,
 * the PC's bring-up finds it. */
#include <stdint.h>
#include "board_main.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "uart.h"

int main(void);
int main(void)
{
    const hg_board_io_t io = { uart_rx_ready, uart_rx, uart_send,
                               fpga_read32(HG_REG_CLK_KHZ) * 1000u, uart_baud() };
    hg_board_run(&io, NULL);
}
