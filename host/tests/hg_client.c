/* SPDX-License-Identifier: Apache-2.0 */
/* hg-client: scripted uses of the hapgate C library, for tb/host_c against the virtual device
 * (built with ASan+UBSan). Each mode prints CSV-like lines the test parses.
 *
 *     hg-client ttl PORT N TTL_MS       N forces (0,-1,0) N answering pushes, then 60 pushes
 *     hg-client garbage PORT SEED       20 bursts of broken frames while streaming
 *     hg-client loop PORT               a 1 kHz loop of zero force until it stops by itself
 *     hg-client reconnect PORT TICKS    open, state, then TICKS pushes of an unenabled stream
 *
 * Lines: "P,seq,ctr,live,enabled,c0,c1,c2,fx,fy,fz" per push; "LAST,ctr"; "STATS,name,value";
 * "STATE,enabled,error"; "STATUS,code,text". Exit 0 when the mode ran to its end, 1 when a
 * call failed (STATUS says which), 2 on bad arguments. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hapgate.h"
#include "hg_frame.h"

#define TIMEOUT_S 10.0

static int status(int r)
{
    printf("STATUS,%d,%s\n", r, hg_strerror(r));
    return r == HG_OK ? 0 : 1;
}

static void print_push(const hg_dev_state_t *s)
{
    printf("P,%lu,%u,%d,%d,%d,%d,%d,%.9g,%.9g,%.9g\n", (unsigned long)s->seq,
           (unsigned)s->force_counter, s->pc_force_live, s->enabled, s->code[0], s->code[1],
           s->code[2], s->f[0], s->f[1], s->f[2]);
}

static void print_stats(const hg_dev_stats_t *st)
{
    printf("STATS,good,%u\nSTATS,bad_framing,%u\nSTATS,bad_crc,%u\nSTATS,bad_version,%u\n"
           "STATS,bad_type,%u\nSTATS,bad_len,%u\nSTATS,rejected,%u\nSTATS,replayed,%u\n"
           "STATS,timeouts,%u\nSTATS,host_bad,%u\n", st->good, st->bad_framing, st->bad_crc,
           st->bad_version, st->bad_type, st->bad_len, st->rejected, st->replayed, st->timeouts,
           st->host_bad_framing + st->host_bad_crc + st->host_bad_version);
}

static int mode_ttl(hg_dev_t *d, int n, unsigned ttl)
{
    hg_dev_state_t s;
    const double f[3] = { 0.0, -1.0, 0.0 };
    uint16_t last = 0;
    int r = hg_set_scene(d, HG_SCENE_PC_FORCE, NULL, NULL, 0, 0, 0);
    if (r == HG_OK)
        r = hg_enable(d, 1);
    if (r == HG_OK)
        r = hg_stream_start(d, 1000.0, NULL);
    for (int i = 0; r == HG_OK && i < n; i++) {
        r = hg_next_push(d, &s, TIMEOUT_S);
        if (r == HG_OK)
            r = hg_set_force(d, f, ttl, s.seq, &last);
    }
    printf("LAST,%u\n", (unsigned)last);
    for (int i = 0; r == HG_OK && i < 60; i++) {
        r = hg_next_push(d, &s, TIMEOUT_S);
        if (r == HG_OK)
            print_push(&s);
    }
    return r;
}

/* A valid v2 FORCE frame, built here so that the bursts can break it. */
static size_t force_frame(uint8_t *out, uint8_t seq, uint16_t ctr)
{
    uint8_t q[HG_FORCE_LEN] = { 0 };
    const float fy = -8.0f;
    memcpy(q + 4, &fy, 4);
    q[12] = 100;
    q[14] = (uint8_t)ctr;
    q[15] = (uint8_t)(ctr >> 8);
    return hg_frame_encode(HG_PROTO_VERSION, HG_MSG_FORCE, seq, q, sizeof q, out);
}

static int mode_garbage(hg_dev_t *d, unsigned seed)
{
    hg_dev_stats_t before, after;
    hg_dev_state_t s;
    srand(seed);
    int r = hg_set_scene(d, HG_SCENE_PC_FORCE, NULL, NULL, 0, 0, 0);
    if (r == HG_OK)
        r = hg_enable(d, 1);
    if (r == HG_OK)
        r = hg_get_stats(d, &before);
    if (r == HG_OK)
        r = hg_stream_start(d, 1000.0, NULL);
    for (int burst = 0; r == HG_OK && burst < 20; burst++) {
        uint8_t junk[200], frame[HG_LINK_MAX_FRAME];
        size_t n = 0;
        junk[n++] = 0;
        const size_t m = force_frame(frame, (uint8_t)burst, (uint16_t)(60000u + (unsigned)burst));
        switch (burst % 3) {
        case 0: /* random bytes, no delimiter inside */
            for (int i = 5 + rand() % 100; i > 0; i--)
                junk[n++] = (uint8_t)(1 + rand() % 255);
            break;
        case 1: { /* a strong force with a flipped bit (never a zero byte) */
            const size_t at = (size_t)rand() % (m - 1);
            frame[at] ^= (uint8_t)(1u << (rand() % 8));
            if (!frame[at])
                frame[at] = 1;
            memcpy(junk + n, frame, m - 1);
            n += m - 1;
            break;
        }
        default: /* truncated */
            memcpy(junk + n, frame, m / 2);
            n += m / 2;
        }
        junk[n++] = 0;
        r = hg_write_raw(d, junk, n);
        for (int i = 0; r == HG_OK && i < 5; i++) {
            r = hg_next_push(d, &s, TIMEOUT_S);
            if (r == HG_OK)
                print_push(&s);
        }
    }
    if (r == HG_OK)
        r = hg_get_stats(d, &after);
    if (r == HG_OK)
        r = hg_get_state(d, &s); /* resynchronised: requests are answered */
    if (r == HG_OK) {
        printf("STATE,%d,%d\n", s.enabled, s.error);
        printf("BEFORE\n");
        print_stats(&before);
        printf("AFTER\n");
        print_stats(&after);
    }
    return r;
}

static int zero_force(const hg_dev_state_t *s, double f[3], void *user)
{
    (void)s, (void)user;
    f[0] = f[1] = f[2] = 0.0;
    return 0;
}

static int mode_loop(hg_dev_t *d)
{
    hg_loop_stats_t ls;
    int r = hg_set_scene(d, HG_SCENE_PC_FORCE, NULL, NULL, 0, 0, 0);
    if (r == HG_OK)
        r = hg_enable(d, 1);
    if (r == HG_OK)
        r = hg_loop_start(d, 1000.0, 10, zero_force, NULL);
    if (r != HG_OK)
        return r;
    printf("RUNNING\n");
    fflush(stdout);
    do {
        hg_dev_state_t s;
        hg_wait_push(d, 0, &s, 0.05);
        hg_loop_get_stats(d, &ls);
    } while (ls.running);
    const int loop = hg_loop_stop(d, &ls);
    printf("LOOP,%d,%llu\n", loop, (unsigned long long)ls.calls);
    hg_dev_state_t s;
    printf("AFTER,%d\n", hg_get_state(d, &s)); /* every call now reports the loss */
    return loop;
}

static int mode_reconnect(hg_dev_t *d, int ticks)
{
    hg_dev_state_t s;
    int r = hg_get_state(d, &s);
    if (r == HG_OK)
        printf("STATE,%d,%d\n", s.enabled, s.error);
    if (r == HG_OK)
        r = hg_stream_start(d, 1000.0, NULL);
    for (int i = 0; r == HG_OK && i < ticks; i++) {
        r = hg_next_push(d, &s, TIMEOUT_S);
        if (r == HG_OK)
            print_push(&s);
    }
    return r;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: hg-client ttl|garbage|loop|reconnect PORT ...\n");
        return 2;
    }
    const char *mode = argv[1];
    hg_dev_t *d = NULL;
    int r = hg_open(&d, argv[2], 1000000, TIMEOUT_S);
    if (r != HG_OK)
        return status(r);
    if (!strcmp(mode, "ttl") && argc == 5)
        r = mode_ttl(d, atoi(argv[3]), (unsigned)atoi(argv[4]));
    else if (!strcmp(mode, "garbage") && argc == 4)
        r = mode_garbage(d, (unsigned)atoi(argv[3]));
    else if (!strcmp(mode, "loop") && argc == 3)
        r = mode_loop(d);
    else if (!strcmp(mode, "reconnect") && argc == 4)
        r = mode_reconnect(d, atoi(argv[3]));
    else {
        hg_close(d);
        fprintf(stderr, "hg-client: bad mode or arguments\n");
        return 2;
    }
    const int c = hg_close(d);
    fflush(stdout);
    return status(r != HG_OK ? r : c);
}
