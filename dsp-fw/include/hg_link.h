/* SPDX-License-Identifier: Apache-2.0 */
/* PC link protocol over a byte stream (RS-232 / USB serial): COBS frames delimited by 0x00,
 * raw frame = version, type, seq, data..., CRC-16/CCITT-FALSE (big-endian) over the rest.
 * A frame that is malformed, truncated, has a wrong CRC, version, type or length is dropped
 * and counted, never acted on. The table is in dsp-fw/README.md. */
#ifndef HG_LINK_H
#define HG_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_servo.h"

#define HG_PROTO_VERSION 1u
#define HG_LINK_HDR 3u        /* version, type, seq */
#define HG_LINK_MAX_DATA 64u
#define HG_LINK_MAX_RAW (HG_LINK_HDR + HG_LINK_MAX_DATA + 2u)
#define HG_LINK_MAX_FRAME (HG_LINK_MAX_RAW + HG_LINK_MAX_RAW / 254u + 2u) /* COBS + 0x00 */

/* Request types; a reply has type | HG_MSG_REPLY and the request's seq. */
enum {
    HG_MSG_PING = 0x01,
    HG_MSG_GET_STATE = 0x02,
    HG_MSG_SET_FORCE = 0x03,
    HG_MSG_SET_SCENE = 0x04,
    HG_MSG_ENABLE = 0x05,
    HG_MSG_GET_STATS = 0x06,
    HG_MSG_CLEAR_ERROR = 0x07,
    HG_MSG_REPLY = 0x80,     /* reply bit                                          */
    HG_MSG_NAK = 0xFF,       /* reply refusing a good frame: data = type, reason   */
};

enum { HG_NAK_RANGE = 1, HG_NAK_ERROR_LATCHED = 2 };

/* Reply data lengths */
#define HG_PING_LEN 8u
#define HG_STATE_LEN 60u
#define HG_STATS_LEN 28u

typedef struct {
    uint32_t good;        /* frames acted on (including rejected ones)           */
    uint32_t bad_framing; /* invalid COBS, shorter than 5 bytes, or over-long    */
    uint32_t bad_crc;
    uint32_t bad_version;
    uint32_t bad_type;    /* unknown request type                                 */
    uint32_t bad_len;     /* data length wrong for the type                       */
    uint32_t rejected;    /* good frames answered with NAK (value out of range...) */
} hg_link_stats_t;

typedef struct {
    hg_servo_t *servo;
    uint8_t rx[HG_LINK_MAX_FRAME];
    size_t n;
    bool overflow;
    hg_link_stats_t st;
} hg_link_t;

void hg_link_init(hg_link_t *l, hg_servo_t *servo);
/* Feed one received byte. When it completes a frame that needs a reply, the encoded reply
 * (delimiter included) is written to tx and its length returned; otherwise 0. */
size_t hg_link_rx_byte(hg_link_t *l, uint8_t b, uint8_t tx[HG_LINK_MAX_FRAME]);
/* Build an encoded frame (delimiter included) from type, seq and data; 0 if it does not fit.
 * The device uses it for replies, host tools and tests for requests. */
size_t hg_link_encode(uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                      uint8_t out[HG_LINK_MAX_FRAME]);

#endif /* HG_LINK_H */
