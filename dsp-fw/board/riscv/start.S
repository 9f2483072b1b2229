/* SPDX-License-Identifier: Apache-2.0 */
/* Start-up and trap entry of the hapgate SoC (VexRiscv, RV32IM, machine mode only).
 * _start (the reset vector, 0): global and stack pointers, thread pointer (picolibc's errno is
 * thread-local), .data/.tdata copied from the image, .tbss/.bss zeroed, mtvec, the tick
 * interrupt unmasked and the float unit's port enabled (one CSR), main. trap_entry: saves the
 * caller-saved registers, calls soc_trap(mcause, mepc) in C, restores them and returns (mret).
 * The ABI lets a C function change only those; the callee-saved ones it restores itself. */
#include "soc.h"

    .section .text.start, "ax"
    .globl _start
_start:
    .option push
    .option norelax
    la      gp, __global_pointer$
    .option pop
    la      sp, __stack_top
    la      tp, __tls_base
    /* initial values of .data and .tdata */
    la      t0, __data_source
    la      t1, __data_start
    la      t2, __data_end
1:  bgeu    t1, t2, 2f
    lw      t3, 0(t0)
    sw      t3, 0(t1)
    addi    t0, t0, 4
    addi    t1, t1, 4
    j       1b
    /* .tbss and .bss */
2:  la      t1, __bss_start
    la      t2, __bss_end
3:  bgeu    t1, t2, 4f
    sw      zero, 0(t1)
    addi    t1, t1, 4
    j       3b
4:  .option push
    .option arch, +zicsr
    la      t0, trap_entry
    csrw    mtvec, t0                  /* direct mode: every trap to trap_entry */
    li      t0, SOC_CSR_CFU_EN | (1 << SOC_IRQ_LINE_TICK)
    csrw    SOC_CSR_IRQ_MASK, t0       /* VexRiscv: the float unit on, the tick line unmasked */
    li      t0, 1 << 11
    csrs    mie, t0                    /* MEIE: the machine external interrupt */
    csrsi   mstatus, 1 << 3            /* MIE: interrupts on (as a Cortex-M from reset) */
    .option pop
    call    main
5:  j       5b

    .section .text.trap, "ax"
    .globl trap_entry
    .balign 4
trap_entry:
    addi    sp, sp, -64
    sw      ra, 0(sp)
    sw      t0, 4(sp)
    sw      t1, 8(sp)
    sw      t2, 12(sp)
    sw      a0, 16(sp)
    sw      a1, 20(sp)
    sw      a2, 24(sp)
    sw      a3, 28(sp)
    sw      a4, 32(sp)
    sw      a5, 36(sp)
    sw      a6, 40(sp)
    sw      a7, 44(sp)
    sw      t3, 48(sp)
    sw      t4, 52(sp)
    sw      t5, 56(sp)
    sw      t6, 60(sp)
    .option push
    .option arch, +zicsr
    csrr    a0, mcause
    csrr    a1, mepc
    .option pop
    call    soc_trap
    lw      ra, 0(sp)
    lw      t0, 4(sp)
    lw      t1, 8(sp)
    lw      t2, 12(sp)
    lw      a0, 16(sp)
    lw      a1, 20(sp)
    lw      a2, 24(sp)
    lw      a3, 28(sp)
    lw      a4, 32(sp)
    lw      a5, 36(sp)
    lw      a6, 40(sp)
    lw      a7, 44(sp)
    lw      t3, 48(sp)
    lw      t4, 52(sp)
    lw      t5, 56(sp)
    lw      t6, 60(sp)
    addi    sp, sp, 64
    mret
