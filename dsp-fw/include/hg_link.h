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
#include "hg_bringup.h"
#include "hg_proto.h"
#include "hg_servo.h"

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
    uint32_t now;         /* link_now(): the latest SEQ seen (bring-up or servo)        */
    hg_bringup_t *bu;     /* bring-up reachable over the link (NULL: its messages NAK 6);
                           * set by the board code after hg_link_init                   */
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
 * them and stops the stream; a state-only stream goes on; while a bring-up step runs, the
 * same silence aborts it to zero torque with HG_BU_ERR_LINK) and the stream. When a push is due
 * and tx_free, the encoded STATE_PUSH (the state of the current tick) is written to tx and its
 * length returned. A due push waits while the transmitter is busy; each further period that
 * passes while it waits counts one dropped sample. Otherwise 0. */
size_t hg_link_poll(hg_link_t *l, bool tx_free, uint8_t tx[HG_LINK_MAX_FRAME]);

#endif /* HG_LINK_H */
