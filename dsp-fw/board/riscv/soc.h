/* SPDX-License-Identifier: Apache-2.0 */
/* The memory map of the hapgate SoC (rtl/soc/README.md, the one description; rtl/soc/hg_soc.v
 * decodes it) and the few machine CSRs the board code touches. Everything at or above
 * 0x80000000 is I/O: VexRiscv's data cache passes those accesses through uncached. */
#ifndef HG_SOC_H
#define HG_SOC_H

#define SOC_RAM_BASE   0x00000000u /* code, data and stack (block RAM, from the image) */
#define SOC_UART_BASE  0x80000000u /* +0 data, +4 status, +8 baud (rtl/soc/hg_uart.v) */
#define SOC_TIMER_BASE 0x80001000u /* +0/+4 mtime lo/hi, +8/+C mtimecmp lo/hi */
#define SOC_REGS_BASE  0x80010000u /* the FPGA register file: word w at +4*w */
/* VexRiscv's external interrupt controller: 32 lines (externalInterruptArray), a mask CSR and
 * a pending CSR; the machine external interrupt (mip.MEIP) is any line pending and unmasked. */

#define SOC_UART_DATA   0u /* read: the oldest received byte (pops it); write: send a byte */
#define SOC_UART_STATUS 1u
#define SOC_UART_BAUD   2u /* read-only: the baud rate the UART was built for */
#define SOC_UART_RX_AVAIL (1u << 0)
#define SOC_UART_TX_READY (1u << 1)
#define SOC_UART_RX_OVERRUN (1u << 2) /* sticky: a byte was lost to a full FIFO */

#define SOC_CSR_IRQ_MASK 0xBC0 /* VexRiscv's external interrupt mask (one bit per line) */
/* ... whose bit 31 is also the enable of the custom-function port (VexRiscv_FullCfu's
 * CfuPlugin): without it a CUSTOM_0 instruction (the float unit, fpu.c) is illegal. Line 31
 * carries no interrupt (rtl/soc/hg_soc.v ties it low). */
#define SOC_CSR_CFU_EN   0x80000000
#define SOC_CSR_IRQ_PEND 0xFC0 /* ... and its pending lines (read-only) */
#define SOC_IRQ_LINE_TICK 0    /* the FPGA's servo tick (hg_regfile's irq) on line 0 */

#ifndef __ASSEMBLER__
#include <stdint.h>

/* CSR access. The Debian GCC 12 toolchain is used with -march=rv32im (a _zicsr suffix would
 * select the wrong libgcc multilib), and its assembler (ISA spec 20191213) then wants Zicsr
 * named for the CSR instructions: each one enables it locally. */
#define SOC_CSR_ASM(insn) ".option push\n\t.option arch, +zicsr\n\t" insn "\n\t.option pop"
static inline uint32_t soc_mcycle(void)   /* the low word of the cycle counter */
{
    uint32_t v;
    __asm__ volatile(SOC_CSR_ASM("csrr %0, mcycle") : "=r"(v) : : "memory");
    return v;
}

#define SOC_MSTATUS_MIE (1u << 3)
#define SOC_MIE_MEIE    (1u << 11)

/* cycles of the last and of the longest tick handler (mcycle around hg_bringup_isr), and the
 * number of handled ticks; read by the simulation (tb/soc) from the RAM through the symbols */
extern volatile uint32_t soc_isr_cycles_last;
extern volatile uint32_t soc_isr_cycles_max;
extern volatile uint32_t soc_isr_count;
/* the last unexpected trap (mcause, mepc, mtval); the core then stops in a loop */
extern volatile uint32_t soc_trap_cause, soc_trap_pc, soc_trap_value;

/* The servo's state after each tick handler, for observation (a debugger, or the simulation's
 * records: hapgate.device.soc reads it from the RAM at the symbol's address): what the
 * virtual device's native firmware records per tick (tb/native/device/harness_common.h
 * TickRec), all 32-bit words; count (the handled ticks) is written last. */
typedef struct {
    uint32_t count;
    float q[3], p[3], f[3], tau[3];  /* the servo's joint angles, endpoint, force, torques */
    int32_t pos[3];                  /* its snapshot's positions, counts                   */
    uint32_t status;                 /* its STATUS word                                    */
    uint32_t err;                    /* err | err_axis << 8 | enabled << 16                */
    uint32_t bringup;                /* a bring-up step runs | its step << 8               */
} soc_tick_obs_t;
extern volatile soc_tick_obs_t soc_tick_obs;

void soc_trap(uint32_t mcause, uint32_t mepc);
#endif /* __ASSEMBLER__ */

#endif /* HG_SOC_H */
