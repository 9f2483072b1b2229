/* SPDX-License-Identifier: Apache-2.0 */
/* hg-wall: a virtual wall computed on the PC in C, rendered at 1 kHz through the hapgate
 * library's servo loop (docs/native-host.md). The C twin of `python -m hapgate.host.example_wall`.
 *
 *     hg-wall PORT [--duration S] [--k N/m] [--b Ns/m] [--depth-mm MM] [--rate HZ]
 *                  [--ttl-ms MS] [--baud B] [--timeout S] [--csv FILE]
 *
 * PORT is the `port:` line of `hapgate device serve`, or a board's serial device. The wall is
 * the plane depth_mm below where the handle rests (normal -y: free space below), F = n max(0,
 * k d - b v.n) for depth d > 0, the firmware's own WALL law. The hand resting on the handle
 * holds it in the wall. Prints the loop's figures in device time; --csv writes every state
 * the callback saw with the force it returned (the loop's forces carry consecutive counters
 * from first_counter on). Exit 0, 1 on a device or link error, 2 on bad arguments. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "hapgate.h"

typedef struct {
    hg_dev_state_t s;
    double cmd[3];
} row_t;

typedef struct {
    double p0[3], n[3], k, b, duration_s, f_max;
    row_t *rows;
    size_t n_rows, cap;
    double t0;
    int have_t0;
} wall_t;

/* The servo callback: no allocation, no I/O. */
static int wall_cb(const hg_dev_state_t *s, double f[3], void *user)
{
    wall_t *w = user;
    if (!w->have_t0) {
        w->t0 = s->t_s;
        w->have_t0 = 1;
    }
    double depth = 0.0, vn = 0.0;
    for (int i = 0; i < 3; i++) {
        depth += (w->p0[i] - s->p[i]) * w->n[i];
        vn += s->v[i] * w->n[i];
    }
    const double mag = depth > 0.0 ? fmax(0.0, w->k * depth - w->b * vn) : 0.0;
    for (int i = 0; i < 3; i++)
        f[i] = mag * w->n[i];
    if (mag > 0.999 * w->f_max) /* the device refuses more than f_max */
        for (int i = 0; i < 3; i++)
            f[i] *= 0.999 * w->f_max / mag;
    if (w->n_rows < w->cap) {
        w->rows[w->n_rows].s = *s;
        memcpy(w->rows[w->n_rows].cmd, f, sizeof w->rows[w->n_rows].cmd);
        w->n_rows++;
    }
    return s->t_s - w->t0 >= w->duration_s;
}

static int usage(const char *why)
{
    fprintf(stderr, "hg-wall: %s\nusage: hg-wall PORT [--duration S] [--k N/m] [--b Ns/m] "
            "[--depth-mm MM] [--rate HZ] [--ttl-ms MS] [--baud B] [--timeout S] [--csv FILE]\n",
            why);
    return 2;
}

static int num(const char *name, const char *s, double lo, double hi, double *out)
{
    char *end = NULL;
    const double v = s ? strtod(s, &end) : (double)NAN;
    if (!s || end == s || *end || !(v >= lo && v <= hi)) {
        fprintf(stderr, "hg-wall: %s %s: expected a number in [%g, %g]\n", name, s ? s : "",
                lo, hi);
        return 0;
    }
    *out = v;
    return 1;
}

/* Write the rows; a path that exists and is not a regular file is refused. */
static int write_csv(const char *path, const wall_t *w, uint16_t first_counter)
{
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        fprintf(stderr, "hg-wall: --csv %s: not a regular file\n", path);
        return 2;
    }
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "hg-wall: --csv %s: cannot write it\n", path);
        return 2;
    }
    fprintf(f, "# first_counter=%u p0=%.17g,%.17g,%.17g\nseq,px,py,pz,vx,vy,vz,fx,fy,fz,ctr,lat,live,enabled,"
               "c0,c1,c2,cmd_fx,cmd_fy,cmd_fz\n", (unsigned)first_counter, w->p0[0], w->p0[1],
            w->p0[2]);
    for (size_t i = 0; i < w->n_rows; i++) {
        const hg_dev_state_t *s = &w->rows[i].s;
        const double *c = w->rows[i].cmd;
        fprintf(f, "%lu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%u,%u,%d,%d,%d,%d,%d,"
                   "%.17g,%.17g,%.17g\n", (unsigned long)s->seq, s->p[0], s->p[1], s->p[2],
                s->v[0], s->v[1], s->v[2], s->f[0], s->f[1], s->f[2],
                (unsigned)s->force_counter, (unsigned)s->force_latency_ticks, s->pc_force_live,
                s->enabled, s->code[0], s->code[1], s->code[2], c[0], c[1], c[2]);
    }
    if (ferror(f) | (fclose(f) != 0)) {
        fprintf(stderr, "hg-wall: --csv %s: write failed (disk full?)\n", path);
        remove(path);
        return 2;
    }
    return 0;
}

int main(int argc, char **argv)
{
    double duration = 2.0, k = 2000.0, b = 10.0, depth_mm = 1.0, rate = 0.0, ttl = 10.0;
    double baud = 1e6, timeout = 5.0;
    const char *port = NULL, *csv = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int ok = 1;
        if (!strcmp(a, "--duration")) ok = num(a, v, 1e-3, 3600.0, &duration), i++;
        else if (!strcmp(a, "--k")) ok = num(a, v, 0.0, 3500.0, &k), i++;
        else if (!strcmp(a, "--b")) ok = num(a, v, 0.0, 100.0, &b), i++;
        else if (!strcmp(a, "--depth-mm")) ok = num(a, v, -50.0, 50.0, &depth_mm), i++;
        else if (!strcmp(a, "--rate")) ok = num(a, v, 0.0, 1e5, &rate), i++;
        else if (!strcmp(a, "--ttl-ms")) ok = num(a, v, 1.0, 65535.0, &ttl), i++;
        else if (!strcmp(a, "--baud")) ok = num(a, v, 0.0, 12e6, &baud), i++;
        else if (!strcmp(a, "--timeout")) ok = num(a, v, 0.01, 600.0, &timeout), i++;
        else if (!strcmp(a, "--csv")) { if (!v) return usage("--csv needs a FILE"); csv = v; i++; }
        else if (a[0] == '-') return usage("unknown option");
        else if (!port) port = a;
        else return usage("one PORT only");
        if (!ok)
            return 2;
    }
    if (!port)
        return usage("PORT is missing");

    hg_dev_t *dev = NULL;
    hg_dev_info_t info;
    hg_dev_state_t rest;
    int r = hg_open(&dev, port, (uint32_t)baud, timeout);
    if (r != HG_OK) {
        fprintf(stderr, "hg-wall: %s: %s\n", port, hg_strerror(r));
        return r == HG_E_OPEN ? 2 : 1;
    }
    wall_t w = { .n = { 0.0, -1.0, 0.0 }, .k = k, .b = b, .duration_s = duration };
    r = hg_get_info(dev, &info);
    if (r == HG_OK)
        r = hg_get_state(dev, &rest);
    if (r == HG_OK) {
        printf("device: firmware %u.%u, protocol %u, servo %u Hz, link %lu baud -> loop at most "
               "%.0f Hz\n", info.fw_version >> 8, info.fw_version & 0xFFu, info.protocol,
               info.servo_hz, (unsigned long)info.baud, info.max_loop_hz);
        for (int i = 0; i < 3; i++)
            w.p0[i] = rest.p[i] + w.n[i] * depth_mm * 1e-3;
        w.f_max = info.f_max_n;
        w.cap = (size_t)(duration * info.servo_hz) + 64;
        w.rows = calloc(w.cap, sizeof *w.rows);
        if (!w.rows)
            r = HG_E_NOMEM;
    }
    if (r == HG_OK)
        r = hg_set_scene(dev, HG_SCENE_PC_FORCE, NULL, NULL, 0.0, 0.0, 0.0);
    if (r == HG_OK)
        r = hg_enable(dev, 1);
    hg_dev_info_t before;
    if (r == HG_OK)
        r = hg_get_info(dev, &before); /* the counter the loop's first force follows */
    const struct timespec wall0 = { 0, 0 };
    struct timespec t0 = wall0, t1 = wall0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (r == HG_OK)
        r = hg_loop_start(dev, rate, (unsigned)ttl, wall_cb, &w);
    hg_loop_stats_t ls;
    memset(&ls, 0, sizeof ls);
    if (r == HG_OK) {
        do { /* the loop runs on its own thread; this one only watches */
            const struct timespec nap = { 0, 10000000L };
            nanosleep(&nap, NULL);
            hg_loop_get_stats(dev, &ls);
        } while (ls.running);
        r = hg_loop_stop(dev, &ls);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    hg_dev_stats_t st;
    memset(&st, 0, sizeof st);
    if (r == HG_OK)
        r = hg_enable(dev, 0);
    if (r == HG_OK)
        r = hg_get_stats(dev, &st);
    const int rc = hg_close(dev);
    if (r == HG_OK)
        r = rc;
    if (r != HG_OK) {
        fprintf(stderr, "hg-wall: %s: %s\n", port, hg_strerror(r));
        free(w.rows);
        return 1;
    }
    const double wall_s = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    printf("loop rate      %8.1f Hz  (stream %.0f Hz; %llu forces over %.3f s device time, "
           "%.2f s wall)\n", ls.achieved_hz, ls.rate_hz, (unsigned long long)ls.calls,
           ls.device_s, wall_s);
    printf("loop interval  p50 %.3f  p99 %.3f  max %.3f ms (device time); missed ticks %llu; "
           "real-time priority %s\n", ls.interval_ms[0], ls.interval_ms[1], ls.interval_ms[2],
           (unsigned long long)ls.missed_ticks, ls.realtime ? "yes" : "no");
    printf("loop latency   p50 %.3f  p99 %.3f  max %.3f ms (device time, state tick -> force's "
           "first tick; %llu forces)\n", ls.latency_ms[0], ls.latency_ms[1], ls.latency_ms[2],
           (unsigned long long)ls.latency_n);
    printf("device link counters: good %u bad %u replayed %u pushed %u push_dropped %u "
           "timeouts %u; host: pushes %llu gaps %u bad %u\n", st.good,
           st.bad_framing + st.bad_crc + st.bad_version + st.bad_type + st.bad_len, st.replayed,
           st.pushed, st.push_dropped, st.timeouts, (unsigned long long)st.pushes, st.push_gaps,
           st.host_bad_framing + st.host_bad_crc + st.host_bad_version);
    int out = 0;
    if (csv)
        out = write_csv(csv, &w, (uint16_t)(before.force_counter + 1u));
    free(w.rows);
    return out;
}
