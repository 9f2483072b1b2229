/* SPDX-License-Identifier: Apache-2.0 */
/* Capture buffer access (hg_capture.c) against the simulated CAP_* registers (hal_sim.c). The
 * expected register words are written out from the RDL's field layout (CAP_CTRL: ARM [0], SEL
 * [5:4], TRIG [6], TRIG_AXIS [9:8], DECIM [31:16]; CAP_STAT: DONE [0], ARMED [1], BUSY [2],
 * DEPTH_LOG2 [7:4], COUNT [31:16]), not from the code under test. */
#include "hal_sim.h"
#include "hg_capture.h"
#include "hg_test.h"

void test_capture_arm_poll(void)
{
    hal_sim_cap_log2 = 10;
    hal_sim_reset();
    CHECK(hg_cap_depth() == 1024);
    CHECK(hg_cap_limit(1) == 1024 && hg_cap_limit(HG_CAP_SEL_ALL) == 1023);
    uint32_t n = 99;
    CHECK(hg_cap_poll(&n) == HG_CAP_STOPPED && n == 0);          /* never armed */
    const hg_cap_cfg_t cfg = {.sel = 2, .index_trigger = true, .trig_axis = 1, .decim = 7};
    CHECK(hg_cap_arm(&cfg) == HG_CAP_OK);
    CHECK(hal_sim_nwrites[HG_REG_CAP_CTRL] == 1);
    CHECK(hal_sim_regs[HG_REG_CAP_CTRL] == 0x00070160u);           /* stored; ARM reads 0 */
    CHECK(hg_cap_poll(&n) == HG_CAP_PENDING && n == 0);          /* armed */
    hal_sim_regs[HG_REG_CAP_STAT] = 0x00640000u | 0xA0u | 0x4u;  /* recording, 100 entries */
    CHECK(hg_cap_poll(&n) == HG_CAP_PENDING && n == 100);
    hal_sim_regs[HG_REG_CAP_STAT] = 0x04000000u | 0xA0u | 0x1u;  /* done, 1024 entries */
    CHECK(hg_cap_poll(&n) == HG_CAP_OK && n == 1024);
    CHECK(hg_cap_poll(0) == HG_CAP_OK);
    /* all axes, at once, every sample; then a stop keeps the fields, clears ARMED */
    const hg_cap_cfg_t all = {.sel = HG_CAP_SEL_ALL, .index_trigger = false, .trig_axis = 0,
                              .decim = 65535};
    CHECK(hg_cap_arm(&all) == HG_CAP_OK);
    CHECK(hal_sim_regs[HG_REG_CAP_CTRL] == 0xFFFF0030u);
    CHECK(hg_cap_poll(&n) == HG_CAP_PENDING && n == 0);
    CHECK(hg_cap_stop() == HG_CAP_OK);
    CHECK(hal_sim_regs[HG_REG_CAP_CTRL] == 0xFFFF0030u);
    CHECK(hg_cap_poll(&n) == HG_CAP_STOPPED);
    /* refused: fields out of range, no configuration */
    const hg_cap_cfg_t bad_sel = {.sel = 4, .index_trigger = false, .trig_axis = 0, .decim = 0};
    const hg_cap_cfg_t bad_ax = {.sel = 0, .index_trigger = true, .trig_axis = 4, .decim = 0};
    const hg_cap_cfg_t bad_dec = {.sel = 0, .index_trigger = false, .trig_axis = 0,
                                  .decim = 65536};
    CHECK(hg_cap_arm(&bad_sel) == HG_CAP_ERR_ARG && hg_cap_arm(&bad_ax) == HG_CAP_ERR_ARG);
    CHECK(hg_cap_arm(&bad_dec) == HG_CAP_ERR_ARG && hg_cap_arm(0) == HG_CAP_ERR_ARG);
    CHECK(hal_sim_nwrites[HG_REG_CAP_CTRL] == 3);                 /* none of them written */
}

void test_capture_read(void)
{
    hal_sim_cap_log2 = 10;
    hal_sim_reset();
    for (uint32_t j = 0; j < 1024; j++)   /* entry j: A = 13 j, B = -7 j (mod 256) */
        hal_sim_cap[j] = (uint16_t)((((0u - 7u * j) & 0xFFu) << 8) | ((13u * j) & 0xFFu));
    int8_t a[12], b[12];
    CHECK(hg_cap_read(1018, a, b, 12) == HG_CAP_OK);              /* wraps after 1023 */
    for (uint32_t k = 0; k < 12; k++) {
        const uint32_t j = (1018u + k) % 1024u;
        CHECK(a[k] == (int8_t)(uint8_t)((13u * j) & 0xFFu));
        CHECK(b[k] == (int8_t)(uint8_t)((0u - 7u * j) & 0xFFu));
    }
    CHECK(a[0] == -78 && b[0] == 42);   /* by hand: 13 * 1018 = 178 - 256, -7 * 1018 = 42 (mod 256) */
    CHECK(hal_sim_nwrites[HG_REG_CAP_ADDR] == 1 && hal_sim_regs[HG_REG_CAP_ADDR] == 6);
    CHECK(hg_cap_read(1024, a, b, 1) == HG_CAP_ERR_ARG);
    CHECK(hg_cap_read(0, a, b, 1025) == HG_CAP_ERR_ARG);
    CHECK(hg_cap_read(0, 0, b, 1) == HG_CAP_ERR_ARG);
    /* an FPGA without the buffer: every call says so, nothing is written */
    hal_sim_cap_log2 = 0;
    hal_sim_reset();
    const hg_cap_cfg_t cfg = {.sel = 0, .index_trigger = false, .trig_axis = 0, .decim = 0};
    CHECK(hg_cap_depth() == 0 && hg_cap_limit(0) == 0);
    CHECK(hg_cap_arm(&cfg) == HG_CAP_ERR_NONE && hg_cap_stop() == HG_CAP_ERR_NONE);
    CHECK(hg_cap_poll(0) == HG_CAP_ERR_NONE && hg_cap_read(0, a, b, 1) == HG_CAP_ERR_NONE);
    CHECK(hal_sim_nwrites[HG_REG_CAP_CTRL] == 0 && hal_sim_nwrites[HG_REG_CAP_ADDR] == 0);
    hal_sim_cap_log2 = 10;
    hal_sim_reset();
}
