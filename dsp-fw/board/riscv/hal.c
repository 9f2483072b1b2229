/* SPDX-License-Identifier: Apache-2.0 */
/* The firmware's HAL (include/hg_hal.h) on the SoC: the FPGA register file as 32-bit words in
 * an uncached I/O window, and the servo interrupt masked through mstatus.MIE. */
#include "hg_hal.h"
#include "soc.h"

static volatile uint32_t *const fpga = (volatile uint32_t *)SOC_REGS_BASE;

uint32_t fpga_read32(uint32_t addr)
{
    return fpga[addr];
}

void fpga_write32(uint32_t addr, uint32_t v)
{
    fpga[addr] = v;
}

/* csrrc returns mstatus before it clears MIE: the token is that MIE bit (nesting restores the
 * outer state) */
uint32_t hg_hal_irq_save(void)
{
    uint32_t m;
    __asm__ volatile(SOC_CSR_ASM("csrrc %0, mstatus, %1")
                     : "=r"(m) : "r"(SOC_MSTATUS_MIE) : "memory");
    return m & SOC_MSTATUS_MIE;
}

void hg_hal_irq_restore(uint32_t token)
{
    if (token & SOC_MSTATUS_MIE)
        __asm__ volatile(SOC_CSR_ASM("csrs mstatus, %0") : : "r"(SOC_MSTATUS_MIE) : "memory");
}
