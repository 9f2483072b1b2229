/* SPDX-License-Identifier: Apache-2.0 */
/* Harmonic table loader (hg_harm.h) over the register HAL. */
#include "hg_harm.h"

#include "hg_fpga_regs.h"
#include "hg_hal.h"

uint32_t hg_harm_size(void)
{
    const uint32_t log2 = HG_HARM_LOG2_OF(fpga_read32(HG_REG_HARM_CTRL));
    return log2 ? (1u << log2) : 0u;
}

int hg_harm_enable(uint32_t axis, bool on)
{
    if (axis >= HG_NAXES)
        return HG_HARM_ERR_AXIS;
    if (hg_harm_size() == 0)
        return HG_HARM_ERR_NO_STAGE;
    const uint32_t en = fpga_read32(HG_REG_HARM_CTRL) & HG_HARM_EN_ALL;
    fpga_write32(HG_REG_HARM_CTRL, on ? (en | HG_HARM_EN(axis)) : (en & ~HG_HARM_EN(axis)));
    return HG_HARM_OK;
}

int hg_harm_load(uint32_t axis, const int8_t *table, uint32_t n)
{
    if (axis >= HG_NAXES)
        return HG_HARM_ERR_AXIS;
    const uint32_t size = hg_harm_size();
    if (size == 0)
        return HG_HARM_ERR_NO_STAGE;
    if (table == 0 || n != size)
        return HG_HARM_ERR_SIZE;
    (void)hg_harm_enable(axis, false); /* a write applies to the samples after it */
    fpga_write32(HG_REG_HARM_ADDR, HG_HARM_ADDR(axis, 0));
    for (uint32_t j = 0; j < n; j++)
        fpga_write32(HG_REG_HARM_DATA, (uint32_t)(uint8_t)table[j]);
    fpga_write32(HG_REG_HARM_ADDR, HG_HARM_ADDR(axis, 0));
    int bad = 0;
    for (uint32_t j = 0; j < n; j++)
        bad |= (fpga_read32(HG_REG_HARM_DATA) & HG_HARM_DATA_MASK) != (uint32_t)(uint8_t)table[j];
    return bad ? HG_HARM_ERR_VERIFY : HG_HARM_OK;
}
