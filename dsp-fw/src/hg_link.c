/* SPDX-License-Identifier: Apache-2.0 */
/* PC link: byte-stream parser, frame checks, message dispatch. */
#include "hg_capture.h"
#include "hg_frame.h"
#include "hg_hal.h"
#include "hg_link.h"

static void put_f32(uint8_t *d, hg_real x)
{
    hg_put_f32(d, (float)x);
}

static hg_real get_f32(const uint8_t *d)
{
    return (hg_real)hg_get_f32(d);
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

#define NO_REPLY (-1) /* a handler's "accepted, answer nothing" (FORCE) */

/* A handler reads req (its exact length is guaranteed), writes reply data to out and its
 * length to *n, and returns 0, NO_REPLY, or a HG_NAK_* reason. l->ver is the request's
 * protocol version. */
typedef int (*handler_fn)(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n);

static int h_ping(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    (void)req;
    hg_put_u16(out, HG_FW_VERSION);
    hg_put_u32(out + 2, l->servo->fpga_id);
    hg_put_u16(out + 6, l->servo->cfg.rate_hz);
    *n = HG_PING_LEN;
    return 0;
}

static int h_get_state(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_servo_t *s = l->servo;
    (void)req;
    const uint32_t t = hg_hal_irq_save();
    hg_put_u32(out, s->seq);
    put_vec(out + 4, s->p);
    put_vec(out + 16, s->v);
    put_vec(out + 28, s->q);
    put_vec(out + 40, s->f);
    out[52] = (uint8_t)((s->enabled ? 1u : 0u) | (s->err ? 2u : 0u)
                        | (s->f_pc_age < s->cfg.pc_force_timeout ? 4u : 0u));
    out[53] = s->err;
    out[54] = s->err_axis;
    out[55] = s->scene.type;
    hg_put_u32(out + 56, s->status);
    hg_hal_irq_restore(t);
    *n = HG_STATE_LEN;
    return 0;
}

/* A step has rendered the pending FORCE: it becomes the one the pushes name. */
static void promote(hg_link_t *l)
{
    if (l->pend && (int32_t)(l->servo->seq - l->pend_tick) >= 0) {
        l->pend = false;
        l->live = true;
        l->live_first = l->pend_tick;
        l->live_ttl = l->pend_ttl;
        l->live_ctr = l->pend_ctr;
        l->live_lat = l->pend_lat;
    }
}

/* A PC force (FORCE or SET_FORCE) was accepted: the next step renders it for ttl ticks. The
 * pushes name it (and flag "PC force live") from that tick on, not before: a push reports
 * what its own tick rendered even if a newer force arrived before it was sent. */
static void pend_force(hg_link_t *l, uint32_t ttl, uint16_t ctr, uint16_t lat)
{
    promote(l); /* before this one replaces it */
    l->pend = true;
    l->pend_tick = l->servo->seq + 1u;
    l->pend_ttl = ttl;
    l->pend_ctr = ctr;
    l->pend_lat = lat;
}

/* A servo refusal as the NAK reason. */
static int servo_nak(int rc)
{
    return rc == HG_SERVO_E_UNCAL ? HG_NAK_UNCALIBRATED
         : rc == HG_SERVO_E_ENABLED ? HG_NAK_ENABLED : HG_NAK_RANGE;
}

static int h_set_force(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_real f[3];
    (void)out;
    (void)n;
    get_vec(req, f);
    const int rc = hg_servo_set_force(l->servo, f);
    if (rc)
        return servo_nak(rc);
    pend_force(l, l->servo->cfg.pc_force_timeout, l->force_ctr, 0);
    return 0;
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
    if (l->bu && hg_bringup_active(l->bu)) {
        if (req[0] == 1)
            return HG_NAK_BRINGUP; /* the step owns the FPGA */
        hg_bringup_abort(l->bu, HG_BU_ERR_ABORT); /* disable stops a step to zero torque */
    }
    const int rc = hg_servo_enable(l->servo, req[0] == 1);
    if (rc)
        return rc == HG_SERVO_E_UNCAL ? HG_NAK_UNCALIBRATED : HG_NAK_ERROR_LATCHED;
    l->armed = req[0] == 1 && l->cfg.timeout_ms > 0; /* from now on silence disables */
    return 0;
}

static int h_get_stats(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const uint32_t v[11] = { l->st.good, l->st.bad_framing, l->st.bad_crc, l->st.bad_version,
                             l->st.bad_type, l->st.bad_len, l->st.rejected, l->st.replayed,
                             l->st.pushed, l->st.push_dropped, l->st.timeouts };
    const size_t k = l->ver == HG_PROTO_V1 ? 7u : 11u; /* a v1 request gets the v1 reply */
    (void)req;
    for (size_t i = 0; i < k; i++)
        hg_put_u32(out + 4 * i, v[i]);
    *n = 4u * k;
    return 0;
}

static uint32_t ms_to_ticks(const hg_servo_t *s, uint32_t ms)
{
    return (uint32_t)(((uint64_t)ms * s->cfg.rate_hz + 999u) / 1000u);
}

static int h_info(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_servo_t *s = l->servo;
    (void)req;
    hg_put_u16(out, HG_FW_VERSION);
    out[2] = HG_PROTO_VERSION;
    out[3] = 0;
    hg_put_u32(out + 4, s->fpga_id);
    hg_put_u16(out + 8, s->cfg.rate_hz);
    hg_put_u16(out + 10, l->cfg.timeout_ms);
    hg_put_u32(out + 12, l->cfg.baud);
    put_vec(out + 16, l->cfg.box_lo);
    put_vec(out + 28, l->cfg.box_hi);
    put_f32(out + 40, s->cfg.f_max);
    put_f32(out + 44, HG_SCENE_K_MAX);
    put_f32(out + 48, HG_SCENE_B_MAX);
    hg_put_u16(out + 52, (uint32_t)((uint64_t)s->cfg.pc_force_timeout * 1000u / s->cfg.rate_hz));
    hg_put_u16(out + 54, l->force_ctr);
    *n = HG_INFO_LEN;
    return 0;
}

static int h_stream(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const uint32_t period = hg_get_u16(req);
    if (period > HG_STREAM_MAX_PERIOD)
        return HG_NAK_RANGE;
    l->period = period;
    l->last_push = l->servo->seq - period; /* the first push goes out at the next poll */
    hg_put_u16(out, period);
    *n = HG_STREAM_ACK_LEN;
    return 0;
}

/* f32 F[3] N, u16 ttl ms, u16 counter, u32 SEQ of the state the force answers. */
static int h_force(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_servo_t *s = l->servo;
    hg_real f[3];
    (void)out;
    (void)n;
    get_vec(req, f);
    const uint32_t ttl = ms_to_ticks(s, hg_get_u16(req + 12));
    const uint16_t ctr = (uint16_t)hg_get_u16(req + 14);
    if (!hg_servo_calibrated(s))
        return HG_NAK_UNCALIBRATED; /* before the counter: a refused force consumes nothing */
    if (ttl == 0 || ttl > s->cfg.pc_force_timeout)
        return HG_NAK_RANGE;
    if (l->have_force && (uint16_t)(ctr - l->force_ctr) - 1u >= 0x7FFFu) {
        l->st.replayed++; /* not newer than the last accepted one: a replay, or stale */
        return HG_NAK_REPLAY;
    }
    if (hg_servo_set_force(s, f))
        return HG_NAK_RANGE;
    const uint32_t t = hg_hal_irq_save();
    s->f_pc_age = s->cfg.pc_force_timeout - ttl; /* live for exactly ttl ticks */
    const uint32_t lat = s->seq + 1u - hg_get_u32(req + 16);
    hg_hal_irq_restore(t);
    l->have_force = true;
    l->force_ctr = ctr;
    pend_force(l, ttl, ctr, (uint16_t)(lat > 0xFFFFu ? 0xFFFFu : lat));
    return NO_REPLY;
}

/* u8 axis, u8 flags, i8 enc_dir, u8 phases_swapped, u8 pole_pairs, i32 index_to_zero,
 * u16 comm_offset (the FPGA's OFFSET units): SET_CALIB's request and GET_CALIB's reply. */
static void put_calib(uint8_t *d, uint8_t axis, const hg_axis_calib_t *c)
{
    d[0] = axis;
    d[1] = c->flags;
    d[2] = (uint8_t)c->enc_dir;
    d[3] = c->phases_swapped;
    d[4] = c->pole_pairs;
    hg_put_u32(d + 5, (uint32_t)c->index_to_zero);
    hg_put_u16(d + 9, c->comm_offset);
}

static int h_set_calib(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_axis_calib_t c;
    (void)out;
    (void)n;
    if (l->bu && hg_bringup_active(l->bu))
        return HG_NAK_BRINGUP;
    c.flags = req[1];
    c.enc_dir = (int8_t)(req[2] >= 0x80u ? (int)req[2] - 256 : (int)req[2]);
    c.phases_swapped = req[3];
    c.pole_pairs = req[4];
    c.index_to_zero = (int32_t)hg_get_u32(req + 5);
    c.comm_offset = hg_get_u16(req + 9);
    const int rc = hg_servo_set_calib(l->servo, req[0], &c);
    return rc ? servo_nak(rc) : 0;
}

static int h_get_calib(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    if (req[0] >= 3u)
        return HG_NAK_RANGE;
    const uint32_t t = hg_hal_irq_save();
    put_calib(out, req[0], &l->servo->cfg.cal.axis[req[0]]);
    hg_hal_irq_restore(t);
    *n = HG_CALIB_LEN;
    return 0;
}

/* ---- bring-up (hg_bringup.h); the layouts are tabled in README.md, "PC link protocol" */

/* u8 step, u8 axis, i8 expect[3], u32 seed -> u8 result (HG_BU_*: 0 started), f32 value,
 * f32 limit (the figures of a refusal, e.g. ERR_CONFIG's planned travel and its bound). */
static int h_bu_start(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    hg_bringup_t *b = l->bu;
    if (!b)
        return HG_NAK_BRINGUP;
    int8_t expect[3];
    for (int i = 0; i < 3; i++)
        expect[i] = (int8_t)(req[2 + i] >= 0x80u ? (int)req[2 + i] - 256 : (int)req[2 + i]);
    int rc = HG_BU_ERR_BUSY;
    if (!hg_bringup_active(b)) {
        /* a refusal leaves its figures here (ERR_CONFIG, NOT_READY); others leave zeros */
        b->err_value = b->err_limit = 0.0f;
        rc = hg_bringup_start(b, req[0], req[1], expect, hg_get_u32(req + 5));
    }
    out[0] = (uint8_t)rc;
    hg_put_f32(out + 1, rc != HG_BU_OK ? b->err_value : 0.0f);
    hg_put_f32(out + 5, rc != HG_BU_OK ? b->err_limit : 0.0f);
    *n = HG_BU_START_ACK_LEN;
    return 0;
}

/* u8 state, u8 step, u8 axis, u8 err, u32 ticks, u32 tick_limit, f32 err_value,
 * f32 err_limit, u32 FPGA SEQ of the step's last snapshot, u16 servo rate Hz. */
static int h_bu_progress(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_bringup_t *b = l->bu;
    (void)req;
    if (!b)
        return HG_NAK_BRINGUP;
    const uint32_t t = hg_hal_irq_save();
    out[0] = (uint8_t)b->state;
    out[1] = b->step;
    out[2] = b->axis;
    out[3] = b->err;
    hg_put_u32(out + 4, b->ticks);
    hg_put_u32(out + 8, b->tick_limit);
    hg_put_f32(out + 12, b->err_value);
    hg_put_f32(out + 16, b->err_limit);
    hg_put_u32(out + 20, b->seq);
    hg_hal_irq_restore(t);
    hg_put_u16(out + 24, l->servo->cfg.rate_hz);
    *n = HG_BU_PROGRESS_LEN;
    return 0;
}

static void put_calib(uint8_t *d, uint8_t axis, const hg_axis_calib_t *c);

/* u8 axis, u8 page -> page 0 (ALIGN, HOME, GUIDED), 1 (IDENT, durations), 2 (calibration),
 * 3 (IDENT's pose and hold), 4 (ENCODER). */
static int h_bu_result(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_bringup_t *b = l->bu;
    const uint8_t a = req[0];
    if (!b)
        return HG_NAK_BRINGUP;
    if (a >= 3u || req[1] > 4u)
        return HG_NAK_RANGE;
    const hg_bu_axis_t *r = &b->res[a];
    const uint32_t t = hg_hal_irq_save();
    if (req[1] == 4u) {
        out[0] = a;
        out[1] = 4;
        out[2] = r->enc_captured ? 1u : 0u;
        out[3] = 0;
        hg_put_f32(out + 4, r->duration_s[HG_BU_STEP_ENCODER]);
        hg_put_u32(out + 8, r->enc_decim);
        hg_put_u32(out + 12, r->enc_entries);
        hg_put_f32(out + 16, r->enc_speed);
        hg_put_f32(out + 20, (float)b->cfg.enc_sample_hz);
        for (int i = 0; i < 5; i++)
            hg_put_u32(out + 24 + 4 * i, r->enc_cal[i]);
        *n = HG_BU_RESULT4_LEN;
    } else if (req[1] == 3u) {
        const float v[9] = { r->id_q[0], r->id_q[1], r->id_q[2], r->id_hold_max, r->id_lag,
                             r->id_se[0], r->id_se[1], r->id_se[2], r->id_se[3] };
        out[0] = a;
        out[1] = 3;
        out[2] = out[3] = 0;
        for (int i = 0; i < 9; i++)
            hg_put_f32(out + 4 + 4 * i, v[i]);
        *n = HG_BU_RESULT3_LEN;
    } else if (req[1] == 2u) {
        put_calib(out, a, &b->calib.axis[a]);
        *n = HG_BU_RESULT2_LEN;
    } else if (req[1] == 1u) {
        const float v[12] = { r->inertia, r->b_visc, r->tau_coulomb, r->tau_gravity, r->kt_amp,
                              r->ident_resid, r->duration_s[0], r->duration_s[1],
                              r->duration_s[2], r->duration_s[3], r->duration_s[4],
                              r->duration_s[5] };
        out[0] = a;
        out[1] = 1;
        out[2] = out[3] = 0;
        for (int i = 0; i < 12; i++)
            hg_put_f32(out + 4 + 4 * i, v[i]);
        *n = HG_BU_RESULT1_LEN;
    } else {
        out[0] = a;
        out[1] = 0;
        out[2] = (uint8_t)((r->aligned ? 1u : 0u) | (r->homed ? 2u : 0u)
                           | (r->home_virtual ? 4u : 0u) | (r->guided_reversed ? 8u : 0u)
                           | (r->refused ? 16u : 0u));
        out[3] = (uint8_t)r->scan_sign;
        out[4] = (uint8_t)r->dir_base;
        out[5] = 0;
        const float f[6] = { r->counts_per_elec, r->counts_per_elec_cfg, r->pole_pairs_meas,
                             r->align_lambda, r->offset_raw, r->move_elec_deg };
        for (int i = 0; i < 6; i++)
            hg_put_f32(out + 6 + 4 * i, f[i]);
        hg_put_u32(out + 30, (uint32_t)r->home_count);
        hg_put_u32(out + 34, (uint32_t)r->ref_count);
        hg_put_u32(out + 38, (uint32_t)r->enc_offset);
        hg_put_f32(out + 42, r->home_travel);
        hg_put_f32(out + 46, r->guided_move);
        hg_put_f32(out + 50, r->guided_wait_s);
        *n = HG_BU_RESULT0_LEN;
    }
    hg_hal_irq_restore(t);
    return 0;
}

static void put_str(uint8_t *d, const char *s, size_t len)
{
    size_t i = 0;
    for (; s && s[i] && i + 1 < len; i++)
        d[i] = (uint8_t)s[i];
    for (; i < len; i++)
        d[i] = 0;
}

/* u8 axis, u8 check -> u8 axis, u8 check, u8 number of checks, u8 flags (bit 0 passes when
 * value >= limit, 1 evaluated in the last run of its step, 2 passed), f32 value, f32 limit,
 * name[32], unit[12] (NUL-terminated, NUL-padded). */
static int h_bu_check(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const hg_bringup_t *b = l->bu;
    if (!b)
        return HG_NAK_BRINGUP;
    if (req[0] >= 3u || req[1] >= HG_BU_NCHECKS)
        return HG_NAK_RANGE;
    const uint32_t t = hg_hal_irq_save();
    const hg_bu_check_info_t c = hg_bringup_check(b, req[0], req[1]);
    hg_hal_irq_restore(t);
    out[0] = req[0];
    out[1] = req[1];
    out[2] = HG_BU_NCHECKS;
    out[3] = (uint8_t)((c.ge ? 1u : 0u) | (c.done ? 2u : 0u) | (c.pass ? 4u : 0u));
    hg_put_f32(out + 4, c.value);
    hg_put_f32(out + 8, c.limit);
    put_str(out + 12, c.name, HG_BU_NAME_LEN);
    put_str(out + 12 + HG_BU_NAME_LEN, c.unit, HG_BU_UNIT_LEN);
    *n = HG_BU_CHECK_LEN;
    return 0;
}

static int h_bu_abort(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    (void)req;
    (void)out;
    (void)n;
    if (!l->bu)
        return HG_NAK_BRINGUP;
    hg_bringup_abort(l->bu, HG_BU_ERR_ABORT);
    return 0;
}

/* u16 first entry, u8 entries (1..HG_CAP_READ_MAX) -> u16 first, u8 entries, u8 0, the raw
 * entries {B, A} as u16. Not while a bring-up step runs (its ISR polls the buffer). */
static int h_cap_read(hg_link_t *l, const uint8_t *req, uint8_t *out, size_t *n)
{
    const uint32_t start = hg_get_u16(req);
    const uint32_t cnt = req[2];
    if (l->bu && hg_bringup_active(l->bu))
        return HG_NAK_BRINGUP;
    const uint32_t depth = hg_cap_depth();
    if (cnt == 0 || cnt > HG_CAP_READ_MAX || start + cnt > depth)
        return HG_NAK_RANGE;
    uint16_t w[HG_CAP_READ_MAX];
    if (hg_cap_read_words(start, w, cnt) != HG_CAP_OK)
        return HG_NAK_RANGE;
    hg_put_u16(out, (uint16_t)start);
    out[2] = (uint8_t)cnt;
    out[3] = 0;
    for (uint32_t j = 0; j < cnt; j++)
        hg_put_u16(out + 4 + 2 * j, w[j]);
    *n = 4u + 2u * cnt;
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
    uint8_t len;     /* exact request data length */
    uint8_t min_ver; /* lowest protocol version that has the message */
    handler_fn fn;
} msgs[] = {
    { HG_MSG_PING, 0, 1, h_ping },           { HG_MSG_GET_STATE, 0, 1, h_get_state },
    { HG_MSG_SET_FORCE, HG_SET_FORCE_LEN, 1, h_set_force },
    { HG_MSG_SET_SCENE, HG_SET_SCENE_LEN, 1, h_set_scene },
    { HG_MSG_ENABLE, HG_ENABLE_LEN, 1, h_enable },        { HG_MSG_GET_STATS, 0, 1, h_get_stats },
    { HG_MSG_CLEAR_ERROR, 0, 1, h_clear_error }, { HG_MSG_INFO, 0, 2, h_info },
    { HG_MSG_STREAM, HG_STREAM_LEN, 2, h_stream },        { HG_MSG_FORCE, HG_FORCE_LEN, 2, h_force },
    { HG_MSG_SET_CALIB, HG_CALIB_LEN, 2, h_set_calib },
    { HG_MSG_GET_CALIB, HG_GET_CALIB_LEN, 2, h_get_calib },
    { HG_MSG_BU_START, HG_BU_START_LEN, 2, h_bu_start },
    { HG_MSG_BU_PROGRESS, 0, 2, h_bu_progress },
    { HG_MSG_BU_RESULT, HG_BU_RESULT_LEN, 2, h_bu_result },
    { HG_MSG_BU_CHECK, HG_BU_CHECK_REQ_LEN, 2, h_bu_check },
    { HG_MSG_BU_ABORT, 0, 2, h_bu_abort },
    { HG_MSG_CAP_READ, HG_CAP_READ_LEN, 2, h_cap_read },
};

void hg_link_init(hg_link_t *l, hg_servo_t *servo)
{
    static const hg_link_cfg_t dflt = {
        0, HG_LINK_TIMEOUT_MS,
        /* bounding box of the endpoint over the wall-limited joint range (default linkage) */
        { HG_C(-0.086), HG_C(0.016), HG_C(-0.093) }, { HG_C(0.086), HG_C(0.099), HG_C(0.093) },
    };
    *l = (hg_link_t){ 0 };
    l->servo = servo;
    l->cfg = dflt;
    l->ver = HG_PROTO_V1;
}

size_t hg_link_encode(uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                      uint8_t out[HG_LINK_MAX_FRAME])
{
    return hg_link_encode_v(HG_PROTO_V1, type, seq, data, n, out);
}

size_t hg_link_encode_v(uint8_t version, uint8_t type, uint8_t seq, const uint8_t *data,
                        size_t n, uint8_t out[HG_LINK_MAX_FRAME])
{
    return hg_frame_encode(version, type, seq, data, n, out);
}

/* The link's clock in FPGA SEQ ticks: the servo's snapshot SEQ, or while bring-up runs (the
 * servo does not step) the later of it and bring-up's, never going back. */
static uint32_t link_now(hg_link_t *l)
{
    if (!l->bu)
        return l->servo->seq;
    uint32_t t = l->now;
    if ((int32_t)(l->servo->seq - t) > 0)
        t = l->servo->seq;
    if (l->bu->have_prev && (int32_t)(l->bu->seq - t) > 0)
        t = l->bu->seq;
    l->now = t;
    return t;
}

/* One complete frame (delimiter stripped): check, dispatch, build the reply. */
static size_t handle_frame(hg_link_t *l, uint8_t tx[HG_LINK_MAX_FRAME])
{
    uint8_t raw[HG_LINK_MAX_RAW];
    size_t n = 0;
    const int chk = hg_frame_check(l->rx, l->n, raw, &n);
    if (chk == HG_FRAME_BAD_FRAMING) {
        l->st.bad_framing++;
        return 0;
    }
    if (chk == HG_FRAME_BAD_CRC) {
        l->st.bad_crc++;
        return 0;
    }
    if (raw[0] < HG_PROTO_V1 || raw[0] > HG_PROTO_VERSION) {
        l->st.bad_version++;
        return 0;
    }
    size_t m = 0;
    while (m < sizeof msgs / sizeof msgs[0] && (msgs[m].type != raw[1] || raw[0] < msgs[m].min_ver))
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
    l->last_rx = link_now(l);
    l->ver = raw[0];
    uint8_t out[HG_LINK_MAX_DATA];
    size_t out_n = 0;
    const int nak = msgs[m].fn(l, raw + HG_LINK_HDR, out, &out_n);
    if (nak == NO_REPLY)
        return 0;
    if (nak) {
        l->st.rejected++;
        out[0] = raw[1];
        out[1] = (uint8_t)nak;
        return hg_link_encode_v(raw[0], HG_MSG_NAK, raw[2], out, 2, tx);
    }
    return hg_link_encode_v(raw[0], (uint8_t)(raw[1] | HG_MSG_REPLY), raw[2], out, out_n, tx);
}

size_t hg_link_poll(hg_link_t *l, bool tx_free, uint8_t tx[HG_LINK_MAX_FRAME])
{
    hg_servo_t *s = l->servo;
    const uint32_t seq = s->seq;
    const uint32_t limit = ms_to_ticks(s, l->cfg.timeout_ms);
    const uint32_t now = link_now(l);
    /* with bring-up, last_rx may be ahead of a servo SEQ not yet re-seeded: no silence */
    const uint32_t quiet = l->bu && (int32_t)(now - l->last_rx) < 0 ? 0u : now - l->last_rx;
    if (l->bu && hg_bringup_active(l->bu) && limit > 0 && quiet > limit) {
        hg_bringup_abort(l->bu, HG_BU_ERR_LINK); /* silence during a step: zero torque */
        l->st.timeouts++;
    }
    if (limit > 0 && l->armed && quiet > limit) { /* the driving PC went silent */
        hg_servo_enable(s, false);
        l->armed = false;
        l->period = 0;
        l->st.timeouts++;
    }
    promote(l);
    if (l->period == 0 || seq - l->last_push < l->period)
        return 0;
    if (!tx_free) { /* a push waits for the line; once the next one is due, one is lost */
        if (seq - l->last_push >= 2u * l->period) {
            l->st.push_dropped++;
            l->last_push += l->period;
        }
        return 0;
    }
    l->last_push = seq;
    uint8_t d[HG_PUSH_LEN];
    const uint32_t t = hg_hal_irq_save();
    hg_put_u32(d, s->seq);
    put_vec(d + 4, s->p);
    put_vec(d + 16, s->v);
    put_vec(d + 28, s->f);
    d[40] = (uint8_t)((s->enabled ? 1u : 0u) | (s->err ? 2u : 0u)
                      | (l->live && seq - l->live_first < l->live_ttl ? 4u : 0u)
                      | (l->armed ? 8u : 0u));
    d[41] = s->err;
    d[42] = s->err_axis;
    d[43] = s->scene.type;
    for (int i = 0; i < 3; i++)
        hg_put_u16(d + 44 + 2 * i, (uint32_t)(uint16_t)s->code[i]);
    hg_hal_irq_restore(t);
    hg_put_u16(d + 50, l->live_ctr);
    hg_put_u16(d + 52, l->live_lat);
    l->st.pushed++;
    return hg_link_encode_v(HG_PROTO_VERSION, HG_MSG_STATE_PUSH, l->push_seq++, d, HG_PUSH_LEN, tx);
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
