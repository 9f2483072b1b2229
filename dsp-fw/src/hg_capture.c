/* SPDX-License-Identifier: Apache-2.0 */
/* Capture buffer access (hg_capture.h) over the register HAL. */
#include "hg_capture.h"

#include "hg_hal.h"

static uint32_t field(uint32_t v, uint32_t mask, uint32_t shift)
{
    return (v & mask) >> shift;
}

uint32_t hg_cap_depth(void)
{
    const uint32_t log2 = field(fpga_read32(HG_REG_CAP_STAT), HAPGATE__CAP_STAT__DEPTH_LOG2_bm,
                                HAPGATE__CAP_STAT__DEPTH_LOG2_bp);
    return log2 ? (1u << log2) : 0u;
}

uint32_t hg_cap_limit(uint32_t sel)
{
    const uint32_t depth = hg_cap_depth();
    return sel == HG_CAP_SEL_ALL ? depth / 3u * 3u : depth;
}

int hg_cap_arm(const hg_cap_cfg_t *cfg)
{
    if (cfg == 0 || cfg->sel > HG_CAP_SEL_ALL || cfg->trig_axis > HG_CAP_TRIG_ANY ||
        cfg->decim > (HAPGATE__CAP_CTRL__DECIM_bm >> HAPGATE__CAP_CTRL__DECIM_bp))
        return HG_CAP_ERR_ARG;
    if (hg_cap_depth() == 0)
        return HG_CAP_ERR_NONE;
    const uint32_t v = HAPGATE__CAP_CTRL__ARM_bm |
                       (cfg->sel << HAPGATE__CAP_CTRL__SEL_bp) |
                       ((cfg->index_trigger ? 1u : 0u) << HAPGATE__CAP_CTRL__TRIG_bp) |
                       (cfg->trig_axis << HAPGATE__CAP_CTRL__TRIG_AXIS_bp) |
                       (cfg->decim << HAPGATE__CAP_CTRL__DECIM_bp);
    fpga_write32(HG_REG_CAP_CTRL, v);
    return HG_CAP_OK;
}

int hg_cap_stop(void)
{
    if (hg_cap_depth() == 0)
        return HG_CAP_ERR_NONE;
    /* the fields as they are, ARM = 0 (it reads 0) */
    fpga_write32(HG_REG_CAP_CTRL, fpga_read32(HG_REG_CAP_CTRL) & ~(uint32_t)HAPGATE__CAP_CTRL__ARM_bm);
    return HG_CAP_OK;
}

int hg_cap_poll(uint32_t *count)
{
    const uint32_t s = fpga_read32(HG_REG_CAP_STAT);
    if (field(s, HAPGATE__CAP_STAT__DEPTH_LOG2_bm, HAPGATE__CAP_STAT__DEPTH_LOG2_bp) == 0)
        return HG_CAP_ERR_NONE;
    if (count)
        *count = field(s, HAPGATE__CAP_STAT__COUNT_bm, HAPGATE__CAP_STAT__COUNT_bp);
    if (s & HAPGATE__CAP_STAT__DONE_bm)
        return HG_CAP_OK;
    if (s & (HAPGATE__CAP_STAT__ARMED_bm | HAPGATE__CAP_STAT__BUSY_bm))
        return HG_CAP_PENDING;
    return HG_CAP_STOPPED;
}

int hg_cap_read(uint32_t start, int8_t *a, int8_t *b, uint32_t n)
{
    const uint32_t depth = hg_cap_depth();
    if (depth == 0)
        return HG_CAP_ERR_NONE;
    if (a == 0 || b == 0 || start >= depth || n > depth)
        return HG_CAP_ERR_ARG;
    fpga_write32(HG_REG_CAP_ADDR, start);
    for (uint32_t j = 0; j < n; j++) {
        const uint32_t v = fpga_read32(HG_REG_CAP_DATA);
        a[j] = (int8_t)(uint8_t)field(v, HAPGATE__CAP_DATA__A_bm, HAPGATE__CAP_DATA__A_bp);
        b[j] = (int8_t)(uint8_t)field(v, HAPGATE__CAP_DATA__B_bm, HAPGATE__CAP_DATA__B_bp);
    }
    return HG_CAP_OK;
}

int hg_cap_read_words(uint32_t start, uint16_t *w, uint32_t n)
{
    const uint32_t depth = hg_cap_depth();
    if (depth == 0)
        return HG_CAP_ERR_NONE;
    if (w == 0 || start >= depth || n > depth)
        return HG_CAP_ERR_ARG;
    fpga_write32(HG_REG_CAP_ADDR, start);
    for (uint32_t j = 0; j < n; j++)
        w[j] = (uint16_t)(fpga_read32(HG_REG_CAP_DATA) & 0xFFFFu);
    return HG_CAP_OK;
}
