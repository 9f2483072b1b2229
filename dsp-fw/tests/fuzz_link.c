/* SPDX-License-Identifier: Apache-2.0 */
/* PC-link fuzz (built with ASan + UBSan): random and mutated frames into the byte parser.
 * Every chunk between delimiters is classified by an independent reference (its own COBS
 * decoder and the protocol table of README.md); the link's counters must match the reference
 * after every chunk, a bad chunk must produce no reply and leave the servo bit-identical,
 * a good one exactly one reply with its seq. Bring-up is reachable (its messages start and
 * abort steps, stepped in place of the servo while one runs) and must stay bit-identical too.
 * Usage: fuzz_link [frames] [seed] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "hal_sim.h"
#include "hg_fpga_regs.h"
#include "hg_frame.h"
#include "hg_link.h"

enum { GOOD, FRAMING, CRC, VERSION, TYPE, LEN, NCLASS };
static const char *const NAMES[NCLASS] = { "good", "framing", "crc", "version", "type", "len" };

static uint64_t rng = 0x9E3779B97F4A7C15u;
static uint32_t rnd(void) /* xorshift64* */
{
    rng ^= rng >> 12;
    rng ^= rng << 25;
    rng ^= rng >> 27;
    return (uint32_t)((rng * 0x2545F4914F6CDD1Du) >> 32);
}

/* request data length per type and version, from the protocol table; -1 = unknown type */
static int ref_len(uint8_t version, uint8_t type)
{
    static const int len[19] = { -1, 0, 0, 12, 37, 1, 0, 0, 0, 2, 20, 11, 1, 9, 0, 2, 2, 0, 3 };
    if (version == 1 && type >= 8)
        return -1; /* the version-2 messages do not exist in version 1 */
    return type < 19 ? len[type] : -1;
}

static int ref_classify(const uint8_t *e, size_t n, uint8_t *seq, uint8_t *type)
{
    uint8_t raw[1024];
    size_t o = 0;
    if (n > HG_LINK_MAX_FRAME)
        return FRAMING;
    for (size_t i = 0; i < n;) { /* COBS, written out again from the definition */
        const size_t code = e[i++];
        if (code == 0 || i + code - 1 > n)
            return FRAMING;
        for (size_t j = 1; j < code; j++)
            raw[o++] = e[i++];
        if (code < 0xFF && i < n)
            raw[o++] = 0;
    }
    if (o < 5 || o > HG_LINK_MAX_RAW)
        return FRAMING;
    if (hg_crc16(raw, o - 2) != (raw[o - 2] << 8 | raw[o - 1]))
        return CRC;
    if (raw[0] != 1 && raw[0] != 2)
        return VERSION;
    if (ref_len(raw[0], raw[1]) < 0)
        return TYPE;
    if ((int)o - 5 != ref_len(raw[0], raw[1]))
        return LEN;
    *seq = raw[2];
    *type = raw[1];
    return GOOD;
}

/* A raw frame: mostly well-formed requests (random data, or plausible floats), then broken
 * in one of several ways. want = the class a mutation guarantees, -1 if only the reference
 * knows. Returns the encoded length (delimiter not included). */
static size_t make_chunk(uint8_t *out, int *want)
{
    static const uint8_t types[] = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17,
                                     18 };
    uint8_t raw[HG_LINK_MAX_RAW + 8];
    const uint8_t type = types[rnd() % 18];
    const uint8_t ver = type >= 8 ? 2 : (uint8_t)(1 + rnd() % 2);
    size_t n = 3 + (size_t)ref_len(ver, type);
    raw[0] = ver;
    raw[1] = type;
    raw[2] = (uint8_t)rnd();
    for (size_t i = 3; i < n; i++)
        raw[i] = (uint8_t)rnd();
    if (type == 3 || type == 4 || type == 10) /* often small finite floats: some accepted */
        for (size_t i = (type == 4 ? 4 : 3); i + 3 < n && i < 15 && rnd() % 2; i += 4) {
            const float f = (float)((int)(rnd() % 2001) - 1000) / 1000.0f;
            memcpy(raw + i, &f, 4);
        }
    if (type == 4)
        raw[3] = (uint8_t)(rnd() % 6);
    if (type == 5)
        raw[3] = (uint8_t)(rnd() % 3);
    if (type == 11 || type == 12) /* calibration: axis mostly in range, valid fields often */
        raw[3] = (uint8_t)(rnd() % 4);
    if (type == 11 && rnd() % 2) {
        raw[4] = (uint8_t)(rnd() % 4 ? 3 : rnd() % 8); /* mostly homed and aligned */
        raw[5] = rnd() % 2 ? 1 : 0xFF;
        raw[6] = (uint8_t)(rnd() % 2);
        raw[7] = 2;
        raw[13] = (uint8_t)(rnd() % 4);
    }
    if (type == 13) { /* BU_START: a valid step, axis and expectation often */
        raw[3] = (uint8_t)(rnd() % 7);
        raw[4] = (uint8_t)(rnd() % 4);
        for (int i = 5; i < 8 && rnd() % 2; i++)
            raw[i] = (uint8_t)(rnd() % 3 == 0 ? 0xFF : rnd() % 2);
    }
    if (type == 15 || type == 16) { /* BU_RESULT / BU_CHECK: axis, page or check in range */
        raw[3] = (uint8_t)(rnd() % 4);
        raw[4] = (uint8_t)(rnd() % (type == 15 ? 5 : 12));
    }
    if (type == 18) { /* CAP_READ: a range inside a small buffer often */
        raw[3] = (uint8_t)(rnd() % 40);
        raw[4] = (uint8_t)(rnd() % 2 ? 0 : rnd());
        raw[5] = (uint8_t)(rnd() % 33);
    }
    if (type == 9) /* stream period: mostly in range */
        raw[4] = (uint8_t)(rnd() % 5);
    if (type == 10 && rnd() % 2) { /* FORCE: a valid TTL and a newer counter half the time */
        static uint16_t ctr;
        ctr = (uint16_t)(ctr + 1 + rnd() % 3);
        raw[15] = (uint8_t)(1 + rnd() % 100);
        raw[16] = 0;
        raw[17] = (uint8_t)ctr;
        raw[18] = (uint8_t)(ctr >> 8);
    }
    const uint32_t kind = rnd() % 8;
    *want = kind <= 1 ? GOOD : -1;
    if (kind == 5) { /* wrong version, unknown type or wrong length under a valid CRC */
        const uint32_t w = rnd() % 3;
        if (w == 0) {
            raw[0] = (uint8_t)(3 + rnd() % 253); /* versions 3..255; 0 comes with garbage */
            *want = VERSION;
        } else if (w == 1) {
            raw[1] = (uint8_t)(19 + rnd() % 237);
            *want = TYPE;
        } else {
            size_t nn;
            do
                nn = 3 + rnd() % 41;
            while (nn == n);
            n = nn;
            *want = LEN;
        }
    }
    const uint16_t crc = hg_crc16(raw, n);
    raw[n] = (uint8_t)(crc >> 8);
    raw[n + 1] = (uint8_t)crc;
    n += 2;
    if (kind == 2) { /* one burst of <= 16 bits: CRC-16 detects every one */
        const size_t bit = rnd() % (8 * n - 15);
        const unsigned len = 1 + rnd() % 16;
        const uint32_t b = (rnd() & ((1u << len) - 1)) | 1u | 1u << (len - 1);
        for (unsigned k = 0; k < len; k++)
            if (b >> k & 1)
                raw[(bit + k) / 8] ^= (uint8_t)(0x80u >> ((bit + k) % 8));
        *want = CRC;
    }
    size_t m = hg_cobs_encode(raw, n, out, 256);
    if (kind == 3) { /* random garbage chunk, possibly over-long */
        m = 1 + rnd() % 100;
        for (size_t i = 0; i < m; i++)
            out[i] = (uint8_t)(1 + rnd() % 255);
    } else if (kind >= 6 && m > 1) { /* damage the encoded bytes */
        const size_t at = rnd() % m;
        switch (rnd() % 4) {
        case 0: out[at] ^= (uint8_t)(1u << (rnd() % 8)); break;          /* may become 0x00 */
        case 1: m = at ? at : 1; break;                                     /* truncate */
        case 2: memmove(out + at, out + at + 1, m - at - 1); m--; break;    /* drop a byte */
        default: memmove(out + at + 1, out + at, m - at); out[at] = (uint8_t)rnd(); m++; break;
        }
    }
    return m;
}

int main(int argc, char **argv)
{
    const long frames = argc > 1 ? atol(argv[1]) : 1000000;
    rng ^= (uint64_t)(argc > 2 ? atol(argv[2]) : 1) * 0x100000001B3u;
    hg_servo_t s;
    hg_link_t l;
    hg_servo_cfg_t cfg;
    hg_servo_default_cfg(&cfg);
    hal_sim_reset();
    hg_servo_init(&s, &cfg);
    hg_link_init(&l, &s);
    static hg_bringup_t bu; /* bring-up reachable: its messages act (steps start, abort) */
    hg_bringup_cfg_t bc;
    hg_bringup_default_cfg(&bc);
    hg_bringup_init(&bu, &s, &bc, NULL);
    l.bu = &bu;

    uint32_t count[NCLASS] = { 0 };
    long chunks = 0, bytes = 0, replies = 0, naks = 0, fails = 0, pushes = 0;
    const int32_t pos[3] = { 0, 131072, 131072 }, vel[3] = { 0 }; /* q = (0, 45, 45) deg */
    const clock_t t0 = clock();
    for (long f = 0; f < frames && fails < 10; f++) {
        if (f % 64 == 0) { /* keep the servo running; clear anything it latched */
            hal_sim_snapshot(pos, vel);
            if (hg_bringup_active(&bu)) /* the ISR's choice (hg_bringup_isr) */
                hg_bringup_step(&bu);
            else
                hg_servo_step(&s);
            uint8_t tx[HG_LINK_MAX_FRAME], raw[HG_LINK_MAX_RAW];
            const size_t r = hg_link_poll(&l, rnd() % 4 != 0, tx);
            if (r) { /* a push is a well-formed version-2 STATE_PUSH */
                const size_t rn = hg_cobs_decode(tx, r - 1, raw, sizeof raw);
                pushes++;
                if (rn != HG_PUSH_LEN + 5 || raw[0] != 2 || raw[1] != HG_MSG_STATE_PUSH
                    || hg_crc16(raw, rn - 2) != (uint16_t)(raw[rn - 2] << 8 | raw[rn - 1])) {
                    printf("FAIL frame %ld: malformed push\n", f);
                    fails++;
                }
            }
        }
        uint8_t buf[512];
        int want;
        const size_t m = make_chunk(buf, &want);
        buf[m] = 0;
        size_t start = 0;
        for (size_t i = 0; i <= m; i++) {
            if (buf[i] != 0)
                continue;
            const size_t len = i - start;
            uint8_t seq = 0, type = 0;
            const int cls = len ? ref_classify(buf + start, len, &seq, &type) : -1;
            if (want >= 0 && start == 0 && i == m && cls != want) {
                printf("FAIL frame %ld: mutation guarantees %s, reference says %s\n", f,
                       NAMES[want], cls < 0 ? "idle" : NAMES[cls]);
                fails++;
            }
            const hg_servo_t before = s;
            static hg_bringup_t bu_before;
            bu_before = bu;
            size_t got = 0, got_nak = 0;
            uint8_t tx[HG_LINK_MAX_FRAME];
            for (size_t j = start; j <= i; j++) {
                const size_t r = hg_link_rx_byte(&l, buf[j], tx);
                if (r) {
                    got++;
                    uint8_t raw[HG_LINK_MAX_RAW];
                    const size_t rn = hg_cobs_decode(tx, r - 1, raw, sizeof raw);
                    if (rn == HG_COBS_ERR || rn < 5 || raw[2] != seq || !(raw[1] & 0x80)) {
                        printf("FAIL frame %ld: malformed reply\n", f);
                        fails++;
                    }
                    naks += raw[1] == HG_MSG_NAK;
                    got_nak += raw[1] == HG_MSG_NAK;
                }
            }
            bytes += (long)(i - start + 1);
            start = i + 1;
            if (cls < 0)
                continue;
            chunks++;
            count[cls]++;
            replies += (long)got;
            const uint32_t *st = &l.st.good;
            for (int c = 0; c < NCLASS; c++)
                if (st[c] != count[c]) {
                    printf("FAIL frame %ld: counter %s = %u, reference %u\n", f, NAMES[c],
                           (unsigned)st[c], (unsigned)count[c]);
                    fails++;
                }
            /* a good FORCE is answered only when refused (NAK); every other good frame once */
            const bool reply_ok = type == HG_MSG_FORCE ? got == got_nak && got <= 1 : got == 1;
            if (cls == GOOD ? !reply_ok
                            : (got != 0 || memcmp(&before, &s, sizeof s) != 0
                               || memcmp(&bu_before, &bu, sizeof bu) != 0)) {
                printf("FAIL frame %ld: class %s gave %zu replies%s\n", f, NAMES[cls], got,
                       cls == GOOD ? "" : " or changed the servo or bring-up");
                fails++;
            }
        }
    }
    const double secs = (double)(clock() - t0) / CLOCKS_PER_SEC;
    if (l.st.rejected != (uint32_t)naks) {
        printf("FAIL rejected = %u, NAK replies %ld\n", (unsigned)l.st.rejected, naks);
        fails++;
    }
    printf("fuzz: %ld frames, %ld bytes in %.2f s (seed %s)\n", chunks, bytes, secs,
           argc > 2 ? argv[2] : "1");
    printf("  good %u (rejected %u, replayed %u) | bad: framing %u, crc %u, version %u, type %u, "
           "len %u | pushes %ld (dropped %u)\n",
           count[GOOD], (unsigned)l.st.rejected, (unsigned)l.st.replayed, count[FRAMING],
           count[CRC], count[VERSION], count[TYPE], count[LEN], pushes,
           (unsigned)l.st.push_dropped);
    printf("fuzz %s\n", fails || chunks < frames ? "FAILED" : "PASSED");
    return fails || chunks < frames ? 1 : 0;
}
