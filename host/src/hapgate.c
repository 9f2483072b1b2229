/* SPDX-License-Identifier: Apache-2.0 */
/* hapgate host library (include/hapgate.h): the port, the reader thread, the requests, the
 * stream and the servo loop. Frames are built and checked by the firmware's own hg_frame.c. */
#include "hapgate.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>
#ifdef __linux__
#include <linux/serial.h>
#include <sys/ioctl.h>
#endif

#include "hg_frame.h"

#define QUEUE_N 4096u /* pushes kept for hg_next_push (the oldest go first)               */
#define HIST_N 1024u  /* histogram bins, one per tick; longer values share the last bin   */
#define POLL_MS 20    /* the reader's poll period: how soon it sees a stop or a silence   */
#define F_SCALE 0.999 /* a loop force longer than f_max is scaled to this fraction of it  */
#define RT_PRIO 50    /* SCHED_FIFO priority of the reader and the loop while a loop runs  */

typedef struct {
    uint64_t bin[HIST_N];
    uint64_t n;
    uint32_t max;
} hist_t;

struct hg_dev {
    int fd;
    double timeout_s;
    pthread_mutex_t mu; /* everything below, except what is marked otherwise */
    pthread_cond_t cv;  /* any change: a reply, a push, a lost link, the loop's end */
    pthread_mutex_t rq; /* one request in flight at a time */
    pthread_mutex_t wr; /* writes to fd */
    pthread_t rx;
    int rx_started, stop_rx;
    int lost;
    /* the request in flight */
    int waiting, got;
    uint8_t seq, want_seq, want_type, got_type;
    uint8_t got_data[HG_LINK_MAX_DATA];
    size_t got_n;
    int nak_force; /* reason of an asynchronous FORCE refusal not yet reported */
    hg_dev_info_t info;
    int have_info;
    /* the stream */
    int streaming;
    struct timespec last_push;
    hg_dev_state_t newest;
    int have_newest;
    hg_dev_state_t *queue; /* QUEUE_N */
    size_t qh, qn;
    int have_push_seq;
    uint8_t push_seq;
    hg_dev_stats_t host;
    hg_push_hook hook;
    void *hook_user;
    uint16_t counter;
    int sent_any, have_lat_ctr;
    uint16_t lat_ctr;
    hist_t lat;
    /* the loop */
    pthread_t loop;
    int loop_started, loop_stop;
    hg_loop_fn fn;
    void *user;
    unsigned ttl_ms, period;
    hg_loop_stats_t ls;
    hist_t ivl;
    uint32_t first_seq, last_seq;
    /* the reader thread's own */
    uint8_t rxb[HG_LINK_MAX_FRAME];
    size_t rxn;
    int rx_over;
};

const char *hg_strerror(int status)
{
    switch (status) {
    case HG_OK: return "success";
    case HG_E_ARG: return "bad argument";
    case HG_E_OPEN: return "the port could not be opened or configured";
    case HG_E_TIMEOUT: return "no reply within the timeout";
    case HG_E_LINK_LOST: return "link lost (the port failed or closed, or the stream went silent)";
    case HG_E_PROTOCOL: return "the device answered something unexpected";
    case HG_E_REFUSED: return "refused by the device, or more than the link carries";
    case HG_E_FAULT: return "the device has latched a safety error";
    case HG_E_BUSY: return "a servo loop is already running";
    case HG_E_NOMEM: return "out of memory";
    default: return "unknown status";
    }
}

int hg_torque_zero(const hg_dev_state_t *s)
{
    if (s->is_push)
        return s->code[0] == 0 && s->code[1] == 0 && s->code[2] == 0;
    return !s->enabled || s->error != 0;
}

/* ---------------------------------------------------------------- bytes and time */
static double get_f32(const uint8_t *d) { return (double)hg_get_f32(d); }

static void get_vec(const uint8_t *d, double v[3])
{
    for (int i = 0; i < 3; i++)
        v[i] = get_f32(d + 4 * i);
}

static void put_f32(uint8_t *d, double x) { hg_put_f32(d, (float)x); }

static struct timespec now_mono(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t;
}

static double since(struct timespec t0)
{
    const struct timespec t = now_mono();
    return (double)(t.tv_sec - t0.tv_sec) + 1e-9 * (double)(t.tv_nsec - t0.tv_nsec);
}

static struct timespec deadline(double s)
{
    struct timespec t = now_mono();
    const double whole = floor(s);
    t.tv_sec += (time_t)whole;
    t.tv_nsec += (long)((s - whole) * 1e9);
    if (t.tv_nsec >= 1000000000L) {
        t.tv_sec++;
        t.tv_nsec -= 1000000000L;
    }
    return t;
}

/* Wait on the condition until `until`; 0 when the time is up. Called with mu held. */
static int wait_until(hg_dev_t *d, const struct timespec *until)
{
    return pthread_cond_timedwait(&d->cv, &d->mu, until) != ETIMEDOUT;
}

static void hist_add(hist_t *h, uint32_t v)
{
    h->bin[v < HIST_N ? v : HIST_N - 1]++;
    h->n++;
    if (v > h->max)
        h->max = v;
}

/* Nearest-rank percentile in bins (ticks); the max is exact. */
static void hist_pct(const hist_t *h, double tick_ms, double out[3])
{
    static const double ps[2] = { 0.50, 0.99 };
    if (h->n == 0) {
        out[0] = out[1] = out[2] = NAN;
        return;
    }
    for (int k = 0; k < 2; k++) {
        const uint64_t rank = (uint64_t)ceil(ps[k] * (double)h->n);
        uint64_t c = 0;
        uint32_t v = 0;
        while (v < HIST_N && (c += h->bin[v]) < rank)
            v++;
        out[k] = (v == HIST_N - 1 ? (double)h->max : (double)v) * tick_ms;
    }
    out[2] = (double)h->max * tick_ms;
}

/* ---------------------------------------------------------------- the port */
static void lose(hg_dev_t *d) /* mu held */
{
    d->lost = 1;
    pthread_cond_broadcast(&d->cv);
}

static int write_all(hg_dev_t *d, const uint8_t *b, size_t n)
{
    int r = HG_OK;
    pthread_mutex_lock(&d->wr);
    while (n > 0) {
        const ssize_t w = write(d->fd, b, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            r = HG_E_LINK_LOST;
            break;
        }
        b += w;
        n -= (size_t)w;
    }
    pthread_mutex_unlock(&d->wr);
    if (r != HG_OK) {
        pthread_mutex_lock(&d->mu);
        lose(d);
        pthread_mutex_unlock(&d->mu);
    }
    return r;
}

static void parse_push(const hg_dev_t *d, const uint8_t *b, hg_dev_state_t *s)
{
    memset(s, 0, sizeof *s);
    s->is_push = 1;
    s->seq = hg_get_u32(b);
    s->t_s = d->have_info && d->info.servo_hz ? (double)s->seq / d->info.servo_hz : 0.0;
    get_vec(b + 4, s->p);
    get_vec(b + 16, s->v);
    get_vec(b + 28, s->f);
    s->q[0] = s->q[1] = s->q[2] = NAN;
    s->flags = b[40];
    s->enabled = (b[40] & HG_FLAG_ENABLED) != 0;
    s->pc_force_live = (b[40] & HG_FLAG_PC_FORCE) != 0;
    s->error = b[41];
    s->error_axis = b[42];
    s->scene = b[43];
    for (int i = 0; i < 3; i++)
        s->code[i] = (int16_t)hg_get_u16(b + 44 + 2 * i);
    s->force_counter = (uint16_t)hg_get_u16(b + 50);
    s->force_latency_ticks = (uint16_t)hg_get_u16(b + 52);
}

static void on_push(hg_dev_t *d, uint8_t frame_seq, const uint8_t *b) /* mu held */
{
    hg_dev_state_t s;
    parse_push(d, b, &s);
    if (d->have_push_seq)
        d->host.push_gaps += (uint8_t)(frame_seq - d->push_seq - 1u);
    d->have_push_seq = 1;
    d->push_seq = frame_seq;
    d->host.pushes++;
    if (d->sent_any && (!d->have_lat_ctr || s.force_counter != d->lat_ctr)) {
        d->have_lat_ctr = 1;
        d->lat_ctr = s.force_counter;
        hist_add(&d->lat, s.force_latency_ticks);
    }
    if (d->hook)
        d->hook(&s, d->hook_user);
    d->newest = s;
    d->have_newest = 1;
    d->queue[(d->qh + d->qn) % QUEUE_N] = s;
    if (d->qn < QUEUE_N)
        d->qn++;
    else
        d->qh = (d->qh + 1) % QUEUE_N;
    d->last_push = now_mono();
    pthread_cond_broadcast(&d->cv);
}

static void on_chunk(hg_dev_t *d) /* mu held */
{
    uint8_t raw[HG_LINK_MAX_RAW];
    size_t n = 0;
    const int chk = hg_frame_check(d->rxb, d->rxn, raw, &n);
    if (chk != HG_FRAME_OK) {
        if (chk == HG_FRAME_BAD_CRC)
            d->host.host_bad_crc++;
        else
            d->host.host_bad_framing++;
        return;
    }
    if (raw[0] < HG_PROTO_V1 || raw[0] > HG_PROTO_VERSION) {
        d->host.host_bad_version++;
        return;
    }
    const uint8_t type = raw[1], seq = raw[2];
    const uint8_t *data = raw + HG_LINK_HDR;
    const size_t dn = n - HG_LINK_HDR - 2;
    if (type == HG_MSG_STATE_PUSH && dn == HG_PUSH_LEN) {
        on_push(d, seq, data);
    } else if (type == HG_MSG_NAK && dn == 2 && data[0] == HG_MSG_FORCE) {
        d->nak_force = data[1] ? data[1] : 1;
        pthread_cond_broadcast(&d->cv);
    } else if (d->waiting && !d->got && seq == d->want_seq
               && (type == (d->want_type | HG_MSG_REPLY) || type == HG_MSG_NAK)) {
        d->got = 1;
        d->got_type = type;
        d->got_n = dn;
        memcpy(d->got_data, data, dn);
        pthread_cond_broadcast(&d->cv);
    } else {
        d->host.host_stray++;
    }
}

static void *rx_main(void *arg)
{
    hg_dev_t *d = arg;
    uint8_t buf[512];
    for (;;) {
        pthread_mutex_lock(&d->mu);
        if (d->stop_rx || d->lost) {
            pthread_mutex_unlock(&d->mu);
            return NULL;
        }
        if (d->streaming && since(d->last_push) > d->timeout_s) /* the stream went silent */
            lose(d);
        pthread_mutex_unlock(&d->mu);
        struct pollfd p = { d->fd, POLLIN, 0 };
        const int r = poll(&p, 1, POLL_MS);
        if (r < 0 && errno == EINTR)
            continue;
        ssize_t got = 0;
        if (r > 0 && (p.revents & POLLIN)) {
            got = read(d->fd, buf, sizeof buf);
            if (got < 0 && (errno == EINTR || errno == EAGAIN))
                continue;
        }
        pthread_mutex_lock(&d->mu);
        if (r < 0 || (r > 0 && got <= 0)) { /* an error, POLLHUP, EOF or EIO: the far end is gone */
            lose(d);
            pthread_mutex_unlock(&d->mu);
            return NULL;
        }
        for (ssize_t i = 0; i < got; i++) {
            const uint8_t b = buf[i];
            if (b != 0) {
                if (d->rxn < sizeof d->rxb)
                    d->rxb[d->rxn++] = b;
                else
                    d->rx_over = 1;
                continue;
            }
            if (d->rx_over)
                d->host.host_bad_framing++;
            else if (d->rxn > 0) /* back-to-back delimiters are idle fill */
                on_chunk(d);
            d->rxn = 0;
            d->rx_over = 0;
        }
        pthread_mutex_unlock(&d->mu);
    }
}

/* ---------------------------------------------------------------- requests */
static int send_frame(hg_dev_t *d, uint8_t type, uint8_t seq, const uint8_t *data, size_t n)
{
    uint8_t frame[HG_LINK_MAX_FRAME];
    const size_t m = hg_frame_encode(HG_PROTO_VERSION, type, seq, data, n, frame);
    if (m == 0)
        return HG_E_ARG;
    return write_all(d, frame, m);
}

/* One request and its reply: exactly `want` data bytes (or any length if want < 0). */
static int request(hg_dev_t *d, uint8_t type, const uint8_t *data, size_t n, uint8_t *reply,
                   int want, double timeout_s)
{
    pthread_mutex_lock(&d->rq);
    pthread_mutex_lock(&d->mu);
    if (d->lost) {
        pthread_mutex_unlock(&d->mu);
        pthread_mutex_unlock(&d->rq);
        return HG_E_LINK_LOST;
    }
    const uint8_t seq = ++d->seq;
    d->waiting = 1;
    d->got = 0;
    d->want_seq = seq;
    d->want_type = type;
    pthread_mutex_unlock(&d->mu);
    int r = send_frame(d, type, seq, data, n);
    pthread_mutex_lock(&d->mu);
    const struct timespec until = deadline(timeout_s);
    while (r == HG_OK && !d->got && !d->lost)
        if (!wait_until(d, &until))
            break;
    if (r == HG_OK) {
        if (d->got && d->got_type == HG_MSG_NAK)
            r = d->got_n == 2 && d->got_data[1] == HG_NAK_ERROR_LATCHED ? HG_E_FAULT
              : d->got_n == 2                                         ? HG_E_REFUSED
                                                                      : HG_E_PROTOCOL;
        else if (d->got)
            r = want >= 0 && d->got_n != (size_t)want ? HG_E_PROTOCOL : HG_OK;
        else
            r = d->lost ? HG_E_LINK_LOST : HG_E_TIMEOUT;
    }
    if (r == HG_OK && reply)
        memcpy(reply, d->got_data, d->got_n);
    d->waiting = 0;
    pthread_mutex_unlock(&d->mu);
    pthread_mutex_unlock(&d->rq);
    return r;
}

static void max_stream(hg_dev_info_t *i)
{
    /* pushes one way and FORCE frames the other, 10 bit-times per byte, 30 % headroom */
    const double wire = (double)(HG_PUSH_LEN + 5u + 1u + 1u); /* header+CRC, COBS, 0x00 */
    if (i->baud == 0 || i->servo_hz == 0) {
        i->max_loop_period = 1;
        i->max_loop_hz = (double)i->servo_hz;
        return;
    }
    const double hz_max = 0.7 * (double)i->baud / 10.0 / wire;
    unsigned period = hz_max >= 1.0 ? (unsigned)ceil((double)i->servo_hz / floor(hz_max))
                                    : i->servo_hz;
    if (period < 1)
        period = 1;
    while ((double)i->servo_hz / period > hz_max)
        period++;
    i->max_loop_period = period;
    i->max_loop_hz = (double)i->servo_hz / period;
}

int hg_get_info(hg_dev_t *d, hg_dev_info_t *out)
{
    uint8_t b[HG_INFO_LEN];
    if (!d)
        return HG_E_ARG;
    const int r = request(d, HG_MSG_INFO, NULL, 0, b, HG_INFO_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    hg_dev_info_t i;
    memset(&i, 0, sizeof i);
    i.fw_version = hg_get_u16(b);
    i.protocol = b[2];
    i.fpga_id = hg_get_u32(b + 4);
    i.servo_hz = hg_get_u16(b + 8);
    i.link_timeout_ms = hg_get_u16(b + 10);
    i.baud = hg_get_u32(b + 12);
    get_vec(b + 16, i.box_lo);
    get_vec(b + 28, i.box_hi);
    i.f_max_n = get_f32(b + 40);
    i.k_max_n_per_m = get_f32(b + 44);
    i.b_max_ns_per_m = get_f32(b + 48);
    i.ttl_max_ms = hg_get_u16(b + 52);
    i.force_counter = (uint16_t)hg_get_u16(b + 54);
    max_stream(&i);
    pthread_mutex_lock(&d->mu);
    d->info = i;
    d->have_info = 1;
    pthread_mutex_unlock(&d->mu);
    if (out)
        *out = i;
    return HG_OK;
}

int hg_get_state(hg_dev_t *d, hg_dev_state_t *s)
{
    uint8_t b[HG_STATE_LEN];
    if (!d || !s)
        return HG_E_ARG;
    const int r = request(d, HG_MSG_GET_STATE, NULL, 0, b, HG_STATE_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    memset(s, 0, sizeof *s);
    s->seq = hg_get_u32(b);
    pthread_mutex_lock(&d->mu);
    s->t_s = d->info.servo_hz ? (double)s->seq / d->info.servo_hz : 0.0;
    pthread_mutex_unlock(&d->mu);
    get_vec(b + 4, s->p);
    get_vec(b + 16, s->v);
    get_vec(b + 28, s->q);
    get_vec(b + 40, s->f);
    s->flags = b[52];
    s->enabled = (b[52] & HG_FLAG_ENABLED) != 0;
    s->pc_force_live = (b[52] & HG_FLAG_PC_FORCE) != 0;
    s->error = b[53];
    s->error_axis = b[54];
    s->scene = b[55];
    s->fpga_status = hg_get_u32(b + 56);
    return HG_OK;
}

int hg_enable(hg_dev_t *d, int on)
{
    const uint8_t b = on ? 1 : 0;
    return d ? request(d, HG_MSG_ENABLE, &b, HG_ENABLE_LEN, NULL, 0, d->timeout_s) : HG_E_ARG;
}

int hg_set_calib(hg_dev_t *d, unsigned axis, const hg_axis_calib_t *c)
{
    uint8_t q[HG_CALIB_LEN];
    if (!d || !c || axis > 2u || c->comm_offset > 0xFFFFu)
        return HG_E_ARG;
    q[0] = (uint8_t)axis;
    q[1] = c->flags;
    q[2] = (uint8_t)c->enc_dir;
    q[3] = c->phases_swapped;
    q[4] = c->pole_pairs;
    hg_put_u32(q + 5, (uint32_t)c->index_to_zero);
    hg_put_u16(q + 9, c->comm_offset);
    return request(d, HG_MSG_SET_CALIB, q, sizeof q, NULL, 0, d->timeout_s);
}

int hg_get_calib(hg_dev_t *d, unsigned axis, hg_axis_calib_t *out)
{
    uint8_t b[HG_CALIB_LEN];
    if (!d || !out || axis > 2u)
        return HG_E_ARG;
    const uint8_t a = (uint8_t)axis;
    const int r = request(d, HG_MSG_GET_CALIB, &a, HG_GET_CALIB_LEN, b, HG_CALIB_LEN,
                          d->timeout_s);
    if (r != HG_OK)
        return r;
    if (b[0] != a)
        return HG_E_PROTOCOL;
    memset(out, 0, sizeof *out);
    out->flags = b[1];
    out->enc_dir = (int8_t)b[2];
    out->phases_swapped = b[3];
    out->pole_pairs = b[4];
    out->index_to_zero = (int32_t)hg_get_u32(b + 5);
    out->comm_offset = hg_get_u16(b + 9);
    return HG_OK;
}

int hg_read_capture(hg_dev_t *d, unsigned start, unsigned n, uint16_t *words)
{
    if (!d || (!words && n) || start > 0xFFFFu || n > 0x10000u - start)
        return HG_E_ARG;
    for (unsigned got = 0; got < n;) {
        const unsigned k = n - got < HG_CAP_READ_MAX ? n - got : HG_CAP_READ_MAX;
        uint8_t q[HG_CAP_READ_LEN], b[4u + 2u * HG_CAP_READ_MAX];
        hg_put_u16(q, start + got);
        q[2] = (uint8_t)k;
        const int r = request(d, HG_MSG_CAP_READ, q, sizeof q, b, (int)(4u + 2u * k),
                              d->timeout_s);
        if (r != HG_OK)
            return r;
        if (hg_get_u16(b) != start + got || b[2] != k)
            return HG_E_PROTOCOL;
        for (unsigned j = 0; j < k; j++)
            words[got + j] = (uint16_t)hg_get_u16(b + 4 + 2 * j);
        got += k;
    }
    return HG_OK;
}

int hg_bu_start(hg_dev_t *d, unsigned step, unsigned axis, const int expect[3], uint32_t seed,
                int *result, double *value, double *limit)
{
    uint8_t q[HG_BU_START_LEN], b[HG_BU_START_ACK_LEN];
    if (!d || step > 255u || axis > 255u)
        return HG_E_ARG;
    q[0] = (uint8_t)step;
    q[1] = (uint8_t)axis;
    for (int i = 0; i < 3; i++) {
        const int e = expect ? expect[i] : 0;
        if (e < -1 || e > 1)
            return HG_E_ARG;
        q[2 + i] = (uint8_t)(int8_t)e;
    }
    hg_put_u32(q + 5, seed);
    const int r = request(d, HG_MSG_BU_START, q, sizeof q, b, HG_BU_START_ACK_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    if (result)
        *result = b[0];
    if (value)
        *value = get_f32(b + 1);
    if (limit)
        *limit = get_f32(b + 5);
    return HG_OK;
}

int hg_bu_progress(hg_dev_t *d, hg_bu_progress_t *out)
{
    uint8_t b[HG_BU_PROGRESS_LEN];
    if (!d || !out)
        return HG_E_ARG;
    const int r = request(d, HG_MSG_BU_PROGRESS, NULL, 0, b, HG_BU_PROGRESS_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    out->state = b[0];
    out->step = b[1];
    out->axis = b[2];
    out->err = b[3];
    out->ticks = hg_get_u32(b + 4);
    out->tick_limit = hg_get_u32(b + 8);
    out->value = get_f32(b + 12);
    out->limit = get_f32(b + 16);
    out->seq = hg_get_u32(b + 20);
    out->servo_hz = hg_get_u16(b + 24);
    out->t_s = out->servo_hz ? (double)out->ticks / out->servo_hz : 0.0;
    return HG_OK;
}

int hg_bu_abort(hg_dev_t *d)
{
    return d ? request(d, HG_MSG_BU_ABORT, NULL, 0, NULL, 0, d->timeout_s) : HG_E_ARG;
}

int hg_clear_error(hg_dev_t *d)
{
    return d ? request(d, HG_MSG_CLEAR_ERROR, NULL, 0, NULL, 0, d->timeout_s) : HG_E_ARG;
}

int hg_set_scene(hg_dev_t *d, int kind, const double p0[3], const double n[3], double k,
                 double b, double ki)
{
    uint8_t q[HG_SET_SCENE_LEN];
    if (!d || kind < 0 || kind > 255)
        return HG_E_ARG;
    q[0] = (uint8_t)kind;
    for (int i = 0; i < 3; i++) {
        put_f32(q + 1 + 4 * i, p0 ? p0[i] : 0.0);
        put_f32(q + 13 + 4 * i, n ? n[i] : 0.0);
    }
    put_f32(q + 25, k);
    put_f32(q + 29, b);
    put_f32(q + 33, ki);
    return request(d, HG_MSG_SET_SCENE, q, sizeof q, NULL, 0, d->timeout_s);
}

static int take_async_nak(hg_dev_t *d) /* mu held */
{
    if (d->lost)
        return HG_E_LINK_LOST;
    if (d->nak_force) {
        d->nak_force = 0;
        return HG_E_REFUSED;
    }
    return HG_OK;
}

int hg_set_force(hg_dev_t *d, const double f[3], unsigned ttl_ms, uint32_t answers,
                 uint16_t *counter)
{
    uint8_t q[HG_FORCE_LEN];
    if (!d || !f || ttl_ms == 0 || ttl_ms > 0xFFFFu || !isfinite(f[0]) || !isfinite(f[1])
        || !isfinite(f[2]))
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const int r = take_async_nak(d);
    if (r != HG_OK) {
        pthread_mutex_unlock(&d->mu);
        return r;
    }
    const uint16_t ctr = ++d->counter;
    const uint8_t seq = ++d->seq;
    d->sent_any = 1;
    pthread_mutex_unlock(&d->mu);
    for (int i = 0; i < 3; i++)
        put_f32(q + 4 * i, f[i]);
    hg_put_u16(q + 12, ttl_ms);
    hg_put_u16(q + 14, ctr);
    hg_put_u32(q + 16, answers);
    if (counter)
        *counter = ctr;
    return send_frame(d, HG_MSG_FORCE, seq, q, sizeof q);
}

int hg_stream_start(hg_dev_t *d, double rate_hz, double *rate_set)
{
    uint8_t q[HG_STREAM_LEN], a[HG_STREAM_ACK_LEN];
    if (!d || !isfinite(rate_hz))
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const hg_dev_info_t i = d->info;
    pthread_mutex_unlock(&d->mu);
    const double hz = rate_hz > 0 ? rate_hz : i.max_loop_hz;
    if (hz > i.servo_hz)
        return HG_E_ARG;
    unsigned period = (unsigned)lround((double)i.servo_hz / hz);
    if (period < 1)
        period = 1;
    if (period < i.max_loop_period)
        return HG_E_REFUSED;
    hg_put_u16(q, period);
    pthread_mutex_lock(&d->mu);
    d->streaming = 0; /* no silence check until the first push of this stream */
    d->have_push_seq = 0;
    pthread_mutex_unlock(&d->mu);
    const int r = request(d, HG_MSG_STREAM, q, sizeof q, a, HG_STREAM_ACK_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    pthread_mutex_lock(&d->mu);
    d->streaming = 1;
    d->period = period;
    d->last_push = now_mono();
    pthread_mutex_unlock(&d->mu);
    if (rate_set)
        *rate_set = (double)i.servo_hz / period;
    return HG_OK;
}

int hg_stream_stop(hg_dev_t *d)
{
    uint8_t q[HG_STREAM_LEN] = { 0, 0 }, a[HG_STREAM_ACK_LEN];
    if (!d)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    d->streaming = 0;
    pthread_mutex_unlock(&d->mu);
    const int r = request(d, HG_MSG_STREAM, q, sizeof q, a, HG_STREAM_ACK_LEN, d->timeout_s);
    pthread_mutex_lock(&d->mu);
    d->qn = 0;
    pthread_mutex_unlock(&d->mu);
    return r;
}

int hg_next_push(hg_dev_t *d, hg_dev_state_t *out, double timeout_s)
{
    if (!d || !out)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const struct timespec until = deadline(timeout_s);
    int r = take_async_nak(d);
    while (r == HG_OK && d->qn == 0) {
        if (!wait_until(d, &until)) {
            r = d->streaming ? HG_E_LINK_LOST : HG_E_TIMEOUT; /* a stream fell silent */
            break;
        }
        r = take_async_nak(d);
    }
    if (r == HG_OK) {
        *out = d->queue[d->qh];
        d->qh = (d->qh + 1) % QUEUE_N;
        d->qn--;
    }
    pthread_mutex_unlock(&d->mu);
    return r;
}

int hg_latest_push(hg_dev_t *d, hg_dev_state_t *out)
{
    if (!d || !out)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    int r = take_async_nak(d);
    if (r == HG_OK && !d->have_newest)
        r = HG_E_TIMEOUT;
    if (r == HG_OK)
        *out = d->newest;
    pthread_mutex_unlock(&d->mu);
    return r;
}

int hg_wait_push(hg_dev_t *d, uint32_t after, hg_dev_state_t *out, double timeout_s)
{
    if (!d || !out)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const struct timespec until = deadline(timeout_s);
    int r = take_async_nak(d);
    while (r == HG_OK && !(d->have_newest && (int32_t)(d->newest.seq - after) > 0)) {
        if (!wait_until(d, &until)) {
            r = d->streaming ? HG_E_LINK_LOST : HG_E_TIMEOUT;
            break;
        }
        r = take_async_nak(d);
    }
    if (r == HG_OK)
        *out = d->newest;
    pthread_mutex_unlock(&d->mu);
    return r;
}

int hg_get_stats(hg_dev_t *d, hg_dev_stats_t *out)
{
    uint8_t b[HG_STATS2_LEN];
    if (!d || !out)
        return HG_E_ARG;
    const int r = request(d, HG_MSG_GET_STATS, NULL, 0, b, HG_STATS2_LEN, d->timeout_s);
    if (r != HG_OK)
        return r;
    pthread_mutex_lock(&d->mu);
    *out = d->host;
    pthread_mutex_unlock(&d->mu);
    uint32_t *dev_ctr[11] = { &out->good,     &out->bad_framing, &out->bad_crc,  &out->bad_version,
                              &out->bad_type, &out->bad_len,     &out->rejected, &out->replayed,
                              &out->pushed,   &out->push_dropped, &out->timeouts };
    for (int i = 0; i < 11; i++)
        *dev_ctr[i] = hg_get_u32(b + 4 * i);
    return HG_OK;
}

int hg_set_push_hook(hg_dev_t *d, hg_push_hook hook, void *user)
{
    if (!d)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    d->hook = hook;
    d->hook_user = user;
    pthread_mutex_unlock(&d->mu);
    return HG_OK;
}

int hg_write_raw(hg_dev_t *d, const void *bytes, size_t n)
{
    if (!d || (!bytes && n))
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const int lost = d->lost;
    pthread_mutex_unlock(&d->mu);
    return lost ? HG_E_LINK_LOST : write_all(d, bytes, n);
}

/* ---------------------------------------------------------------- open and close */
static speed_t speed_of(uint32_t baud)
{
    switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
#ifdef B460800
    case 460800: return B460800;
#endif
#ifdef B921600
    case 921600: return B921600;
#endif
#ifdef B1000000
    case 1000000: return B1000000;
#endif
#ifdef B2000000
    case 2000000: return B2000000;
#endif
    default: return B0;
    }
}

static int configure(int fd, uint32_t baud)
{
    struct termios t;
    if (!isatty(fd) || tcgetattr(fd, &t) != 0)
        return HG_E_OPEN;
    t.c_iflag &= ~(tcflag_t)(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON
                             | IXOFF);
    t.c_oflag &= ~(tcflag_t)OPOST;
    t.c_lflag &= ~(tcflag_t)(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    t.c_cflag &= ~(tcflag_t)(CSIZE | PARENB | CSTOPB);
    t.c_cflag |= CS8 | CREAD | CLOCAL;
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    const speed_t sp = speed_of(baud);
    if (sp != B0) {
        cfsetispeed(&t, sp);
        cfsetospeed(&t, sp);
    }
    if (tcsetattr(fd, TCSANOW, &t) != 0)
        return HG_E_OPEN;
#ifdef __linux__
    struct serial_struct ss; /* a real UART: no 16 ms receive batching (a pty has none) */
    if (ioctl(fd, TIOCGSERIAL, &ss) == 0) {
        ss.flags |= ASYNC_LOW_LATENCY;
        (void)ioctl(fd, TIOCSSERIAL, &ss);
    }
#endif
    tcflush(fd, TCIFLUSH);
    return HG_OK;
}

static void teardown(hg_dev_t *d)
{
    if (d->rx_started) {
        pthread_mutex_lock(&d->mu);
        d->stop_rx = 1;
        pthread_mutex_unlock(&d->mu);
        pthread_join(d->rx, NULL);
    }
    close(d->fd);
    pthread_mutex_destroy(&d->mu);
    pthread_mutex_destroy(&d->rq);
    pthread_mutex_destroy(&d->wr);
    pthread_cond_destroy(&d->cv);
    free(d->queue);
    free(d);
}

int hg_open(hg_dev_t **out, const char *path, uint32_t baud, double timeout_s)
{
    if (!out || !path || !(timeout_s > 0) || !isfinite(timeout_s))
        return HG_E_ARG;
    *out = NULL;
    hg_dev_t *d = calloc(1, sizeof *d);
    hg_dev_state_t *q = calloc(QUEUE_N, sizeof *q);
    if (!d || !q) {
        free(d);
        free(q);
        return HG_E_NOMEM;
    }
    d->queue = q;
    d->timeout_s = timeout_s;
    d->fd = open(path, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (d->fd < 0) {
        free(q);
        free(d);
        return HG_E_OPEN;
    }
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&d->cv, &ca);
    pthread_condattr_destroy(&ca);
    pthread_mutex_init(&d->mu, NULL);
    pthread_mutex_init(&d->rq, NULL);
    pthread_mutex_init(&d->wr, NULL);
    int r = configure(d->fd, baud);
    if (r == HG_OK)
        r = pthread_create(&d->rx, NULL, rx_main, d) == 0 ? HG_OK : HG_E_NOMEM;
    d->rx_started = r == HG_OK;
    if (r == HG_OK)
        r = hg_get_info(d, NULL);
    if (r == HG_OK) /* a stream left running by an earlier client, and forces off */
        r = hg_stream_stop(d);
    if (r == HG_OK)
        r = hg_enable(d, 0);
    if (r != HG_OK) {
        teardown(d);
        return r;
    }
    d->counter = d->info.force_counter;
    *out = d;
    return HG_OK;
}

int hg_close(hg_dev_t *d)
{
    if (!d)
        return HG_E_ARG;
    hg_loop_stop(d, NULL);
    int r = hg_stream_stop(d);
    if (r == HG_OK)
        r = hg_enable(d, 0);
    hg_dev_state_t s = { 0 };
    if (r == HG_OK)
        r = hg_get_state(d, &s);
    const uint32_t s0 = s.seq;
    const struct timespec t0 = now_mono();
    while (r == HG_OK) { /* one whole tick with the servo disabled */
        r = hg_get_state(d, &s);
        if (r == HG_OK && s.seq - s0 >= 2u && hg_torque_zero(&s))
            break;
        if (r == HG_OK && since(t0) > d->timeout_s)
            r = HG_E_TIMEOUT;
    }
    teardown(d);
    return r;
}

/* ---------------------------------------------------------------- the servo loop */
static void *loop_main(void *arg)
{
    hg_dev_t *d = arg;
    int status = HG_OK, have = 0;
    uint32_t last = 0;
    pthread_mutex_lock(&d->mu);
    const double f_max = d->info.f_max_n;
    for (;;) {
        struct timespec until = deadline(d->timeout_s);
        while (!d->loop_stop && !d->lost && !(d->have_newest && (!have || d->newest.seq != last)))
            if (!wait_until(d, &until)) /* the reader judges silence; wait on */
                until = deadline(d->timeout_s);
        if (d->loop_stop || d->lost) {
            status = d->lost ? HG_E_LINK_LOST : HG_OK;
            break;
        }
        const hg_dev_state_t s = d->newest;
        have = 1;
        last = s.seq;
        pthread_mutex_unlock(&d->mu);
        if (s.error) {
            pthread_mutex_lock(&d->mu);
            status = HG_E_FAULT;
            break;
        }
        double f[3] = { 0.0, 0.0, 0.0 };
        const int done = d->fn(&s, f, d->user);
        if (done) {
            pthread_mutex_lock(&d->mu);
            break;
        }
        if (!isfinite(f[0]) || !isfinite(f[1]) || !isfinite(f[2])) {
            pthread_mutex_lock(&d->mu);
            status = HG_E_ARG;
            break;
        }
        const double mag = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
        const int clamp = mag > F_SCALE * f_max;
        if (clamp)
            for (int i = 0; i < 3; i++)
                f[i] *= F_SCALE * f_max / mag;
        const int r = hg_set_force(d, f, d->ttl_ms, s.seq, NULL);
        pthread_mutex_lock(&d->mu);
        if (r != HG_OK) {
            status = r;
            break;
        }
        if (d->ls.calls > 0) { /* the states the forces answered: intervals, missed ticks */
            const uint32_t gap = s.seq - d->last_seq;
            hist_add(&d->ivl, gap);
            if (gap > d->period)
                d->ls.missed_ticks += gap / d->period - 1u;
        } else {
            d->first_seq = s.seq;
        }
        d->ls.calls++;
        d->ls.clamped += (uint64_t)clamp;
        d->last_seq = s.seq;
    }
    d->ls.status = status;
    d->ls.running = 0;
    pthread_cond_broadcast(&d->cv);
    pthread_mutex_unlock(&d->mu);
    return NULL;
}

/* Real-time priority for a servo thread, as HDAPI's scheduler has: granted to root or with
 * CAP_SYS_NICE / an rtprio limit, else the thread keeps its normal priority. 1 if granted. */
static int realtime(pthread_t t, int on)
{
    struct sched_param sp;
    memset(&sp, 0, sizeof sp);
    sp.sched_priority = on ? RT_PRIO : 0;
    return pthread_setschedparam(t, on ? SCHED_FIFO : SCHED_OTHER, &sp) == 0 && on;
}

int hg_loop_start(hg_dev_t *d, double rate_hz, unsigned ttl_ms, hg_loop_fn fn, void *user)
{
    if (!d || !fn || ttl_ms == 0 || ttl_ms > 0xFFFFu)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    const int busy = d->ls.running;
    pthread_mutex_unlock(&d->mu);
    if (busy)
        return HG_E_BUSY;
    if (d->loop_started) { /* an ended loop not yet collected */
        pthread_join(d->loop, NULL);
        d->loop_started = 0;
    }
    double rate = 0.0;
    const int r = hg_stream_start(d, rate_hz, &rate);
    if (r != HG_OK)
        return r;
    pthread_mutex_lock(&d->mu);
    memset(&d->ls, 0, sizeof d->ls);
    memset(&d->ivl, 0, sizeof d->ivl);
    memset(&d->lat, 0, sizeof d->lat);
    d->have_lat_ctr = 0;
    d->ls.running = 1;
    d->ls.rate_hz = rate;
    d->loop_stop = 0;
    d->fn = fn;
    d->user = user;
    d->ttl_ms = ttl_ms;
    pthread_mutex_unlock(&d->mu);
    if (pthread_create(&d->loop, NULL, loop_main, d) != 0) {
        pthread_mutex_lock(&d->mu);
        d->ls.running = 0;
        pthread_mutex_unlock(&d->mu);
        return HG_E_NOMEM;
    }
    d->loop_started = 1;
    const int rt = realtime(d->loop, 1) & realtime(d->rx, 1);
    pthread_mutex_lock(&d->mu);
    d->ls.realtime = rt;
    pthread_mutex_unlock(&d->mu);
    return HG_OK;
}

int hg_loop_get_stats(hg_dev_t *d, hg_loop_stats_t *st)
{
    if (!d || !st)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    *st = d->ls;
    const double tick_ms = d->info.servo_hz ? 1e3 / d->info.servo_hz : (double)NAN;
    st->device_s = st->calls > 0 ? (double)(d->last_seq - d->first_seq) * tick_ms * 1e-3 : 0.0;
    st->achieved_hz = st->device_s > 0 ? (double)(st->calls - 1) / st->device_s : 0.0;
    hist_pct(&d->ivl, tick_ms, st->interval_ms);
    hist_pct(&d->lat, tick_ms, st->latency_ms);
    st->latency_n = d->lat.n;
    pthread_mutex_unlock(&d->mu);
    return HG_OK;
}

int hg_loop_stop(hg_dev_t *d, hg_loop_stats_t *st)
{
    if (!d)
        return HG_E_ARG;
    pthread_mutex_lock(&d->mu);
    d->loop_stop = 1;
    pthread_cond_broadcast(&d->cv);
    pthread_mutex_unlock(&d->mu);
    if (d->loop_started) {
        pthread_join(d->loop, NULL);
        d->loop_started = 0;
        realtime(d->rx, 0); /* the reader back to normal between loops */
    }
    hg_loop_stats_t tmp;
    hg_loop_get_stats(d, st ? st : &tmp);
    return st ? st->status : tmp.status;
}
