/* SPDX-License-Identifier: Apache-2.0 */
/* Calibration (hg_calib.h): torque gating of an uncalibrated axis (servo API and PC link),
 * SET_CALIB / GET_CALIB, the calibration's effect on the encoder, OFFSET and MODE, and the
 * firmware's own commutation of an axis whose field turns against the count. */
#include <string.h>
#include "hal_sim.h"
#include "hg_frame.h"
#include "hg_test.h"

static hg_servo_t S;
static hg_link_t L;

static const double Q45[3] = { 0, DEG_D(45.0), DEG_D(45.0) };
static const double QD0[3] = { 0, 0, 0 };

static const hg_axis_calib_t CAL_OK = { HG_CAL_HOMED | HG_CAL_ALIGNED, 1, 0, 2, 0, 0 };

static void setup(const hg_servo_cfg_t *cfg)
{
    fx_servo(&S, cfg);
    hg_link_init(&L, &S);
}

/* Send one request of protocol version ver; the reply's type and reason/data into raw.
 * Returns the number of replies (0 or 1). */
static int request(uint8_t ver, uint8_t type, const uint8_t *data, size_t n,
                   uint8_t raw[HG_LINK_MAX_RAW], size_t *rn)
{
    static uint8_t seq;
    uint8_t f[HG_LINK_MAX_FRAME];
    const size_t m = hg_link_encode_v(ver, type, ++seq, data, n, f);
    int replies = 0;
    for (size_t i = 0; i < m; i++) {
        uint8_t tx[HG_LINK_MAX_FRAME];
        const size_t k = hg_link_rx_byte(&L, f[i], tx);
        if (k) {
            replies++;
            *rn = hg_cobs_decode(tx, k - 1, raw, HG_LINK_MAX_RAW);
        }
    }
    return replies;
}

/* The NAK reason of a request that must be refused (0 if it was not a NAK). */
static int nak(uint8_t ver, uint8_t type, const uint8_t *data, size_t n)
{
    uint8_t raw[HG_LINK_MAX_RAW];
    size_t rn = 0;
    if (request(ver, type, data, n, raw, &rn) != 1 || raw[1] != HG_MSG_NAK)
        return 0;
    CHECK(raw[3] == type);
    return raw[4];
}

static int acked(uint8_t ver, uint8_t type, const uint8_t *data, size_t n)
{
    uint8_t raw[HG_LINK_MAX_RAW];
    size_t rn = 0;
    return request(ver, type, data, n, raw, &rn) == 1 && raw[1] == (type | HG_MSG_REPLY);
}

static void calib_req(uint8_t *d, uint8_t axis, uint8_t flags, int dir, uint8_t swapped,
                      uint8_t pp, int32_t i2z, uint32_t off)
{
    d[0] = axis;
    d[1] = flags;
    d[2] = (uint8_t)(dir & 0xFF);
    d[3] = swapped;
    d[4] = pp;
    for (int i = 0; i < 4; i++)
        d[5 + i] = (uint8_t)((uint32_t)i2z >> (8 * i));
    d[9] = (uint8_t)off;
    d[10] = (uint8_t)(off >> 8);
}

static void wall_1mm(void)
{
    const hg_scene_t sc = { HG_SCENE_WALL, { 0, 0.1f * 0.70710678f - 0.001f, 0 }, { 0, -1, 0 },
                            1000, 0, 0 };
    CHECK(hg_servo_set_scene(&S, &sc) == 0);
}

/* One axis without a calibration: ENABLE and every force refused (API and link, NAK 4), zero
 * torque on every axis; SET_CALIB then makes the same device render the wall. */
void test_calib_gating(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.cal.axis[1].flags = HG_CAL_HOMED; /* homed, not aligned */
    cfg.cal.axis[1].pole_pairs = 0;       /* unknown: allowed while not aligned */
    setup(&cfg);
    CHECK(S.err == HG_ERR_NONE);
    CHECK(hg_servo_axis_calibrated(&S, 0) && !hg_servo_axis_calibrated(&S, 1));
    CHECK(!hg_servo_calibrated(&S));
    wall_1mm();
    const hg_real f[3] = { 1, 0, 0 };
    CHECK(hg_servo_enable(&S, true) == HG_SERVO_E_UNCAL && !S.enabled);
    CHECK(hg_servo_set_force(&S, f) == HG_SERVO_E_UNCAL && S.f_pc_age == S.cfg.pc_force_timeout);
    uint8_t on = 1, fr[HG_FORCE_LEN] = { 0 }, sf[HG_SET_FORCE_LEN] = { 0 };
    CHECK(nak(HG_PROTO_V1, HG_MSG_ENABLE, &on, 1) == HG_NAK_UNCALIBRATED);
    CHECK(nak(HG_PROTO_VERSION, HG_MSG_ENABLE, &on, 1) == HG_NAK_UNCALIBRATED);
    CHECK(nak(HG_PROTO_V1, HG_MSG_SET_FORCE, sf, sizeof sf) == HG_NAK_UNCALIBRATED);
    fr[12] = 10; /* TTL 10 ms, counter 1 */
    fr[14] = 1;
    CHECK(nak(HG_PROTO_VERSION, HG_MSG_FORCE, fr, sizeof fr) == HG_NAK_UNCALIBRATED);
    CHECK(!L.have_force && L.st.replayed == 0);  /* the refused FORCE consumed no counter */
    CHECK(!S.enabled && !L.armed);
    for (int k = 0; k < 3; k++) {
        fx_pose(&S, Q45, QD0);
        hg_servo_step(&S);
        CHECK(S.err == HG_ERR_NONE && S.f[1] < -0.9f); /* the scene is evaluated ...        */
        for (unsigned i = 0; i < 3; i++)                /* ... and nothing reaches a motor  */
            CHECK(hal_sim_torque(i) == 0 && S.code[i] == 0);
        CHECK(hal_sim_regs[HG_REG_CTRL] == 0);
    }
    /* disabling is always accepted */
    on = 0;
    CHECK(acked(HG_PROTO_V1, HG_MSG_ENABLE, &on, 1));
    /* calibrate axis 1 over the link: now the wall reaches motors 1 and 2 */
    uint8_t c[HG_CALIB_LEN];
    calib_req(c, 1, HG_CAL_HOMED | HG_CAL_ALIGNED, 1, 0, 2, 0, 0);
    CHECK(acked(HG_PROTO_VERSION, HG_MSG_SET_CALIB, c, sizeof c));
    CHECK(hg_servo_calibrated(&S));
    on = 1;
    CHECK(acked(HG_PROTO_VERSION, HG_MSG_ENABLE, &on, 1) && S.enabled);
    fx_pose(&S, Q45, QD0);
    hg_servo_step(&S);
    CHECK_NEAR(fx_code_to_tau(&S.cfg.motor[1], hal_sim_torque(1)), 0.05 * sqrt(0.5), 3e-5);
    CHECK(hal_sim_regs[HG_REG_CTRL] == 0xFu);
    CHECK(hg_servo_set_force(&S, f) == 0);
}

/* SET_CALIB / GET_CALIB: the round trip, the refusals, and what a calibration changes. */
void test_calib_set_get(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    setup(&cfg);
    uint8_t c[HG_CALIB_LEN], raw[HG_LINK_MAX_RAW];
    size_t rn = 0;
    /* every axis, every field, negative index_to_zero and direction */
    for (uint8_t ax = 0; ax < 3; ax++) {
        calib_req(c, ax, HG_CAL_HOMED | HG_CAL_ALIGNED | HG_CAL_DIR_SEEN, -1, ax == 1,
                  2, -123456 - ax, 1000u - ax);
        CHECK(acked(HG_PROTO_VERSION, HG_MSG_SET_CALIB, c, sizeof c));
        const uint8_t a = ax;
        CHECK(request(HG_PROTO_VERSION, HG_MSG_GET_CALIB, &a, 1, raw, &rn) == 1);
        CHECK(raw[1] == (HG_MSG_GET_CALIB | HG_MSG_REPLY) && rn - 5 == HG_CALIB_LEN);
        CHECK(memcmp(raw + 3, c, HG_CALIB_LEN) == 0);
        const hg_axis_calib_t *k = &S.cfg.cal.axis[ax];
        CHECK(k->enc_dir == -1 && k->phases_swapped == (ax == 1) && k->pole_pairs == 2);
        CHECK(k->index_to_zero == -123456 - ax && k->comm_offset == 1000u - ax);
        /* applied: the encoder direction and index_to_zero, OFFSET, MODE (the field turns
         * against the count unless both the encoder and the phases are reversed) */
        CHECK(S.cfg.enc[ax].dir == -1 && S.cfg.enc[ax].index_to_zero == -123456 - ax);
        CHECK(hal_sim_regs[HG_REG_AXIS(ax, HG_AX_OFFSET)] == 1000u - ax);
        CHECK(hal_sim_regs[HG_REG_AXIS(ax, HG_AX_MODE)]
              == (ax == 1 ? HG_MODE_SINE : HG_MODE_ALIGN));
    }
    /* out of range: axis, direction, swapped, unknown flag, offset, pole pairs when aligned */
    const struct { uint8_t ax, flags; int dir; uint8_t sw, pp; uint32_t off; } bad[] = {
        { 3, 3, 1, 0, 2, 0 }, { 0, 3, 0, 0, 2, 0 }, { 0, 3, 2, 0, 2, 0 }, { 0, 3, 1, 2, 2, 0 },
        { 0, 8 | 3, 1, 0, 2, 0 }, { 0, 3, 1, 0, 2, 1024 }, { 0, 3, 1, 0, 3, 0 },
        { 0, 2, 1, 0, 4, 0 },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        calib_req(c, bad[i].ax, bad[i].flags, bad[i].dir, bad[i].sw, bad[i].pp, 7, bad[i].off);
        CHECK(nak(HG_PROTO_VERSION, HG_MSG_SET_CALIB, c, sizeof c) == HG_NAK_RANGE);
    }
    CHECK(S.cfg.cal.axis[0].index_to_zero == -123456); /* nothing changed */
    const uint8_t a3 = 3;
    CHECK(nak(HG_PROTO_VERSION, HG_MSG_GET_CALIB, &a3, 1) == HG_NAK_RANGE);
    /* pole pairs unknown (0) is fine for an axis that is not aligned */
    calib_req(c, 2, HG_CAL_HOMED, 1, 0, 0, 5, 0);
    CHECK(acked(HG_PROTO_VERSION, HG_MSG_SET_CALIB, c, sizeof c) && !hg_servo_calibrated(&S));
    /* version 1 has neither message: dropped as an unknown type, no reply */
    const uint32_t bt = L.st.bad_type;
    CHECK(request(HG_PROTO_V1, HG_MSG_SET_CALIB, c, sizeof c, raw, &rn) == 0);
    CHECK(request(HG_PROTO_V1, HG_MSG_GET_CALIB, &a3, 1, raw, &rn) == 0);
    CHECK(L.st.bad_type == bt + 2);
    /* not while enabled (NAK 5); a calibration for every axis first */
    for (uint8_t ax = 0; ax < 3; ax++)
        CHECK(hg_servo_set_calib(&S, ax, &CAL_OK) == 0);
    CHECK(hg_servo_enable(&S, true) == 0);
    calib_req(c, 0, 3, -1, 0, 2, 0, 0);
    CHECK(nak(HG_PROTO_VERSION, HG_MSG_SET_CALIB, c, sizeof c) == HG_NAK_ENABLED);
    CHECK(S.cfg.cal.axis[0].enc_dir == 1);
    /* a homed axis is re-homed on IDX_POS with the new index_to_zero */
    CHECK(hg_servo_enable(&S, false) == 0);
    hal_sim_regs[HG_REG_AXIS(0, HG_AX_IDX_POS)] = 5000;
    S.status = HG_STAT_HOMED(0);
    hg_axis_calib_t k = CAL_OK;
    k.index_to_zero = -200;
    CHECK(hg_servo_set_calib(&S, 0, &k) == 0 && S.cfg.enc[0].offset == 4800);
    /* an invalid calibration in the configuration is a configuration error */
    hg_servo_default_cfg(&cfg);
    cfg.cal.axis[2].pole_pairs = 3;
    setup(&cfg);
    CHECK(S.err == HG_ERR_CONFIG);
    hg_servo_default_cfg(&cfg);
    cfg.cal.axis[0].enc_dir = 0;
    setup(&cfg);
    CHECK(S.err == HG_ERR_CONFIG);
}

/* Expected OFFSET of a firmware-commutated axis: the field at -pole_pairs x the position from
 * the home (counts, half a tick ahead), in 1/1024 electrical cycle, floored, plus the offset. */
static uint32_t field_code(double counts_from_home, double vel, double rate, uint32_t off)
{
    const double x = counts_from_home + vel / (2.0 * rate);
    const double codes = -2.0 * x * 1024.0 / 1048576.0;
    const long f = (long)floor(codes);
    return (uint32_t)(((long)off + f) % 1024 + 1024) % 1024;
}

/* An axis whose field turns against its count (reversed encoder, or swapped phases) is
 * commutated by the firmware: MODE = ALIGN, OFFSET written every tick at the field angle the
 * count implies; the other axes keep the FPGA's sine mode and a constant OFFSET. */
void test_calib_fw_commutation(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.cal.axis[0].enc_dir = -1;            /* reversed encoder          */
    cfg.cal.axis[0].comm_offset = 700;
    cfg.cal.axis[1].phases_swapped = 1;      /* swapped phases            */
    cfg.cal.axis[1].comm_offset = 100;
    cfg.cal.axis[2].enc_dir = -1;            /* both: the field follows the count */
    cfg.cal.axis[2].phases_swapped = 1;
    cfg.cal.axis[2].comm_offset = 333;
    setup(&cfg);
    CHECK(S.err == HG_ERR_NONE);
    CHECK(hal_sim_regs[HG_REG_AXIS(0, HG_AX_MODE)] == HG_MODE_ALIGN);
    CHECK(hal_sim_regs[HG_REG_AXIS(1, HG_AX_MODE)] == HG_MODE_ALIGN);
    CHECK(hal_sim_regs[HG_REG_AXIS(2, HG_AX_MODE)] == HG_MODE_SINE);
    CHECK(S.cfg.enc[0].dir == -1 && S.cfg.enc[2].dir == -1 && S.cfg.enc[1].dir == 1);
    /* home the encoders at IDX_POS = 1000 (index_to_zero 0: q = 0 at the index) */
    for (unsigned i = 0; i < 3; i++)
        hg_enc_home(&S.cfg.enc[i], 1000);
    /* (steps within the encoder plausibility limit of 16689 counts per tick) */
    const int32_t from_home[] = { 0, 1, 511, 512, 10000, 20000, 30001, 16000, 2000, -1, -9000 };
    const int32_t vels[] = { 0, 0, 0, 4000, 0, -8000, 123456, 0, -123456, 0, 777 };
    for (size_t k = 0; k < sizeof from_home / sizeof from_home[0]; k++) {
        const int32_t pos[3] = { 1000 + from_home[k], 1000 + from_home[k], 1000 + from_home[k] };
        const int32_t vel[3] = { vels[k], vels[k], vels[k] };
        hal_sim_snapshot(pos, vel);
        const uint32_t w2 = hal_sim_nwrites[HG_REG_AXIS(2, HG_AX_OFFSET)];
        hg_servo_step(&S);
        CHECK(S.err == HG_ERR_NONE);
        CHECK(hal_sim_regs[HG_REG_AXIS(0, HG_AX_OFFSET)]
              == field_code(from_home[k], vels[k], 1000.0, 700));
        CHECK(hal_sim_regs[HG_REG_AXIS(1, HG_AX_OFFSET)]
              == field_code(from_home[k], vels[k], 1000.0, 100));
        CHECK(hal_sim_regs[HG_REG_AXIS(2, HG_AX_OFFSET)] == 333
              && hal_sim_nwrites[HG_REG_AXIS(2, HG_AX_OFFSET)] == w2);
    }
    /* the encoder direction is the joint's: a reversed axis reads +q for falling counts */
    const double q[3] = { -0.01, 0.02, 0.03 };
    fx_pose(&S, q, QD0);
    hg_servo_step(&S);
    for (unsigned i = 0; i < 3; i++)
        CHECK_NEAR(S.q[i], q[i], 1e-5);
    CHECK(hal_sim_regs[HG_REG_AXIS(0, HG_AX_POS)] > 1000); /* q < 0: counts rose on axis 0 */
}
