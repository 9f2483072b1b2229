/* SPDX-License-Identifier: Apache-2.0 */
/* The whole hardware abstraction the firmware core needs. One implementation per target:
 * tests/hal_sim.c (host unit tests, fuzz, bench), the co-simulation harness (calls into the
 * Verilated FPGA top), and the DSP board support (EMIF accesses, interrupt masking). */
#ifndef HG_HAL_H
#define HG_HAL_H

#include <stdint.h>

/* One 32-bit access to the FPGA register file. addr is a WORD address (hg_fpga_regs.h). */
uint32_t fpga_read32(uint32_t addr);
void fpga_write32(uint32_t addr, uint32_t v);

/* Mask the servo interrupt around code outside the ISR (the PC link) that touches state the
 * ISR also uses. save returns an opaque token that restore takes back (nesting allowed). */
uint32_t hg_hal_irq_save(void);
void hg_hal_irq_restore(uint32_t token);

#endif /* HG_HAL_H */
