/* SPDX-License-Identifier: Apache-2.0 */
/* The trap dispatch (start.S's trap_entry calls it with interrupts off): the machine external
 * interrupt is the FPGA's servo tick, handled by the firmware's tick entry hg_bringup_isr()
 * (the bring-up step while one runs, else the servo step; either acknowledges the tick in the
 * FPGA's IRQ register). Its cost in CPU cycles is kept for the budget. Anything else (an
 * exception: a bus error, an illegal instruction; an interrupt this board never enables) is a
 * fault: it is recorded and the core stops here with interrupts off, so the watchdog is no
 * longer petted and the FPGA zeroes the torque (rtl/top/README.md). */
#include "hg_bringup.h"
#include "hg_servo.h"
#include "soc.h"

#define MCAUSE_IRQ      0x80000000u
#define MCAUSE_EXTERNAL (MCAUSE_IRQ | 11u)

volatile uint32_t soc_isr_cycles_last;
volatile uint32_t soc_isr_cycles_max;
volatile uint32_t soc_isr_count;
volatile uint32_t soc_trap_cause, soc_trap_pc, soc_trap_value;
volatile soc_tick_obs_t soc_tick_obs;

/* the servo's state after the handler (soc.h; outside the measured cycles) */
static void observe(void)
{
    const hg_servo_t *s = hg_servo_isr_ctx;
    if (!s)
        return;
    for (unsigned i = 0; i < 3u; i++) {
        soc_tick_obs.q[i] = s->q[i];
        soc_tick_obs.p[i] = s->p[i];
        soc_tick_obs.f[i] = s->f[i];
        soc_tick_obs.tau[i] = s->tau[i];
        soc_tick_obs.pos[i] = s->pos[i];
    }
    soc_tick_obs.status = s->status;
    soc_tick_obs.err = (uint32_t)s->err | (uint32_t)s->err_axis << 8 | (uint32_t)s->enabled << 16;
    const hg_bringup_t *b = hg_bringup_isr_ctx;
    soc_tick_obs.bringup = b && hg_bringup_active(b) ? 1u | (uint32_t)b->step << 8 : 0u;
    soc_tick_obs.count = soc_tick_obs.count + 1u;
}

void soc_trap(uint32_t mcause, uint32_t mepc)
{
    if (mcause == MCAUSE_EXTERNAL) {
        const uint32_t t0 = soc_mcycle();
        hg_bringup_isr();
        const uint32_t dt = soc_mcycle() - t0;
        soc_isr_cycles_last = dt;
        if (dt > soc_isr_cycles_max)
            soc_isr_cycles_max = dt;
        soc_isr_count = soc_isr_count + 1u;
        observe();
        return;
    }
    uint32_t mtval;
    __asm__ volatile(SOC_CSR_ASM("csrr %0, mtval") : "=r"(mtval));
    soc_trap_cause = mcause;
    soc_trap_pc = mepc;
    soc_trap_value = mtval;
    for (;;)
        ;
}
