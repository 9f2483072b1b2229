/* SPDX-License-Identifier: Apache-2.0 */
/* Host HAL: the FPGA register file as memory, with just enough behaviour for the tests
 * (SEQ/snapshot updates, FAULT_CLR, a torn-snapshot injector, the HARM_* table access, the CAP_* capture buffer) and access bookkeeping. */
#ifndef HAL_SIM_H
#define HAL_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "hg_fpga_regs.h"

#define HAL_SIM_NREGS HG_NREGS

extern uint32_t hal_sim_regs[HAL_SIM_NREGS];
extern uint32_t hal_sim_nwrites[HAL_SIM_NREGS]; /* writes per address since reset */
extern uint32_t hal_sim_nreads[HAL_SIM_NREGS];  /* reads per address since reset  */
extern uint32_t hal_sim_bad_access;             /* accesses outside the map        */
extern int hal_sim_irq_depth;                   /* > 0 while masked                */
extern uint32_t hal_sim_irq_saves;
extern bool hal_sim_tear;                       /* bump SEQ on the next POS read   */
extern uint8_t hal_sim_harm[HG_NAXES][256];     /* harmonic tables (not reset)     */
extern unsigned hal_sim_harm_log2;              /* HARM_CTRL.LOG2 at reset (0: none) */
extern int hal_sim_harm_flip;                   /* read-back of this entry flips bit 0 */
extern uint16_t hal_sim_cap[1u << 15];          /* capture buffer entries {B, A} (not reset) */
extern unsigned hal_sim_cap_log2;               /* CAP_STAT.DEPTH_LOG2 at reset (0: none) */

void hal_sim_reset(void);
/* Latch a new snapshot: SEQ += 1, positions and velocities. */
void hal_sim_snapshot(const int32_t pos[3], const int32_t vel[3]);
int16_t hal_sim_torque(unsigned axis);

#endif /* HAL_SIM_H */
