/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop, shared by every board (board.c: the Cortex-M4F stub; riscv/main.c:
 * the hapgate SoC). A board gives its UART and, from its start-up, calls hg_board_run. */
#ifndef HG_BOARD_MAIN_H
#define HG_BOARD_MAIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_calib.h"
#include "hg_link.h"

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

/* A board's stored setup (a configuration sector flashed with the image): what this joystick
 * is (its calibration, servo rate, the reference pose the power-up fixture holds and its
 * bring-up bounds) and what it does on its own (an environment rendered from power-up and,
 * without a PC, the time its forces are enabled). Every word is 32 bits, floats as IEEE-754
 * binary32; a zero (or a magic other than HG_BOARD_SETUP_MAGIC) means "the default". */
#define HG_BOARD_SETUP_MAGIC 0x46434748u /* "HGCF" */
typedef struct {
    uint32_t magic;              /* HG_BOARD_SETUP_MAGIC: the sector holds a setup             */
    uint32_t words;              /* its length in words (sizeof / 4): the layout's check       */
    int32_t calib[3][6];         /* per axis: flags, enc_dir, phases_swapped, pole_pairs,
                                  * index_to_zero, comm_offset (hg_axis_calib_t)              */
    uint32_t rate_hz;            /* servo rate (0: the firmware's default)                     */
    int32_t pc_force_timeout;    /* ticks (-1: the firmware's default)                         */
    float q_ref[3];              /* rad: the power-up pose (bring-up's reference)             */
    float align_cycles, align_rate, travel_max; /* bring-up's bounds (hg_bringup_cfg_t); with
                                  * q_ref, used together when travel_max > 0          */
    uint32_t env_kind;           /* the environment set at power-up (hg_scene_t)               */
    float env_p[3], env_n[3], env_k, env_b, env_ki;
    uint32_t enable_at_us;       /* stand-alone: enable the forces once now_us() reaches this,
                                  * if calibrated (0: never; a PC enables)                     */
} hg_board_setup_t;

/* hg_board_run with a stored setup (NULL: as hg_board_run): the servo and bring-up configured
 * from it, its calibration the stored one when every axis of it is homed and aligned (the
 * servo still starts unhomed), its environment set at power-up, its timed enable checked on
 * every pass of the loop (now_us: the board's microsecond clock). */
void hg_board_run_setup(const hg_board_io_t *io, const hg_board_setup_t *setup,
                        uint32_t (*now_us)(void)) __attribute__((noreturn));

/* The link's counters (for a debugger or the simulation: rtl/soc README) */
extern volatile hg_link_stats_t hg_board_link_stats;

#endif /* HG_BOARD_MAIN_H */
