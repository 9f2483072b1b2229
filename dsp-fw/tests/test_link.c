/* SPDX-License-Identifier: Apache-2.0 */
/* PC link: every message, every way a frame can be bad, resynchronisation. */
#include <string.h>
#include "hal_sim.h"
#include "hg_frame.h"
#include "hg_test.h"

static hg_servo_t S;
static hg_link_t L;

static void setup(void)
{
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    fx_servo(&S, &cfg);
    hg_link_init(&L, &S);
}

/* Feed bytes; return the number of replies, the last one decoded into raw/n. */
static int feed(const uint8_t *b, size_t n, uint8_t raw[HG_LINK_MAX_RAW], size_t *rn)
{
    int replies = 0;
    for (size_t i = 0; i < n; i++) {
        uint8_t tx[HG_LINK_MAX_FRAME];
        const size_t m = hg_link_rx_byte(&L, b[i], tx);
        if (m) {
            replies++;
            CHECK(tx[m - 1] == 0 && memchr(tx, 0, m - 1) == NULL);
            *rn = hg_cobs_decode(tx, m - 1, raw, HG_LINK_MAX_RAW);
            CHECK(*rn >= 5 && *rn != HG_COBS_ERR);
            CHECK(hg_crc16(raw, *rn - 2) == (uint16_t)(raw[*rn - 2] << 8 | raw[*rn - 1]));
        }
    }
    return replies;
}

/* Send one request; expect exactly one reply of type `want`; return its data length. */
static size_t request(uint8_t type, const uint8_t *data, size_t n, uint8_t want,
                      uint8_t raw[HG_LINK_MAX_RAW])
{
    static uint8_t seq;
    uint8_t f[HG_LINK_MAX_FRAME];
    size_t rn = 0;
    const size_t m = hg_link_encode(type, ++seq, data, n, f);
    CHECK(m > 0);
    CHECK(feed(f, m, raw, &rn) == 1);
    CHECK(raw[0] == HG_PROTO_V1 && raw[1] == want && raw[2] == seq);
    return rn - 5;
}

static float f32_at(const uint8_t *d)
{
    union { uint32_t u; float f; } b;
    b.u = (uint32_t)d[0] | (uint32_t)d[1] << 8 | (uint32_t)d[2] << 16 | (uint32_t)d[3] << 24;
    return b.f;
}

static void put_f32(uint8_t *d, float x)
{
    union { uint32_t u; float f; } b;
    b.f = x;
    for (int i = 0; i < 4; i++)
        d[i] = (uint8_t)(b.u >> (8 * i));
}

void test_link_ping_state(void)
{
    uint8_t raw[HG_LINK_MAX_RAW];
    setup();
    CHECK(request(HG_MSG_PING, NULL, 0, 0x81, raw) == HG_PING_LEN);
    CHECK(raw[3] == 0x00 && raw[4] == 0x01);                     /* fw 1.0 */
    CHECK(raw[5] == (HG_ID_VERSION & 0xFF) && raw[6] == HG_ID_VERSION >> 8 &&
          raw[7] == 0x47 && raw[8] == 0x48);                     /* FPGA ID, little-endian */
    CHECK(raw[9] == (1000 & 0xFF) && raw[10] == 1000 >> 8);      /* rate */
    const double q[3] = { 0, DEG_D(45.0), DEG_D(45.0) }, qd[3] = { 0, 1.0, 1.0 };
    fx_pose(&S, q, qd);
    hg_servo_step(&S);
    CHECK(request(HG_MSG_GET_STATE, NULL, 0, 0x82, raw) == HG_STATE_LEN);
    const uint8_t *d = raw + 3;
    CHECK(d[0] == 1 && d[1] == 0 && d[2] == 0 && d[3] == 0);     /* SEQ */
    CHECK_NEAR(f32_at(d + 8), 0.0707107, 1e-6);                   /* y */
    CHECK_NEAR(f32_at(d + 16 + 8), 0.0, 1e-6);                    /* vz */
    CHECK_NEAR(f32_at(d + 16 + 4), -2 * 0.05 * sqrt(0.5), 1e-5);  /* vy = -2 L sin45 qd */
    CHECK_NEAR(f32_at(d + 28 + 4), DEG_D(45.0), 1e-5);            /* beta */
    CHECK(d[52] == 0 && d[53] == 0 && d[55] == HG_SCENE_NONE);
}

void test_link_commands(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], req[37] = { 0 };
    setup();
    /* SET_SCENE: wall at y = 0.07, normal -y, 2000 N/m */
    req[0] = HG_SCENE_WALL;
    put_f32(req + 1 + 4, 0.07f);
    put_f32(req + 13 + 4, -1.0f);
    put_f32(req + 25, 2000.0f);
    CHECK(request(HG_MSG_SET_SCENE, req, 37, 0x84, raw) == 0);
    CHECK(S.scene.type == HG_SCENE_WALL && S.scene.k == 2000.0f && S.scene.n[1] == -1.0f);
    /* ENABLE */
    uint8_t on = 1;
    CHECK(request(HG_MSG_ENABLE, &on, 1, 0x85, raw) == 0 && S.enabled);
    /* SET_FORCE */
    uint8_t f[12];
    put_f32(f, 1.5f);
    put_f32(f + 4, -2.5f);
    put_f32(f + 8, 0.25f);
    CHECK(request(HG_MSG_SET_FORCE, f, 12, 0x83, raw) == 0);
    CHECK(S.f_pc[0] == 1.5f && S.f_pc[1] == -2.5f && S.f_pc[2] == 0.25f && S.f_pc_age == 0);
    /* NAKs: out of range, and enabling with an error latched; nothing changes */
    put_f32(req + 25, 4000.0f);                                  /* > 35 N/cm */
    CHECK(request(HG_MSG_SET_SCENE, req, 37, HG_MSG_NAK, raw) == 2);
    CHECK(raw[3] == HG_MSG_SET_SCENE && raw[4] == HG_NAK_RANGE && S.scene.k == 2000.0f);
    put_f32(f, NAN);
    CHECK(request(HG_MSG_SET_FORCE, f, 12, HG_MSG_NAK, raw) == 2 && S.f_pc[0] == 1.5f);
    on = 2;
    CHECK(request(HG_MSG_ENABLE, &on, 1, HG_MSG_NAK, raw) == 2 && S.enabled);
    hg_servo_step(&S);                                           /* stale? no: first step */
    hg_servo_step(&S);                                           /* stale: latches */
    CHECK(S.err == HG_ERR_STALE && !S.enabled);
    on = 1;
    CHECK(request(HG_MSG_ENABLE, &on, 1, HG_MSG_NAK, raw) == 2);
    CHECK(raw[4] == HG_NAK_ERROR_LATCHED && !S.enabled);
    CHECK(request(HG_MSG_GET_STATE, NULL, 0, 0x82, raw) == HG_STATE_LEN);
    CHECK(raw[3 + 52] == (2 | 4) && raw[3 + 53] == HG_ERR_STALE); /* error, PC force live */
    CHECK(request(HG_MSG_CLEAR_ERROR, NULL, 0, 0x87, raw) == 0 && S.err == HG_ERR_NONE);
    CHECK(request(HG_MSG_ENABLE, &on, 1, 0x85, raw) == 0 && S.enabled);
    /* statistics: 10 good frames so far (4 of them refused), this one makes 11 */
    CHECK(request(HG_MSG_GET_STATS, NULL, 0, 0x86, raw) == HG_STATS_LEN);
    CHECK(raw[3] == 11 && raw[3 + 24] == 4);
    CHECK(L.st.bad_framing + L.st.bad_crc + L.st.bad_version + L.st.bad_type + L.st.bad_len == 0);
}

/* Each kind of bad frame: counted in its own counter, no reply, no action. */
void test_link_bad_frames(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], f[HG_LINK_MAX_FRAME], on = 1;
    size_t rn = 0;
    setup();
    const hg_servo_t before = S;
    size_t m = hg_link_encode(HG_MSG_ENABLE, 7, &on, 1, f);

    uint8_t bad[HG_LINK_MAX_FRAME];
    memcpy(bad, f, m);
    bad[3] ^= 0x10; /* a flipped bit in the data or CRC */
    if (bad[3] == 0)
        bad[3] = 0x10;
    CHECK(feed(bad, m, raw, &rn) == 0 && L.st.bad_crc == 1);

    const uint8_t trunc[] = { 0x02, 0x01, 0x00 }; /* 1 byte: shorter than a header + CRC */
    CHECK(feed(trunc, 3, raw, &rn) == 0 && L.st.bad_framing == 1);
    CHECK(feed(f + 2, m - 2, raw, &rn) == 0);     /* frame with its head cut off */
    CHECK(L.st.bad_framing + L.st.bad_crc == 3);
    const uint8_t cobs_bad[] = { 0x09, 0x01, 0x02, 0x00 }; /* code runs past the end */
    CHECK(feed(cobs_bad, 4, raw, &rn) == 0);

    /* right CRC, wrong content: build the raw frame by hand */
    const uint8_t cases[][6] = {
        { 4, 3, HG_MSG_ENABLE, 1, 1 },    /* version 3 */
        { 4, 1, 0x55, 1, 1 },             /* unknown type */
        { 4, 1, 0x85, 1, 1 },             /* a reply type sent to the device */
        { 3, 1, HG_MSG_INFO, 1 },         /* a version-2 message in a version-1 frame */
        { 5, 1, HG_MSG_ENABLE, 1, 1, 1 }, /* ENABLE with 2 data bytes */
        { 3, 1, HG_MSG_ENABLE, 1 },       /* ENABLE with none */
    };
    for (unsigned c = 0; c < 6; c++) {
        uint8_t r[8], e[16];
        const size_t n = cases[c][0];
        memcpy(r, cases[c] + 1, n);
        const uint16_t crc = hg_crc16(r, n);
        r[n] = (uint8_t)(crc >> 8);
        r[n + 1] = (uint8_t)crc;
        const size_t k = hg_cobs_encode(r, n + 2, e, sizeof e);
        e[k] = 0;
        CHECK(feed(e, k + 1, raw, &rn) == 0);
    }
    CHECK(L.st.bad_version == 1 && L.st.bad_type == 3 && L.st.bad_len == 2);
    CHECK(L.st.bad_framing == 3 && L.st.good == 0);

    /* over-long: 200 non-zero bytes, then the valid frame still works */
    uint8_t junk[200];
    memset(junk, 0x41, sizeof junk);
    CHECK(feed(junk, sizeof junk, raw, &rn) == 0);
    CHECK(!S.enabled && S.scene.type == before.scene.type && S.f_pc_age == before.f_pc_age);
    const uint8_t z = 0;
    CHECK(feed(&z, 1, raw, &rn) == 0 && L.st.bad_framing == 4);
    CHECK(feed(&z, 1, raw, &rn) == 0 && L.st.bad_framing == 4); /* idle 0x00: not a frame */
    CHECK(feed(f, m, raw, &rn) == 1 && S.enabled && L.st.good == 1);
}

/* Garbage glued to the front of a frame costs that frame; the parser resynchronises on 0x00. */
void test_link_resync(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], f[2 * HG_LINK_MAX_FRAME + 8];
    size_t rn = 0;
    setup();
    const uint8_t g[] = { 0x13, 0x37, 0xFF };
    memcpy(f, g, 3);
    size_t m = 3 + hg_link_encode(HG_MSG_PING, 1, NULL, 0, f + 3);
    CHECK(feed(f, m, raw, &rn) == 0 && L.st.good == 0);
    f[0] = 0;                                   /* same garbage, then a delimiter */
    m = 1 + hg_link_encode(HG_MSG_PING, 2, NULL, 0, f + 1);
    m += hg_link_encode(HG_MSG_GET_STATS, 3, NULL, 0, f + m);
    CHECK(feed(f, m, raw, &rn) == 2 && L.st.good == 2 && raw[1] == 0x86);
}

/* A version-2 request: one frame, the replies (0, 1 or more) counted, the last one in raw. */
static int request2(uint8_t type, const uint8_t *data, size_t n, uint8_t raw[HG_LINK_MAX_RAW],
                    size_t *rn)
{
    static uint8_t seq;
    uint8_t f[HG_LINK_MAX_FRAME];
    const size_t m = hg_link_encode_v(2, type, ++seq, data, n, f);
    CHECK(m > 0);
    const int r = feed(f, m, raw, rn);
    if (r)
        CHECK(raw[0] == 2 && raw[2] == seq);
    return r;
}

static void force_req(uint8_t *d, float fx, float fy, float fz, uint32_t ttl_ms, uint32_t ctr,
                      uint32_t ref)
{
    put_f32(d, fx);
    put_f32(d + 4, fy);
    put_f32(d + 8, fz);
    d[12] = (uint8_t)ttl_ms;
    d[13] = (uint8_t)(ttl_ms >> 8);
    d[14] = (uint8_t)ctr;
    d[15] = (uint8_t)(ctr >> 8);
    for (int i = 0; i < 4; i++)
        d[16 + i] = (uint8_t)(ref >> (8 * i));
}

static void tick(void)
{
    static const int32_t pos[3] = { 0, 1 << 17, 1 << 17 }, vel[3] = { 0, 0, 0 };
    hal_sim_snapshot(pos, vel);
    hg_servo_step(&S);
}

/* INFO, stats in both versions, v2 replies carry version 2. */
void test_link_v2_info_stats(void)
{
    uint8_t raw[HG_LINK_MAX_RAW];
    size_t rn = 0;
    setup();
    L.cfg.baud = 1000000;
    CHECK(request2(HG_MSG_INFO, NULL, 0, raw, &rn) == 1 && raw[1] == 0x88);
    CHECK(rn - 5 == HG_INFO_LEN);
    const uint8_t *d = raw + 3;
    CHECK(d[0] == 0x00 && d[1] == 0x01 && d[2] == HG_PROTO_VERSION);
    CHECK(d[4] == (HG_ID_VERSION & 0xFF) && d[5] == HG_ID_VERSION >> 8 &&
          d[6] == 0x47 && d[7] == 0x48);                             /* FPGA ID */
    CHECK(d[8] == (1000 & 0xFF) && d[9] == 1000 >> 8);               /* rate */
    CHECK(d[10] == (HG_LINK_TIMEOUT_MS & 0xFF) && d[11] == HG_LINK_TIMEOUT_MS >> 8);
    CHECK(d[12] == 0x40 && d[13] == 0x42 && d[14] == 0x0F && d[15] == 0); /* 1000000 */
    CHECK_NEAR(f32_at(d + 16 + 4), 0.016, 1e-7);                     /* box_lo y */
    CHECK_NEAR(f32_at(d + 40), 10.0, 0);                              /* f_max */
    CHECK_NEAR(f32_at(d + 44), 3500.0, 0);
    CHECK_NEAR(f32_at(d + 48), 100.0, 0);
    CHECK(d[52] == 100 && d[53] == 0);                                /* ttl max 100 ms */
    /* GET_STATS: 28 bytes in v1 (unchanged), 44 in v2 */
    CHECK(request(HG_MSG_GET_STATS, NULL, 0, 0x86, raw) == HG_STATS_LEN && raw[3] == 2);
    CHECK(request2(HG_MSG_GET_STATS, NULL, 0, raw, &rn) == 1 && rn - 5 == HG_STATS2_LEN);
    CHECK(raw[3] == 3);
    /* v1 PING in a v2 frame: same data, version-2 reply */
    CHECK(request2(HG_MSG_PING, NULL, 0, raw, &rn) == 1 && raw[1] == 0x81 && rn - 5 == HG_PING_LEN);
}

/* FORCE: no reply, TTL in ticks, counter and latency; replays and out-of-range refused. */
void test_link_v2_force(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], f[HG_FORCE_LEN], sc[37] = { 0 }, on = 1;
    size_t rn = 0;
    setup();
    tick();
    sc[0] = HG_SCENE_PC_FORCE;
    CHECK(request2(HG_MSG_SET_SCENE, sc, 37, raw, &rn) == 1 && raw[1] == 0x84);
    CHECK(request2(HG_MSG_ENABLE, &on, 1, raw, &rn) == 1 && raw[1] == 0x85 && L.armed);
    const uint32_t seq0 = S.seq;
    force_req(f, 1.0f, -2.0f, 0.5f, 5, 1, seq0 - 2);
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 0);    /* accepted: silent */
    CHECK(S.f_pc[1] == -2.0f && L.force_ctr == 1 && L.pend_lat == 3);
    uint8_t tx[HG_LINK_MAX_FRAME], per[2] = { 1, 0 };
    CHECK(request2(HG_MSG_STREAM, per, 2, raw, &rn) == 1);
    size_t m0 = hg_link_poll(&L, true, tx);                           /* not rendered yet: */
    CHECK(m0 > 0 && L.live_ctr == 0);
    rn = hg_cobs_decode(tx, m0 - 1, raw, HG_LINK_MAX_RAW);
    CHECK((raw[3 + 40] & 4) == 0 && f32_at(raw + 3 + 32) == 0.0f);   /* not live, F = 0 */
    for (int k = 0; k < 5; k++) {                                     /* live for 5 ticks */
        tick();
        const size_t m = hg_link_poll(&L, true, tx);
        CHECK(m > 0 && L.live_ctr == 1 && L.live_lat == 3);          /* the push names it */
        rn = hg_cobs_decode(tx, m - 1, raw, HG_LINK_MAX_RAW);
        CHECK(raw[3 + 50] == 1 && raw[3 + 52] == 3 && f32_at(raw + 3 + 32) == -2.0f);
        CHECK(raw[3 + 40] & 4);                                       /* live */
        CHECK(S.f[0] == 1.0f && S.f[1] == -2.0f && hal_sim_torque(1) != 0);
    }
    tick();                                                           /* then gone */
    CHECK(S.f[0] == 0.0f && S.f[1] == 0.0f && S.f[2] == 0.0f && hal_sim_torque(1) == 0);
    /* the same frame again (a replay), and an older counter: refused, nothing moves */
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 1);
    CHECK(raw[1] == HG_MSG_NAK && raw[4] == HG_NAK_REPLAY && L.st.replayed == 1);
    tick();
    CHECK(S.f[1] == 0.0f && hal_sim_torque(1) == 0);
    force_req(f, 1.0f, -2.0f, 0.5f, 5, 0xFFF0, S.seq);
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 1 && raw[4] == HG_NAK_REPLAY);
    /* TTL 0 and TTL above the firmware's limit, and |F| > f_max: range */
    force_req(f, 1.0f, 0, 0, 0, 2, S.seq);
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 1 && raw[4] == HG_NAK_RANGE);
    force_req(f, 1.0f, 0, 0, 101, 2, S.seq);
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 1 && raw[4] == HG_NAK_RANGE);
    force_req(f, 11.0f, 0, 0, 5, 2, S.seq);
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 1 && raw[4] == HG_NAK_RANGE);
    CHECK(L.st.rejected == 5 && L.force_ctr == 1);
    force_req(f, 0.0f, 3.0f, 0, 1, 2, S.seq);                          /* ttl 1 ms = 1 tick */
    CHECK(request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn) == 0 && L.force_ctr == 2);
    tick();
    CHECK(S.f[1] == 3.0f);
    tick();
    CHECK(S.f[1] == 0.0f);
}

/* Streaming: a push every N ticks, dropped (and counted) while the transmitter is busy. */
void test_link_v2_stream(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], tx[HG_LINK_MAX_FRAME], per[2] = { 3, 0 };
    size_t rn = 0;
    setup();
    tick();
    CHECK(request2(HG_MSG_STREAM, per, 2, raw, &rn) == 1 && raw[1] == 0x89 && raw[3] == 3);
    int pushes = 0;
    uint32_t last = 0;
    for (int k = 0; k < 30; k++) {
        tick();
        for (int r = 0; r < 3; r++) { /* the background loop polls several times a tick */
            const size_t m = hg_link_poll(&L, true, tx);
            if (!m)
                continue;
            pushes++;
            rn = hg_cobs_decode(tx, m - 1, raw, HG_LINK_MAX_RAW);
            CHECK(rn == HG_PUSH_LEN + 5 && raw[0] == 2 && raw[1] == HG_MSG_STATE_PUSH);
            const uint32_t sq = (uint32_t)raw[3] | (uint32_t)raw[4] << 8;
            CHECK(pushes == 1 || sq - last == 3);
            last = sq;
            CHECK_NEAR(f32_at(raw + 3 + 8), 0.0707107, 1e-6);         /* p y */
        }
    }
    CHECK(pushes == 10 && L.st.pushed == 10 && L.st.push_dropped == 0);
    for (int k = 0; k < 9; k++) {
        tick();
        CHECK(hg_link_poll(&L, false, tx) == 0);
    }
    CHECK(L.st.push_dropped == 2 && L.st.pushed == 10); /* 9 busy ticks, period 3 */
    per[0] = 0xE9; /* 1001 */
    per[1] = 0x03;
    CHECK(request2(HG_MSG_STREAM, per, 2, raw, &rn) == 1 && raw[1] == HG_MSG_NAK);
}

/* Link silence beyond the timeout disables an enabled servo and stops the stream; nothing
 * re-enables it, not even new traffic. */
void test_link_v2_timeout(void)
{
    uint8_t raw[HG_LINK_MAX_RAW], tx[HG_LINK_MAX_FRAME], on = 1, per[2] = { 1, 0 };
    size_t rn = 0;
    setup();
    L.cfg.timeout_ms = 20;
    tick();
    CHECK(request2(HG_MSG_ENABLE, &on, 1, raw, &rn) == 1 && S.enabled);
    CHECK(request2(HG_MSG_STREAM, per, 2, raw, &rn) == 1);
    for (int k = 0; k < 20; k++) {
        tick();
        (void)hg_link_poll(&L, true, tx);
        CHECK(S.enabled);
    }
    tick();
    CHECK(hg_link_poll(&L, true, tx) == 0);
    CHECK(!S.enabled && !L.armed && L.period == 0 && L.st.timeouts == 1);
    CHECK(request2(HG_MSG_PING, NULL, 0, raw, &rn) == 1);
    for (int k = 0; k < 5; k++) {
        tick();
        CHECK(hg_link_poll(&L, true, tx) == 0 && !S.enabled);
    }
    CHECK(L.st.timeouts == 1);
    /* a stream without enabled forces is not stopped by silence */
    CHECK(request2(HG_MSG_STREAM, per, 2, raw, &rn) == 1);
    for (int k = 0; k < 40; k++) {
        tick();
        CHECK(hg_link_poll(&L, true, tx) > 0);
    }
    CHECK(L.st.timeouts == 1 && !S.enabled);
}

/* Boundary (issue 29): the link-silence timeout at its default, HG_LINK_TIMEOUT_MS. The spec
 * (dsp-fw/README.md, "Safety over the link": "no good frame for timeout_ms (default 250 ms,
 * counted in servo ticks) disables the servo"; hg_link.h: "link silence beyond this disables
 * forces") with the numbers written here: 250 ms, i.e. 250 ticks at 1 kHz and 1000 at 4 kHz.
 * Silence of exactly the timeout keeps the servo enabled, one tick more disables it. */
static void bounds_timeout_at(uint32_t rate_hz, uint32_t want_ticks)
{
    uint8_t raw[HG_LINK_MAX_RAW], tx[HG_LINK_MAX_FRAME], on = 1;
    size_t rn = 0;
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.rate_hz = rate_hz;
    fx_servo(&S, &cfg);
    hg_link_init(&L, &S);
    CHECK(L.cfg.timeout_ms == 250u);                 /* the default is the spec's */
    CHECK(HG_LINK_TIMEOUT_MS == 250u);
    tick();
    CHECK(request2(HG_MSG_ENABLE, &on, 1, raw, &rn) == 1 && S.enabled && L.armed);
    for (uint32_t k = 1; k <= want_ticks; k++) {     /* the last tick before the timeout */
        tick();
        (void)hg_link_poll(&L, true, tx);
        if (!S.enabled) {
            CHECK(k > want_ticks);                   /* disabled early: fails here */
            return;
        }
    }
    CHECK(S.enabled && L.armed && L.st.timeouts == 0);
    tick();                                          /* the first tick past it */
    (void)hg_link_poll(&L, true, tx);
    CHECK(!S.enabled && !L.armed && L.st.timeouts == 1);
    for (int k = 0; k < 3; k++) {                    /* and it stays off */
        tick();
        (void)hg_link_poll(&L, true, tx);
        CHECK(!S.enabled && L.st.timeouts == 1);
    }
}

void test_bounds_link_timeout(void)
{
    bounds_timeout_at(1000, 250);
    bounds_timeout_at(4000, 1000);
}

/* Ticks a PC force is rendered for: from the first tick after it arrives, while F[1] shows. */
static uint32_t bounds_live_ticks(float fy, uint32_t max_ticks)
{
    uint32_t live = 0;
    for (uint32_t k = 0; k < max_ticks; k++) {
        tick();
        if (S.f[1] != fy)
            break;
        live++;
    }
    return live;
}

/* Boundary (issue 29): the PC force TTL. The spec (dsp-fw/README.md: FORCE "NAK 1 if TTL = 0 or
 * > the longest TTL"; "A FORCE lasts exactly its TTL (converted to whole ticks, rounded up; at
 * most pc_force_timeout ticks), then the scene force is zero from the next tick on"; "A
 * version-1 SET_FORCE lasts pc_force_timeout ticks"; pc_force_timeout default 100 ticks): at
 * 1 kHz the longest TTL is 100 ms; at 1.5 kHz 1 ms is 1.5 ticks -> 2, 66 ms 99 ticks, 67 ms
 * 100.5 -> 101 ticks, past the 100-tick limit. */
static void bounds_ttl_at(uint32_t rate_hz, const uint32_t ttl_ms[], const uint32_t ticks[],
                          size_t n)
{
    uint8_t raw[HG_LINK_MAX_RAW], f[HG_FORCE_LEN], sc[37] = { 0 }, on = 1;
    size_t rn = 0;
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    cfg.rate_hz = rate_hz;
    CHECK(cfg.pc_force_timeout == 100u);
    fx_servo(&S, &cfg);
    hg_link_init(&L, &S);
    tick();
    sc[0] = HG_SCENE_PC_FORCE;
    CHECK(request2(HG_MSG_SET_SCENE, sc, 37, raw, &rn) == 1 && raw[1] == 0x84);
    CHECK(request2(HG_MSG_ENABLE, &on, 1, raw, &rn) == 1 && S.enabled);
    for (size_t i = 0; i < n; i++) {
        const float fy = 1.0f + (float)i;
        force_req(f, 0.0f, fy, 0.0f, ttl_ms[i], (uint32_t)(i + 1), S.seq);
        const int r = request2(HG_MSG_FORCE, f, HG_FORCE_LEN, raw, &rn);
        if (ticks[i] == 0) {                         /* refused, nothing rendered */
            CHECK(r == 1 && raw[1] == HG_MSG_NAK && raw[4] == HG_NAK_RANGE);
            tick();
            CHECK(S.f[1] == 0.0f);
            continue;
        }
        CHECK(r == 0);
        CHECK(bounds_live_ticks(fy, 200) == ticks[i]);
        CHECK(S.f[1] == 0.0f);                       /* zero from the next tick on */
    }
}

void test_bounds_force_ttl(void)
{
    /* 1 kHz: 0 refused, 1 ms 1 tick, 99, 100 (the longest) last exactly that, 101 refused */
    const uint32_t ms1[] = { 0, 1, 99, 100, 101 }, t1[] = { 0, 1, 99, 100, 0 };
    bounds_ttl_at(1000, ms1, t1, 5);
    /* 1.5 kHz: rounded up to whole ticks */
    const uint32_t ms2[] = { 1, 2, 3, 66, 67 }, t2[] = { 2, 3, 5, 99, 0 };
    bounds_ttl_at(1500, ms2, t2, 5);
    /* version 1: SET_FORCE lasts pc_force_timeout = 100 ticks, zero on the 101st */
    uint8_t raw[HG_LINK_MAX_RAW], d[12];
    setup();
    tick();
    const hg_scene_t sc = { HG_SCENE_PC_FORCE, { 0 }, { 0 }, 0, 0, 0 };
    CHECK(hg_servo_set_scene(&S, &sc) == 0 && hg_servo_enable(&S, true) == 0);
    put_f32(d, 0.0f);
    put_f32(d + 4, 2.5f);
    put_f32(d + 8, 0.0f);
    CHECK(request(HG_MSG_SET_FORCE, d, 12, 0x83, raw) == 0);
    CHECK(bounds_live_ticks(2.5f, 200) == 100);
}
