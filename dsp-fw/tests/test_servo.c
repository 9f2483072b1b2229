/* SPDX-License-Identifier: Apache-2.0 */
/* Servo step: init, outputs, controller responses, every safety path. */
#include <stdlib.h>
#include "hal_sim.h"
#include "hg_fpga_regs.h"
#include "hg_test.h"

static const double Q45[3] = { 0, DEG_D(45.0), DEG_D(45.0) }; /* p = (0, 70.7 mm, 0) */
static const double QD0[3] = { 0, 0, 0 };

static void setup(hg_servo_t *s)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    fx_servo(s, &cfg);
}

static void wall_y(hg_servo_t *s, float y, float k, float b)
{
    const hg_scene_t sc = { HG_SCENE_WALL, { 0, y, 0 }, { 0, -1, 0 }, k, b, 0 };
    CHECK(hg_servo_set_scene(s, &sc) == 0);
}

void test_servo_init(void)
{
    hg_servo_t s;
    setup(&s);
    CHECK(s.err == HG_ERR_NONE);
    CHECK(hal_sim_regs[HG_REG_TICK_DIV] == 48000);
    for (uint32_t i = 0; i < 3; i++) {
        CHECK(hal_sim_regs[HG_REG_AXIS(i, HG_AX_MODE)] == HG_MODE_TORQUE);
        CHECK(hal_sim_regs[HG_REG_AXIS(i, HG_AX_TQ_LIMIT)] == 20479); /* 0.3 of 0.48 N m */
        CHECK(hal_sim_nwrites[HG_REG_AXIS(i, HG_AX_TORQUE)] == 1 && hal_sim_torque(i) == 0);
    }
    CHECK(hal_sim_regs[HG_REG_WDOG] == HG_WDOG_KEY);

    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.rate_hz = 20000;
    fx_servo(&s, &cfg);
    CHECK(s.err == HG_ERR_CONFIG && hal_sim_nwrites[HG_REG_WDOG] == 0);
    hg_servo_default_cfg(&cfg);
    cfg.motor[2].kt = NAN;
    fx_servo(&s, &cfg);
    CHECK(s.err == HG_ERR_CONFIG);
    hg_servo_default_cfg(&cfg);
    hal_sim_reset();
    hal_sim_regs[HG_REG_ID] = 0x12345678u;
    CHECK(hg_servo_init(&s, &cfg) == HG_ERR_FPGA_ID);
    CHECK(hal_sim_nwrites[HG_REG_AXIS(0, HG_AX_TORQUE)] == 1 && hal_sim_torque(0) == 0);
    CHECK(hg_servo_enable(&s, true) != 0);
}

/* Wall 1 mm into the check pose: F = (0, -1, 0) N, so tau = (0, 0.0354, 0.0354) N m
 * (docs/design/KINEMATICS.md), written as codes, only while enabled. */
void test_servo_wall_torque(void)
{
    hg_servo_t s;
    setup(&s);
    wall_y(&s, 0.1f * sqrtf(0.5f) - 0.001f, 1000, 0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_torque(0) == 0 && hal_sim_torque(1) == 0 && hal_sim_regs[HG_REG_CTRL] == 0);
    CHECK_NEAR(s.f[1], -1.0, 1e-3);
    CHECK(hg_servo_enable(&s, true) == 0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    const double lsb = 0.48 / 32767;
    CHECK(abs(hal_sim_torque(0)) <= 1);
    CHECK_NEAR(fx_code_to_tau(&s.cfg.motor[1], hal_sim_torque(1)), 0.05 * sqrt(0.5), 1.5 * lsb);
    CHECK_NEAR(fx_code_to_tau(&s.cfg.motor[2], hal_sim_torque(2)), 0.05 * sqrt(0.5), 1.5 * lsb);
    CHECK(hal_sim_regs[HG_REG_CTRL] == 0xFu);
    CHECK(hal_sim_nwrites[HG_REG_WDOG] == 3); /* init + one per step */
    /* the ISR entry steps the registered servo and acknowledges the tick */
    hg_servo_isr_ctx = &s;
    fx_pose(&s, Q45, QD0);
    hg_servo_isr();
    hg_servo_isr_ctx = NULL;
    CHECK(s.steps == 3 && hal_sim_nwrites[HG_REG_IRQ] == 1);
    /* disable: zero torque at the next step */
    CHECK(hg_servo_enable(&s, false) == 0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_torque(1) == 0 && hal_sim_torque(2) == 0 && hal_sim_regs[HG_REG_CTRL] == 0);
    CHECK(hal_sim_irq_depth == 0 && hal_sim_irq_saves >= 3);
}

void test_servo_torque_clamp(void)
{
    hg_servo_t s;
    setup(&s);
    const hg_scene_t sc = { HG_SCENE_PC_FORCE, { 0 }, { 0 }, 0, 0, 0 };
    const hg_real f[3] = { 0, -10, 0 }; /* needs 0.354 N m, tau_max is 0.3 */
    CHECK(hg_servo_set_scene(&s, &sc) == 0 && hg_servo_set_force(&s, f) == 0);
    CHECK(hg_servo_enable(&s, true) == 0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_torque(1) == 20479 && hal_sim_torque(2) == 20479);
    const hg_real too_big[3] = { 0, -10.5f, 0 }, nan[3] = { NAN, 0, 0 };
    CHECK(hg_servo_set_force(&s, too_big) != 0 && hg_servo_set_force(&s, nan) != 0);
    CHECK(s.f_pc[1] == -10.0f);
}

void test_servo_pc_force_timeout(void)
{
    hg_servo_t s;
    setup(&s);
    const hg_scene_t sc = { HG_SCENE_PC_FORCE, { 0 }, { 0 }, 0, 0, 0 };
    const hg_real f[3] = { 0, -1, 0 };
    CHECK(hg_servo_set_scene(&s, &sc) == 0 && hg_servo_enable(&s, true) == 0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_torque(1) == 0); /* nothing sent yet */
    CHECK(hg_servo_set_force(&s, f) == 0);
    uint32_t held = 0;
    for (uint32_t i = 0; i < s.cfg.pc_force_timeout; i++) {
        fx_pose(&s, Q45, QD0);
        hg_servo_step(&s);
        held += hal_sim_torque(1) > 2400; /* 0.0354 N m = 2417 codes */
    }
    CHECK(held == s.cfg.pc_force_timeout);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_torque(1) == 0 && s.err == HG_ERR_NONE);
}

/* Step response on a simulated plant: a 0.1 kg endpoint mass pushed by the user with 2 N into
 * a 1000 N/m wall settles at depth F/k = 2 mm, damped, and never pulled through the wall. */
static void solve3(const hg_real J[3][3], const double t[3], double f[3]) /* J^T f = t */
{
    double a[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            a[i][j] = (double)J[j][i];
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                     - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                     + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    for (int c = 0; c < 3; c++) {
        double m[3][3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                m[i][j] = j == c ? t[i] : a[i][j];
        f[c] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
              - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
              + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) / det;
    }
}

void test_servo_step_response_wall(void)
{
    hg_servo_t s;
    setup(&s);
    const double wall = 0.070, mass = 0.1, push = 2.0, dt = 1e-3;
    wall_y(&s, (float)wall, 1000, 10);
    CHECK(hg_servo_enable(&s, true) == 0);
    double p[3] = { 0, 0.065, 0 }, v[3] = { 0 }, qprev[3] = { 0 }, ymax = 0;
    for (int n = 0; n < 1500; n++) {
        hg_real pr[3] = { (hg_real)p[0], (hg_real)p[1], (hg_real)p[2] }, qr[3];
        CHECK(hg_kin_ik(&s.cfg.link, pr, qr) == 0);
        double q[3], qd[3];
        for (int i = 0; i < 3; i++) {
            q[i] = (double)qr[i];
            qd[i] = n ? (q[i] - qprev[i]) / dt : 0;
            qprev[i] = q[i];
        }
        fx_pose(&s, q, qd);
        hg_servo_step(&s);
        hg_kin_t k;
        double tau[3], f[3];
        hg_kin_eval(&s.cfg.link, qr, &k);
        for (int i = 0; i < 3; i++)
            tau[i] = fx_code_to_tau(&s.cfg.motor[i], hal_sim_torque((unsigned)i));
        solve3(k.J, tau, f);
        f[1] += push;
        for (int i = 0; i < 3; i++) {
            v[i] += f[i] / mass * dt;
            p[i] += v[i] * dt;
        }
        ymax = p[1] > ymax ? p[1] : ymax;
    }
    CHECK(s.err == HG_ERR_NONE);
    CHECK_NEAR(p[1], wall + push / 1000, 2e-5);       /* k * depth = push */
    CHECK(ymax < wall + 2 * push / 1000);             /* damped overshoot */
    CHECK(fabs(p[0]) < 1e-4 && fabs(p[2]) < 1e-4);    /* pushed straight back */
}

/* ---- safety ---- */

/* After a latch: zero torque, CTRL 0, no watchdog pet, error kept with good snapshots,
 * enable refused; clear_error pulses FAULT_CLR and re-enabling drives again. */
static void expect_latched(hg_servo_t *s, uint8_t err, uint8_t axis)
{
    CHECK(s->err == err && s->err_axis == axis && !s->enabled);
    CHECK(hal_sim_torque(0) == 0 && hal_sim_torque(1) == 0 && hal_sim_torque(2) == 0);
    CHECK(hal_sim_regs[HG_REG_CTRL] == 0);
    const uint32_t pets = hal_sim_nwrites[HG_REG_WDOG];
    hal_sim_regs[HG_REG_STATUS] = 0;
    for (int i = 0; i < 3; i++) {
        fx_pose(s, Q45, QD0);
        hg_servo_step(s);
    }
    CHECK(s->err == err && hal_sim_nwrites[HG_REG_WDOG] == pets && hal_sim_torque(1) == 0);
    CHECK(hg_servo_enable(s, true) != 0);
    const uint32_t clr = hal_sim_nwrites[HG_REG_CTRL];
    hg_servo_clear_error(s);
    CHECK(s->err == HG_ERR_NONE && hal_sim_nwrites[HG_REG_CTRL] == clr + 1);
    CHECK(hg_servo_enable(s, true) == 0);
    fx_pose(s, Q45, QD0);
    hg_servo_step(s);
    CHECK(s->err == HG_ERR_NONE && hal_sim_torque(1) > 2000);
    CHECK(hal_sim_nwrites[HG_REG_WDOG] == pets + 1);
}

/* An enabled servo pushing (0.0354 N m on B and Gamma) at the check pose. */
static void armed(hg_servo_t *s)
{
    setup(s);
    wall_y(s, 0.1f * sqrtf(0.5f) - 0.001f, 1000, 0);
    CHECK(hg_servo_enable(s, true) == 0);
    fx_pose(s, Q45, QD0);
    hg_servo_step(s);
    CHECK(hal_sim_torque(1) > 2000 && s->err == HG_ERR_NONE);
}

void test_safety_nonfinite(void)
{
    hg_servo_t s;
    armed(&s);
    s.cfg.grav.k[6 - 1] = INFINITY; /* a corrupted coefficient */
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    s.cfg.grav.k[6 - 1] = 0;
    expect_latched(&s, HG_ERR_NONFINITE, 0);
    /* a scene parameter corrupted behind hg_scene_check()'s back */
    armed(&s);
    s.scene.k = NAN;
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    s.scene.k = 1000;
    expect_latched(&s, HG_ERR_NONFINITE, 0);
}

void test_safety_fault_bit(void)
{
    hg_servo_t s;
    armed(&s);
    hal_sim_regs[HG_REG_STATUS] = HG_STAT_FAULT(2) | HG_STAT_INDEX(0);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_AXIS_FAULT, 2);
    armed(&s);
    hal_sim_regs[HG_REG_STATUS] = HG_STAT_WDOG;
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_WATCHDOG, 0);
}

void test_safety_fpga_fault(void)
{
    /* STATUS.HW_FAULT: latched as HG_ERR_FPGA_FAULT with HW_FAULT's cause bits in err_axis,
     * read in the same tick; the alarm wins over an axis fault reported with it */
    hg_servo_t s;
    armed(&s);
    const uint32_t reads = hal_sim_nreads[HG_REG_HW_FAULT];
    hal_sim_regs[HG_REG_STATUS] = HG_STAT_HW_FAULT | HG_STAT_FAULT(1);
    hal_sim_regs[HG_REG_HW_FAULT] = (0x1Fu << 8) | 0x12u;       /* built: all; COMM and POS */
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(hal_sim_nreads[HG_REG_HW_FAULT] == reads + 1);
    hal_sim_regs[HG_REG_HW_FAULT] = 0;
    expect_latched(&s, HG_ERR_FPGA_FAULT, 0x12);
    /* without the STATUS bit the register is not read and nothing latches */
    armed(&s);
    const uint32_t reads2 = hal_sim_nreads[HG_REG_HW_FAULT];
    hal_sim_regs[HG_REG_HW_FAULT] = 0x4u;
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    CHECK(s.err == HG_ERR_NONE && hal_sim_nreads[HG_REG_HW_FAULT] == reads2);
    hal_sim_regs[HG_REG_HW_FAULT] = 0;
}

void test_safety_encoder_jump(void)
{
    hg_servo_t s;
    armed(&s);
    /* 100 rad/s max at 1 kHz = 0.1 rad per tick: 0.09 passes, 0.11 latches */
    double q[3] = { Q45[0], Q45[1] + 0.09, Q45[2] };
    fx_pose(&s, q, QD0);
    hg_servo_step(&s);
    CHECK(s.err == HG_ERR_NONE);
    q[1] += 0.11;
    fx_pose(&s, q, QD0);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_ENCODER, 1);
    /* implausible velocity register */
    armed(&s);
    const double qd[3] = { 0, 0, 101.0 };
    fx_pose(&s, Q45, qd);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_ENCODER, 2);
    /* two missed ticks allow twice the step */
    armed(&s);
    hal_sim_regs[HG_REG_SEQ]++;
    double q2[3] = { Q45[0] + 0.19, Q45[1], Q45[2] };
    fx_pose(&s, q2, QD0);
    hg_servo_step(&s);
    CHECK(s.err == HG_ERR_NONE);
}

void test_safety_stale(void)
{
    hg_servo_t s;
    armed(&s);
    hg_servo_step(&s); /* no new snapshot since the last step */
    expect_latched(&s, HG_ERR_STALE, 0);
    armed(&s);
    hal_sim_tear = true; /* SEQ moves while the axes are being read */
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_STALE, 0);
    armed(&s);
    hal_sim_regs[HG_REG_SEQ] += 3; /* 3 ticks missed, max_missed = 2 */
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    expect_latched(&s, HG_ERR_OVERRUN, 0);
}

/* The first error wins; a second one does not overwrite the code. */
void test_safety_first_error_kept(void)
{
    hg_servo_t s;
    armed(&s);
    hal_sim_regs[HG_REG_STATUS] = HG_STAT_FAULT(1);
    fx_pose(&s, Q45, QD0);
    hg_servo_step(&s);
    hg_servo_step(&s); /* stale as well */
    CHECK(s.err == HG_ERR_AXIS_FAULT && s.err_axis == 1);
}
