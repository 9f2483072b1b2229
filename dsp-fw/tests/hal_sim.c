/* SPDX-License-Identifier: Apache-2.0 */
/* Host HAL implementation over a simulated register file. */
#include "hal_sim.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"

uint32_t hal_sim_regs[HAL_SIM_NREGS];
uint32_t hal_sim_nwrites[HAL_SIM_NREGS];
uint32_t hal_sim_bad_access;
int hal_sim_irq_depth;
uint32_t hal_sim_irq_saves;
bool hal_sim_tear;

void hal_sim_reset(void)
{
    for (unsigned i = 0; i < HAL_SIM_NREGS; i++)
        hal_sim_regs[i] = hal_sim_nwrites[i] = 0;
    hal_sim_regs[HG_REG_ID] = HG_ID_MAGIC << HG_ID_MAGIC_SHIFT | 0x0001u;
    hal_sim_bad_access = 0;
    hal_sim_irq_depth = 0;
    hal_sim_irq_saves = 0;
    hal_sim_tear = false;
}

uint32_t fpga_read32(uint32_t addr)
{
    if (addr >= HAL_SIM_NREGS) {
        hal_sim_bad_access++;
        return 0xDEADBEEFu;
    }
    if (hal_sim_tear && addr == HG_REG_AXIS(0, HG_AX_POS)) {
        hal_sim_tear = false;
        hal_sim_regs[HG_REG_SEQ]++;
    }
    return hal_sim_regs[addr];
}

void fpga_write32(uint32_t addr, uint32_t v)
{
    if (addr >= HAL_SIM_NREGS) {
        hal_sim_bad_access++;
        return;
    }
    hal_sim_nwrites[addr]++;
    if (addr == HG_REG_CTRL && (v & HG_CTRL_FAULT_CLR)) {
        hal_sim_regs[HG_REG_STATUS] &= ~(HG_STAT_FAULT_ALL | HG_STAT_WDOG);
        v &= ~HG_CTRL_FAULT_CLR; /* a pulse, not a state */
    }
    hal_sim_regs[addr] = v;
}

uint32_t hg_hal_irq_save(void)
{
    hal_sim_irq_saves++;
    return (uint32_t)hal_sim_irq_depth++;
}

void hg_hal_irq_restore(uint32_t token)
{
    hal_sim_irq_depth = (int)token;
}

void hal_sim_snapshot(const int32_t pos[3], const int32_t vel[3])
{
    hal_sim_regs[HG_REG_SEQ]++;
    for (uint32_t i = 0; i < HG_NAXES; i++) {
        hal_sim_regs[HG_REG_AXIS(i, HG_AX_POS)] = (uint32_t)pos[i];
        hal_sim_regs[HG_REG_AXIS(i, HG_AX_VEL)] = (uint32_t)vel[i];
    }
}

int16_t hal_sim_torque(unsigned axis)
{
    return (int16_t)(uint16_t)hal_sim_regs[HG_REG_AXIS(axis, HG_AX_TORQUE)];
}
