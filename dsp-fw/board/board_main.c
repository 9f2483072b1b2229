/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's main loop, shared by every board (board_main.h). */
#include "board_main.h"
#include "hg_bringup.h"
#include "hg_link.h"
#include "hg_servo.h"

static hg_servo_t servo;
static hg_link_t link;
static hg_bringup_t bringup;

volatile hg_link_stats_t hg_board_link_stats;

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
    hg_board_link_stats = link.st;
}

static bool setup_valid(const hg_board_setup_t *s)
{
    return s && s->magic == HG_BOARD_SETUP_MAGIC && s->words == sizeof *s / 4u;
}

static hg_scene_t setup_scene(const hg_board_setup_t *s)
{
    hg_scene_t sc = { 0 };
    sc.type = (uint8_t)s->env_kind;
    for (unsigned i = 0; i < 3u; i++) {
        sc.p0[i] = (hg_real)s->env_p[i];
        sc.n[i] = (hg_real)s->env_n[i];
    }
    sc.k = (hg_real)s->env_k;
    sc.b = (hg_real)s->env_b;
    sc.ki = (hg_real)s->env_ki;
    return sc;
}

void hg_board_run_setup(const hg_board_io_t *io, const hg_board_setup_t *setup,
                        uint32_t (*now_us)(void))
{
    const bool have = setup_valid(setup);
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    if (io->fpga_clk_hz)
        cfg.fpga_clk_hz = io->fpga_clk_hz;
    hg_calib_t stored;
    bool all = false;
    if (have) {
        if (setup->rate_hz)
            cfg.rate_hz = setup->rate_hz;
        if (setup->pc_force_timeout >= 0)
            cfg.pc_force_timeout = (uint32_t)setup->pc_force_timeout;
        all = true;
        for (unsigned i = 0; i < 3u; i++) {
            hg_axis_calib_t *a = &cfg.cal.axis[i];
            const int32_t *w = setup->calib[i];
            a->flags = (uint8_t)w[0];
            a->enc_dir = (int8_t)w[1];
            a->phases_swapped = (uint8_t)w[2];
            a->pole_pairs = (uint8_t)w[3];
            a->index_to_zero = w[4];
            a->comm_offset = (uint32_t)w[5];
            all = all && (a->flags & (HG_CAL_HOMED | HG_CAL_ALIGNED)) ==
                             (HG_CAL_HOMED | HG_CAL_ALIGNED);
        }
        stored = cfg.cal;
    }
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
    if (have && setup->travel_max > 0.0f) { /* the linkage's geometry, given together */
        for (unsigned i = 0; i < 3u; i++)
            bc.q_ref[i] = (hg_real)setup->q_ref[i];
        bc.align_cycles = (hg_real)setup->align_cycles;
        bc.align_rate = (hg_real)setup->align_rate;
        bc.travel_max = (hg_real)setup->travel_max;
    }
    hg_bringup_init(&bringup, &servo, &bc, all ? &stored : NULL);
    if (all)
        (void)hg_bringup_power_up(&bringup);
    if (have) {
        const hg_scene_t sc = setup_scene(setup);
        (void)hg_servo_set_scene(&servo, &sc);
    }
    hg_bringup_isr_ctx = &bringup;
    link.bu = &bringup;
    bool enable_due = have && setup->enable_at_us != 0u && now_us;
    for (;;) {
        link_pass(io);
        if (enable_due && now_us() >= setup->enable_at_us) {
            enable_due = false;
            if (hg_servo_calibrated(&servo))
                (void)hg_servo_enable(&servo, true);
        }
    }
}

void hg_board_run(const hg_board_io_t *io, const hg_calib_t *stored)
{
    if (!stored)
        hg_board_run_setup(io, NULL, NULL);
    hg_board_setup_t s = { 0 };
    s.magic = HG_BOARD_SETUP_MAGIC;
    s.words = sizeof s / 4u;
    s.pc_force_timeout = -1;
    for (unsigned i = 0; i < 3u; i++) {
        const hg_axis_calib_t *a = &stored->axis[i];
        s.calib[i][0] = a->flags;
        s.calib[i][1] = a->enc_dir;
        s.calib[i][2] = a->phases_swapped;
        s.calib[i][3] = a->pole_pairs;
        s.calib[i][4] = a->index_to_zero;
        s.calib[i][5] = (int32_t)a->comm_offset;
    }
    hg_board_run_setup(io, &s, NULL);
}
