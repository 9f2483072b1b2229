/* SPDX-License-Identifier: Apache-2.0 */
/* PC link: byte-stream parser, frame checks, message dispatch. */
#include "hg_frame.h"
#include "hg_hal.h"
#include "hg_link.h"

typedef union {
    float f;
    uint32_t u;
} f32_bits;

static void put_u16(uint8_t *d, uint32_t v)
{
    d[0] = (uint8_t)v;
    d[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *d, uint32_t v)
{
    put_u16(d, v);
    put_u16(d + 2, v >> 16);
}

static void put_f32(uint8_t *d, hg_real x)
{
    f32_bits b;
    b.f = (float)x;
    put_u32(d, b.u);
}

static hg_real get_f32(const uint8_t *d)
{
    f32_bits b;
    b.u = (uint32_t)d[0] | (uint32_t)d[1] << 8 | (uint32_t)d[2] << 16 | (uint32_t)d[3] << 24;
    return (hg_real)b.f;
}

static void put_vec(uint8_t *d, const hg_real v[3])
{
    for (int i = 0; i < 3; i++)
        put_f32(d + 4 * i, v[i]);
}

static void get_vec(const uint8_t *d, hg_real v[3])
{
    for (int i = 0; i < 3; i++)
        v[i] = get_f32(d + 4 * i);
}

/* A handler reads req (its exact length is guaranteed), writes reply data to out and its
 * length to *n, and returns 0, or a HG_NAK_* reason. */
typedef int (*handler_fn)(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n);

static int h_ping(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    (void)req;
    put_u16(out, HG_FW_VERSION);
    put_u32(out + 2, l->servo->fpga_id);
    put_u16(out + 6, l->servo->cfg.rate_hz);
    *n = HG_PING_LEN;
    return 0;
}

static int h_get_state(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_servo_t *s = l->servo;
    (void)req;
    const uint32_t t = hg_hal_irq_save();
    put_u32(out, s->seq);
    put_vec(out + 4, s->p);
    put_vec(out + 16, s->v);
    put_vec(out + 28, s->q);
    put_vec(out + 40, s->f);
    out[52] = (uint8_t)((s->enabled ? 1u : 0u) | (s->err ? 2u : 0u)
                        | (s->f_pc_age < s->cfg.pc_force_timeout ? 4u : 0u));
    out[53] = s->err;
    out[54] = s->err_axis;
    out[55] = s->scene.type;
    put_u32(out + 56, s->status);
    hg_hal_irq_restore(t);
    *n = HG_STATE_LEN;
    return 0;
}

static int h_set_force(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_real f[3];
    (void)out;
    (void)n;
    get_vec(req, f);
    return hg_servo_set_force(l->servo, f) ? HG_NAK_RANGE : 0;
}

static int h_set_scene(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_scene_t sc;
    (void)out;
    (void)n;
    sc.type = req[0];
    get_vec(req + 1, sc.p0);
    get_vec(req + 13, sc.n);
    sc.k = get_f32(req + 25);
    sc.b = get_f32(req + 29);
    sc.ki = get_f32(req + 33);
    return hg_servo_set_scene(l->servo, &sc) ? HG_NAK_RANGE : 0;
}

static int h_enable(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    (void)out;
    (void)n;
    if (req[0] > 1)
        return HG_NAK_RANGE;
    return hg_servo_enable(l->servo, req[0] == 1) ? HG_NAK_ERROR_LATCHED : 0;
}

static int h_get_stats(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const uint32_t v[7] = { l->st.good, l->st.bad_framing, l->st.bad_crc, l->st.bad_version,
                            l->st.bad_type, l->st.bad_len, l->st.rejected };
    (void)req;
    for (int i = 0; i < 7; i++)
        put_u32(out + 4 * i, v[i]);
    *n = HG_STATS_LEN;
    return 0;
}

static int h_clear_error(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    (void)req;
    (void)out;
    (void)n;
    hg_servo_clear_error(l->servo);
    return 0;
}

static const struct {
    uint8_t type;
    uint8_t len; /* exact request data length */
    handler_fn fn;
} msgs[] = {
    { HG_MSG_PING, 0, h_ping },           { HG_MSG_GET_STATE, 0, h_get_state },
    { HG_MSG_SET_FORCE, 12, h_set_force }, { HG_MSG_SET_SCENE, 37, h_set_scene },
    { HG_MSG_ENABLE, 1, h_enable },        { HG_MSG_GET_STATS, 0, h_get_stats },
    { HG_MSG_CLEAR_ERROR, 0, h_clear_error },
};

void hg_link_init(hg_link_t *l, hg_servo_t *servo)
{
    *l = (hg_link_t){ 0 };
    l->servo = servo;
}

size_t hg_link_encode(uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                      uint8_t out[HG_LINK_MAX_FRAME])
{
    uint8_t raw[HG_LINK_MAX_RAW];
    if (n > HG_LINK_MAX_DATA)
        return 0;
    raw[0] = HG_PROTO_VERSION;
    raw[1] = type;
    raw[2] = seq;
    for (size_t i = 0; i < n; i++)
        raw[HG_LINK_HDR + i] = data[i];
    const uint16_t crc = hg_crc16(raw, HG_LINK_HDR + n);
    raw[HG_LINK_HDR + n] = (uint8_t)(crc >> 8);
    raw[HG_LINK_HDR + n + 1] = (uint8_t)crc;
    const size_t m = hg_cobs_encode(raw, HG_LINK_HDR + n + 2, out, HG_LINK_MAX_FRAME - 1);
    if (m == 0)
        return 0;
    out[m] = 0;
    return m + 1;
}

/* One complete frame (delimiter stripped): check, dispatch, build the reply. */
static size_t handle_frame(hg_link_t *l, uint8_t tx[HG_LINK_MAX_FRAME])
{
    uint8_t raw[HG_LINK_MAX_RAW];
    const size_t n = hg_cobs_decode(l->rx, l->n, raw, sizeof raw);
    if (n == HG_COBS_ERR || n < HG_LINK_HDR + 2) {
        l->st.bad_framing++;
        return 0;
    }
    if (hg_crc16(raw, n - 2) != (uint16_t)(raw[n - 2] << 8 | raw[n - 1])) {
        l->st.bad_crc++;
        return 0;
    }
    if (raw[0] != HG_PROTO_VERSION) {
        l->st.bad_version++;
        return 0;
    }
    size_t m = 0;
    while (m < sizeof msgs / sizeof msgs[0] && msgs[m].type != raw[1])
        m++;
    if (m == sizeof msgs / sizeof msgs[0]) {
        l->st.bad_type++;
        return 0;
    }
    if (n - HG_LINK_HDR - 2 != msgs[m].len) {
        l->st.bad_len++;
        return 0;
    }
    l->st.good++;
    uint8_t out[HG_LINK_MAX_DATA];
    size_t out_n = 0;
    const int nak = msgs[m].fn(l, raw + HG_LINK_HDR, out, &out_n);
    if (nak) {
        l->st.rejected++;
        out[0] = raw[1];
        out[1] = (uint8_t)nak;
        return hg_link_encode(HG_MSG_NAK, raw[2], out, 2, tx);
    }
    return hg_link_encode((uint8_t)(raw[1] | HG_MSG_REPLY), raw[2], out, out_n, tx);
}

size_t hg_link_rx_byte(hg_link_t *l, uint8_t b, uint8_t tx[HG_LINK_MAX_FRAME])
{
    size_t r = 0;
    if (b != 0) {
        if (l->n < sizeof l->rx)
            l->rx[l->n++] = b;
        else
            l->overflow = true;
        return 0;
    }
    if (l->overflow)
        l->st.bad_framing++;
    else if (l->n > 0) /* back-to-back delimiters are idle fill, not frames */
        r = handle_frame(l, tx);
    l->n = 0;
    l->overflow = false;
    return r;
}
