/* SPDX-License-Identifier: Apache-2.0 */
/* PC link protocol over a byte stream (RS-232 / USB serial): COBS frames delimited by 0x00,
 * raw frame = version, type, seq, data..., CRC-16/CCITT-FALSE (big-endian) over the rest.
 * A frame that is malformed, truncated, has a wrong CRC, version, type or length is dropped
 * and counted, never acted on. Version 2 adds INFO, streaming (STREAM + STATE_PUSH), a PC
 * force with a TTL and replay protection (FORCE), and the link-silence timeout; version-1
 * frames are answered exactly as before. The table is in dsp-fw/README.md. */
#ifndef HG_LINK_H
#define HG_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "hg_servo.h"

#define HG_PROTO_V1 1u         /* the first protocol: frames with it are answered as in v1 */
#define HG_PROTO_VERSION 2u    /* the highest version this firmware speaks                 */
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
    HG_MSG_INFO = 0x08,      /* v2: identity, rates and limits                          */
    HG_MSG_STREAM = 0x09,    /* v2: push STATE_PUSH every N servo ticks (0 = stop)      */
    HG_MSG_FORCE = 0x0A,     /* v2: PC force with TTL, counter and the state it answers */
    HG_MSG_STATE_PUSH = 0x8A, /* v2, device -> PC only: the compact streamed state       */
    HG_MSG_REPLY = 0x80,     /* reply bit                                          */
    HG_MSG_NAK = 0xFF,       /* reply refusing a good frame: data = type, reason   */
};

enum { HG_NAK_RANGE = 1, HG_NAK_ERROR_LATCHED = 2, HG_NAK_REPLAY = 3 };

/* Reply data lengths */
#define HG_PING_LEN 8u
#define HG_STATE_LEN 60u
#define HG_STATS_LEN 28u
#define HG_STATS2_LEN 44u      /* GET_STATS in a version-2 frame */
#define HG_INFO_LEN 56u
#define HG_STREAM_ACK_LEN 2u
#define HG_PUSH_LEN 54u
#define HG_FORCE_LEN 20u
#define HG_STREAM_MAX_PERIOD 1000u  /* ticks */
#define HG_LINK_TIMEOUT_MS 250u     /* default link-silence timeout */

typedef struct {
    uint32_t good;        /* frames acted on (including rejected ones)           */
    uint32_t bad_framing; /* invalid COBS, shorter than 5 bytes, or over-long    */
    uint32_t bad_crc;
    uint32_t bad_version;
    uint32_t bad_type;    /* unknown request type                                 */
    uint32_t bad_len;     /* data length wrong for the type                       */
    uint32_t rejected;    /* good frames answered with NAK (value out of range...) */
    /* version 2 */
    uint32_t replayed;    /* FORCE frames whose counter was not newer (also rejected) */
    uint32_t pushed;      /* STATE_PUSH frames sent                               */
    uint32_t push_dropped; /* push samples skipped because the transmitter was busy */
    uint32_t timeouts;    /* link-silence timeouts that disabled the forces        */
} hg_link_stats_t;

/* Link configuration the PC can read with INFO (set by the board code after hg_link_init). */
typedef struct {
    uint32_t baud;        /* the UART's configured rate (0 = unknown, e.g. USB CDC) */
    uint32_t timeout_ms;  /* link silence beyond this disables forces (0 = never)   */
    hg_real box_lo[3];    /* m, workspace box the endpoint can reach               */
    hg_real box_hi[3];
} hg_link_cfg_t;

typedef struct {
    hg_servo_t *servo;
    uint8_t rx[HG_LINK_MAX_FRAME];
    size_t n;
    bool overflow;
    hg_link_stats_t st;
    hg_link_cfg_t cfg;
    /* version 2 state */
    bool armed;           /* forces were enabled over the link: silence times out    */
    uint32_t last_rx;     /* servo SEQ at the last good frame                        */
    uint32_t period;      /* stream period in ticks, 0 = off                         */
    uint32_t last_push;   /* servo SEQ of the last push sample (sent or dropped)     */
    uint8_t push_seq;     /* frame seq of the pushes                                 */
    bool have_force;      /* a FORCE counter has been accepted since the last enable */
    uint16_t force_ctr;   /* counter of the last accepted FORCE (replay check)       */
    bool pend;            /* an accepted FORCE not yet rendered by a servo step     */
    uint32_t pend_tick;   /* the first tick that renders it (SEQ at arrival + 1)     */
    uint32_t pend_ttl;    /* ticks it lasts                                          */
    uint16_t pend_ctr, pend_lat;
    bool live;            /* a PC force has been rendered (first tick, ttl below)    */
    uint32_t live_first, live_ttl;
    uint16_t live_ctr;    /* counter of the FORCE the pushed tick rendered           */
    uint16_t live_lat;    /* its latency in ticks: first tick using it - answered SEQ */
    uint8_t ver;          /* protocol version of the request being handled           */
} hg_link_t;

void hg_link_init(hg_link_t *l, hg_servo_t *servo);
/* Feed one received byte. When it completes a frame that needs a reply, the encoded reply
 * (delimiter included) is written to tx and its length returned; otherwise 0. */
size_t hg_link_rx_byte(hg_link_t *l, uint8_t b, uint8_t tx[HG_LINK_MAX_FRAME]);
/* Build an encoded frame (delimiter included) from type, seq and data; 0 if it does not fit.
 * The device uses it for replies, host tools and tests for requests. */
size_t hg_link_encode(uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                      uint8_t out[HG_LINK_MAX_FRAME]);
/* The same with an explicit protocol version (replies carry the request's version). */
size_t hg_link_encode_v(uint8_t version, uint8_t type, uint8_t seq, const uint8_t *data,
                        size_t n, uint8_t out[HG_LINK_MAX_FRAME]);
/* Background-loop duty, called often (at least once per servo tick): the link-silence
 * timeout (while forces are enabled over the link, silence beyond cfg.timeout_ms disables
 * them and stops the stream; a state-only stream goes on) and the stream. When a push is due
 * and tx_free, the encoded STATE_PUSH (the state of the current tick) is written to tx and its
 * length returned. A due push waits while the transmitter is busy; each further period that
 * passes while it waits counts one dropped sample. Otherwise 0. */
size_t hg_link_poll(hg_link_t *l, bool tx_free, uint8_t tx[HG_LINK_MAX_FRAME]);

#endif /* HG_LINK_H */
