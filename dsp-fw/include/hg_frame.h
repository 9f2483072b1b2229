/* SPDX-License-Identifier: Apache-2.0 */
/* PC-link framing: CRC-16/CCITT-FALSE and COBS (0x00 is the frame delimiter). */
#ifndef HG_FRAME_H
#define HG_FRAME_H

#include <stddef.h>
#include <stdint.h>
#include "hg_proto.h"

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, xorout 0; "123456789" -> 0x29B1 */
uint16_t hg_crc16(const uint8_t *d, size_t n);

#define HG_COBS_ERR ((size_t)-1)
/* Encode n bytes (no delimiter appended). Returns the length, or 0 if cap is too small. */
size_t hg_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);
/* Decode one frame without its delimiter. Returns the length, or HG_COBS_ERR if the frame is
 * malformed (a zero byte, a code running past the end) or does not fit in cap. */
size_t hg_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);

/* Little-endian fields of the messages' data (both ends read and write them with these). */
static inline void hg_put_u16(uint8_t *d, uint32_t v)
{
    d[0] = (uint8_t)v;
    d[1] = (uint8_t)(v >> 8);
}

static inline void hg_put_u32(uint8_t *d, uint32_t v)
{
    hg_put_u16(d, v);
    hg_put_u16(d + 2, v >> 16);
}

static inline uint32_t hg_get_u16(const uint8_t *d)
{
    return (uint32_t)d[0] | (uint32_t)d[1] << 8;
}

static inline uint32_t hg_get_u32(const uint8_t *d)
{
    return hg_get_u16(d) | hg_get_u16(d + 2) << 16;
}

/* f32 = IEEE-754 binary32, through a union (no aliasing cast) */
static inline void hg_put_f32(uint8_t *d, float x)
{
    union { float f; uint32_t u; } b;
    b.f = x;
    hg_put_u32(d, b.u);
}

static inline float hg_get_f32(const uint8_t *d)
{
    union { float f; uint32_t u; } b;
    b.u = hg_get_u32(d);
    return b.f;
}

/* One link frame, delimiter included: COBS(version, type, seq, data[n], CRC-16 big-endian), 0x00.
 * Returns its length, or 0 if n > HG_LINK_MAX_DATA. Both ends build their frames with it. */
size_t hg_frame_encode(uint8_t version, uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                       uint8_t out[HG_LINK_MAX_FRAME]);

enum { HG_FRAME_OK = 0, HG_FRAME_BAD_FRAMING = 1, HG_FRAME_BAD_CRC = 2 };
/* Check one received chunk (delimiter stripped): valid COBS decoding to HG_LINK_HDR + 2 ...
 * HG_LINK_MAX_RAW bytes (else HG_FRAME_BAD_FRAMING), then the CRC (else HG_FRAME_BAD_CRC).
 * The raw frame (header, data, CRC) goes to raw and its length to *raw_n. Version, type and
 * length are the caller's to check. */
int hg_frame_check(const uint8_t *chunk, size_t n, uint8_t raw[HG_LINK_MAX_RAW], size_t *raw_n);

#endif /* HG_FRAME_H */
