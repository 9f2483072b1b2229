/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop, shared by every board (board.c: the Cortex-M4F stub; riscv/main.c:
 * the hapgate SoC). A board gives its UART and, from its start-up, calls hg_board_run. */
#ifndef HG_BOARD_MAIN_H
#define HG_BOARD_MAIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_calib.h"

typedef struct {
    bool (*rx_ready)(void);                      /* a received byte is waiting          */
    uint8_t (*rx)(void);                         /* take it                             */
    void (*send)(const uint8_t *d, size_t n);    /* send n bytes (blocking)             */
    uint32_t fpga_clk_hz;                        /* the FPGA's clock (0: the default)   */
    uint32_t baud;                               /* the link's rate for INFO (0: default) */
} hg_board_io_t;

/* Servo init with nothing homed (ENABLE and forces refused until each axis is), the PC link
 * answering from the first line, then, once the snapshot has settled
 * (HG_BU_POWER_UP_TICKS servo ticks), bring-up in the power-up pose (the reference pose: a
 * fixture holds the handle there) with the stored calibration, restarted without motion
 * (hg_bringup_power_up; NULL: none, the PC's bring-up finds it); then the link forever. The
 * board's tick interrupt calls hg_bringup_isr(). */
void hg_board_run(const hg_board_io_t *io, const hg_calib_t *stored) __attribute__((noreturn));

#endif /* HG_BOARD_MAIN_H */
