/* SPDX-License-Identifier: Apache-2.0 */
/* Host HAL implementation over a simulated register file. */
#include "hal_sim.h"
#include "hg_capture.h"
#include "hg_fpga_regs.h"
#include "hg_hal.h"

uint32_t hal_sim_regs[HAL_SIM_NREGS];
uint32_t hal_sim_nwrites[HAL_SIM_NREGS];
uint32_t hal_sim_nreads[HAL_SIM_NREGS];
uint32_t hal_sim_bad_access;
uint8_t hal_sim_harm[HG_NAXES][256];
unsigned hal_sim_harm_log2 = 6;
int hal_sim_harm_flip = -1;
uint16_t hal_sim_cap[1u << 15];
unsigned hal_sim_cap_log2 = 10;
int hal_sim_irq_depth;
uint32_t hal_sim_irq_saves;
bool hal_sim_tear;

void hal_sim_reset(void)
{
    for (unsigned i = 0; i < HAL_SIM_NREGS; i++)
        hal_sim_regs[i] = hal_sim_nwrites[i] = hal_sim_nreads[i] = 0;
    hal_sim_regs[HG_REG_ID] = HG_ID_MAGIC << HG_ID_MAGIC_SHIFT | HG_ID_VERSION;
    hal_sim_regs[HG_REG_HARM_CTRL] = (uint32_t)hal_sim_harm_log2 << HAPGATE__HARM_CTRL__LOG2_bp;
    hal_sim_regs[HG_REG_CAP_STAT] = (uint32_t)hal_sim_cap_log2 << HAPGATE__CAP_STAT__DEPTH_LOG2_bp;
    hal_sim_harm_flip = -1;
    hal_sim_bad_access = 0;
    hal_sim_irq_depth = 0;
    hal_sim_irq_saves = 0;
    hal_sim_tear = false;
}

/* HARM_ADDR / HARM_DATA as hg_regfile.v has them: an access to HARM_DATA reads or writes entry
 * ADDR mod 2^LOG2 of axis AXIS (3: none), then ADDR += 1 (mod 256); HARM_CTRL.LOG2 is read-only;
 * LOG2 = 0 (no harmonic stage): the three registers read 0 and ignore writes. */
static uint32_t harm_access(bool we, uint32_t v)
{
    const uint32_t a = hal_sim_regs[HG_REG_HARM_ADDR];
    const uint32_t axis = (a & HAPGATE__HARM_ADDR__AXIS_bm) >> HAPGATE__HARM_ADDR__AXIS_bp;
    const uint32_t entry = (a & HAPGATE__HARM_ADDR__ADDR_bm) & ((1u << hal_sim_harm_log2) - 1u);
    uint32_t r = 0;
    if (axis < HG_NAXES) {
        if (we)
            hal_sim_harm[axis][entry] = (uint8_t)(v & HG_HARM_DATA_MASK);
        r = hal_sim_harm[axis][entry];
        if (!we && (int)entry == hal_sim_harm_flip)
            r ^= 1u;
    }
    hal_sim_regs[HG_REG_HARM_ADDR] = (a & ~(uint32_t)HAPGATE__HARM_ADDR__ADDR_bm) |
                                     ((a + 1u) & HAPGATE__HARM_ADDR__ADDR_bm);
    return we ? 0 : r;
}

/* CAP_* as hg_capture.v has them, without the recording (a test sets CAP_STAT and the
 * entries): a CAP_CTRL write stores the fields (ARM reads 0) and arms (CAP_STAT: ARMED, COUNT
 * and DONE cleared) or stops (ARMED and BUSY cleared); CAP_ADDR is taken modulo the depth; a
 * CAP_DATA read returns entry CAP_ADDR, then CAP_ADDR += 1 (wrapping); CAP_STAT and CAP_DATA are
 * read-only. DEPTH_LOG2 = 0 (no buffer): the four read 0 and ignore writes. */
static bool cap_reg(uint32_t addr)
{
    return addr >= HG_REG_CAP_CTRL && addr <= HG_REG_CAP_DATA;
}

static uint32_t cap_mask(void)
{
    return (1u << hal_sim_cap_log2) - 1u;
}

static bool harm_reg(uint32_t addr)
{
    return addr == HG_REG_HARM_CTRL || addr == HG_REG_HARM_ADDR || addr == HG_REG_HARM_DATA;
}

uint32_t fpga_read32(uint32_t addr)
{
    if (addr >= HAL_SIM_NREGS) {
        hal_sim_bad_access++;
        return 0xDEADBEEFu;
    }
    hal_sim_nreads[addr]++;
    if (harm_reg(addr) && hal_sim_harm_log2 == 0)
        return 0;
    if (addr == HG_REG_HARM_DATA)
        return harm_access(false, 0);
    if (cap_reg(addr) && hal_sim_cap_log2 == 0)
        return 0;
    if (addr == HG_REG_CAP_DATA) {
        const uint32_t e = hal_sim_regs[HG_REG_CAP_ADDR];
        hal_sim_regs[HG_REG_CAP_ADDR] = (e + 1u) & cap_mask();
        return hal_sim_cap[e];
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
    if (harm_reg(addr)) {
        if (hal_sim_harm_log2 == 0)
            return;
        if (addr == HG_REG_HARM_DATA) {
            (void)harm_access(true, v);
            return;
        }
        if (addr == HG_REG_HARM_CTRL)
            v = (v & HG_HARM_EN_ALL) | (hal_sim_regs[addr] & HAPGATE__HARM_CTRL__LOG2_bm);
        else
            v &= HAPGATE__HARM_ADDR__ADDR_bm | HAPGATE__HARM_ADDR__AXIS_bm;
    }
    if (cap_reg(addr)) {
        const uint32_t keep = (uint32_t)HAPGATE__CAP_STAT__DEPTH_LOG2_bm;
        uint32_t *stat = &hal_sim_regs[HG_REG_CAP_STAT];
        if (hal_sim_cap_log2 == 0 || addr == HG_REG_CAP_STAT || addr == HG_REG_CAP_DATA)
            return;
        if (addr == HG_REG_CAP_ADDR) {
            v &= cap_mask();
        } else if (v & HAPGATE__CAP_CTRL__ARM_bm) {
            *stat = (*stat & keep) | HAPGATE__CAP_STAT__ARMED_bm;
            v &= ~(uint32_t)HAPGATE__CAP_CTRL__ARM_bm;
        } else {
            *stat &= ~(uint32_t)(HAPGATE__CAP_STAT__ARMED_bm | HAPGATE__CAP_STAT__BUSY_bm);
        }
    }
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
