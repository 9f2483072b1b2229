/* SPDX-License-Identifier: Apache-2.0 */
/* Harmonic table loader (hg_harm.c) against the simulated HARM_* registers (hal_sim.c). */
#include "hal_sim.h"
#include "hg_fpga_regs.h"
#include "hg_harm.h"
#include "hg_test.h"

void test_harm_load(void)
{
    int8_t t[64];
    for (int j = 0; j < 64; j++)
        t[j] = (int8_t)(j * 37 - 1000 / (j + 1));  /* negative and positive entries */
    hal_sim_harm_log2 = 6;
    hal_sim_reset();
    for (uint32_t i = 0; i < HG_NAXES; i++)
        for (int j = 0; j < 256; j++)
            hal_sim_harm[i][j] = 0xA5;
    CHECK(hg_harm_size() == 64);
    CHECK(hg_harm_enable(0, true) == HG_HARM_OK && hg_harm_enable(2, true) == HG_HARM_OK);
    CHECK((hal_sim_regs[HG_REG_HARM_CTRL] & HG_HARM_EN_ALL) == 5);
    CHECK(hg_harm_load(2, t, 64) == HG_HARM_OK);
    for (int j = 0; j < 64; j++) {
        CHECK(hal_sim_harm[2][j] == (uint8_t)t[j]);
        CHECK(hal_sim_harm[0][j] == 0xA5 && hal_sim_harm[1][j] == 0xA5);  /* other axes kept */
    }
    /* the load switched axis 2 off and left axis 0 on; LOG2 unchanged */
    CHECK((hal_sim_regs[HG_REG_HARM_CTRL] & HG_HARM_EN_ALL) == 1);
    CHECK(HG_HARM_LOG2_OF(hal_sim_regs[HG_REG_HARM_CTRL]) == 6);
    /* one address write and 64 data writes, twice the address (verify), 64 reads */
    CHECK(hal_sim_nwrites[HG_REG_HARM_ADDR] == 2 && hal_sim_nwrites[HG_REG_HARM_DATA] == 64);
    CHECK(hg_harm_enable(2, true) == HG_HARM_OK);
    CHECK((hal_sim_regs[HG_REG_HARM_CTRL] & HG_HARM_EN_ALL) == 5);

    hal_sim_harm_flip = 17;                           /* a read-back that differs */
    CHECK(hg_harm_load(1, t, 64) == HG_HARM_ERR_VERIFY);
    CHECK(hg_harm_load(1, t, 63) == HG_HARM_ERR_SIZE);
    CHECK(hg_harm_load(1, 0, 64) == HG_HARM_ERR_SIZE);
    CHECK(hg_harm_load(3, t, 64) == HG_HARM_ERR_AXIS && hg_harm_enable(3, true) == HG_HARM_ERR_AXIS);

    hal_sim_harm_log2 = 0;                            /* an FPGA without the stage */
    hal_sim_reset();
    CHECK(hg_harm_size() == 0);
    CHECK(hg_harm_load(0, t, 64) == HG_HARM_ERR_NO_STAGE);
    CHECK(hg_harm_enable(0, true) == HG_HARM_ERR_NO_STAGE);
    hal_sim_harm_log2 = 6;
    hal_sim_reset();
}

/* Init refuses an FPGA whose register map has another major version; a newer minor is fine. */
void test_servo_fpga_version(void)
{
    hg_servo_t s;
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    hal_sim_reset();
    hal_sim_regs[HG_REG_ID] = HG_ID_MAGIC << HG_ID_MAGIC_SHIFT | (HG_ID_VERSION + 0x0100u);
    CHECK(hg_servo_init(&s, &cfg) == HG_ERR_FPGA_ID);
    hal_sim_reset();
    hal_sim_regs[HG_REG_ID] = HG_ID_MAGIC << HG_ID_MAGIC_SHIFT | (HG_ID_VERSION - 0x0100u);
    CHECK(hg_servo_init(&s, &cfg) == HG_ERR_FPGA_ID);
    hal_sim_reset();
    hal_sim_regs[HG_REG_ID] = HG_ID_MAGIC << HG_ID_MAGIC_SHIFT | (HG_ID_VERSION + 1u);
    CHECK(hg_servo_init(&s, &cfg) == HG_ERR_NONE);
    hal_sim_reset();
    CHECK(hg_servo_init(&s, &cfg) == HG_ERR_NONE && s.fpga_id >> 16 == HG_ID_MAGIC);
    CHECK(HG_ID_VERSION_OF(s.fpga_id) == HG_ID_VERSION);
}
