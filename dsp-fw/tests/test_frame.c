/* SPDX-License-Identifier: Apache-2.0 */
/* CRC-16 and COBS. */
#include <string.h>
#include "hg_frame.h"
#include "hg_test.h"

void test_crc_check_value(void)
{
    const uint8_t s[] = "123456789";
    CHECK(hg_crc16(s, 9) == 0x29B1u);  /* CRC-16/CCITT-FALSE catalogue check value */
    CHECK(hg_crc16(s, 0) == 0xFFFFu);  /* init, nothing shifted in */
}

/* COBS of known vectors (from the COBS paper / Wikipedia examples) and round trips. */
void test_cobs_vectors(void)
{
    const uint8_t in1[] = { 0x00 }, ex1[] = { 0x01, 0x01 };
    const uint8_t in2[] = { 0x11, 0x22, 0x00, 0x33 }, ex2[] = { 0x03, 0x11, 0x22, 0x02, 0x33 };
    const uint8_t in3[] = { 0x11, 0x00, 0x00, 0x00 }, ex3[] = { 0x02, 0x11, 0x01, 0x01, 0x01 };
    uint8_t out[600], back[600];
    CHECK(hg_cobs_encode(in1, 1, out, sizeof out) == 2 && memcmp(out, ex1, 2) == 0);
    CHECK(hg_cobs_encode(in2, 4, out, sizeof out) == 5 && memcmp(out, ex2, 5) == 0);
    CHECK(hg_cobs_encode(in3, 4, out, sizeof out) == 5 && memcmp(out, ex3, 5) == 0);
    /* 254 non-zero bytes: one 0xFF block, no trailing code byte */
    uint8_t run[300];
    for (int i = 0; i < 300; i++)
        run[i] = (uint8_t)(1 + i % 255);
    size_t n = hg_cobs_encode(run, 254, out, sizeof out);
    CHECK(n == 255 && out[0] == 0xFF);
    for (size_t len = 0; len < 300; len += 7) {
        uint8_t buf[300];
        for (size_t i = 0; i < len; i++)
            buf[i] = (uint8_t)(i % 5 == 0 ? 0 : run[i]);
        n = hg_cobs_encode(buf, len, out, sizeof out);
        CHECK(n > len && memchr(out, 0, n) == NULL);
        CHECK(hg_cobs_decode(out, n, back, sizeof back) == len && memcmp(back, buf, len) == 0);
    }
    n = hg_cobs_encode(run, 254, out, sizeof out);
    CHECK(hg_cobs_decode(out, n, back, sizeof back) == 254 && memcmp(back, run, 254) == 0);
}

void test_cobs_errors(void)
{
    const uint8_t past_end[] = { 0x05, 0x11, 0x22 };   /* code says 4 bytes follow */
    const uint8_t zero_in[] = { 0x03, 0x11, 0x00 };
    uint8_t out[8];
    CHECK(hg_cobs_decode(past_end, 3, out, sizeof out) == HG_COBS_ERR);
    CHECK(hg_cobs_decode(zero_in, 3, out, sizeof out) == HG_COBS_ERR);
    const uint8_t ok[] = { 0x03, 0x11, 0x22, 0x02, 0x33 };
    CHECK(hg_cobs_decode(ok, 5, out, 3) == HG_COBS_ERR); /* does not fit */
    CHECK(hg_cobs_encode(ok, 5, out, 4) == 0);
}
