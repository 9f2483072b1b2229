/* SPDX-License-Identifier: Apache-2.0 */
/* The FPGA's raw ADC capture buffer (hapgate_top CAPTURE = 1; docs/blocks/capture.md): arm a
 * capture of one axis or all three (at once or at an index edge, one sample in decim + 1), poll
 * it from the background loop, and read the entries back through CAP_ADDR / CAP_DATA (one address
 * write, then auto-incrementing data reads). Register addresses and fields come from hg_regs.h
 * (generated from rtl/regs/hapgate.rdl). Nothing here waits: the caller polls. */
#ifndef HG_CAPTURE_H
#define HG_CAPTURE_H

#include <stdbool.h>
#include <stdint.h>

#include "hg_fpga_regs.h"

#define HG_REG_CAP_CTRL HG_WORD(offsetof(hapgate_t, CAP_CTRL))
#define HG_REG_CAP_STAT HG_WORD(offsetof(hapgate_t, CAP_STAT))
#define HG_REG_CAP_ADDR HG_WORD(offsetof(hapgate_t, CAP_ADDR))
#define HG_REG_CAP_DATA HG_WORD(offsetof(hapgate_t, CAP_DATA))

#define HG_CAP_SEL_ALL 3u   /* sel: all three axes, entries 3m .. 3m+2 = axes 0, 1, 2 */
#define HG_CAP_TRIG_ANY 3u  /* trig_axis: the index of any axis */

enum {
    HG_CAP_OK = 0,          /* done: the buffer is full                               */
    HG_CAP_PENDING = 1,     /* armed (waiting for the trigger) or recording            */
    HG_CAP_STOPPED = 2,     /* neither done nor running (never armed, or stopped)      */
    HG_CAP_ERR_NONE = 3,    /* CAP_STAT.DEPTH_LOG2 = 0: the FPGA has no capture buffer */
    HG_CAP_ERR_ARG = 4,     /* a field out of range, a NULL pointer or entries past the end */
};

typedef struct {
    uint32_t sel;           /* 0..2 one axis, HG_CAP_SEL_ALL all three */
    bool index_trigger;     /* false: the first sample after arming; true: an index edge */
    uint32_t trig_axis;     /* index_trigger: axis 0..2, or HG_CAP_TRIG_ANY */
    uint32_t decim;         /* one sample in decim + 1 (0..65535) */
} hg_cap_cfg_t;

/* Entries of the FPGA's buffer (0: no capture buffer). */
uint32_t hg_cap_depth(void);
/* Entries of a full capture with selection sel (depth, or 3 * floor(depth / 3) for all axes). */
uint32_t hg_cap_limit(uint32_t sel);
/* Arm a capture (clears the previous one's DONE and COUNT). One bus read and one write. */
int hg_cap_arm(const hg_cap_cfg_t *cfg);
/* Stop a capture in progress (its entries so far are kept). */
int hg_cap_stop(void);
/* HG_CAP_OK when done, HG_CAP_PENDING while armed or recording, HG_CAP_STOPPED otherwise;
 * *count (if not NULL): entries written so far. One bus read. */
int hg_cap_poll(uint32_t *count);
/* n entries from entry start (wrapping at the depth) into a[] and b[] (the ADC codes as the
 * interpolator takes them). Not for the servo ISR: one write and n reads. */
int hg_cap_read(uint32_t start, int8_t *a, int8_t *b, uint32_t n);
/* The same as the raw 16-bit entries {B, A} (the PC link's CAP_READ). */
int hg_cap_read_words(uint32_t start, uint16_t *w, uint32_t n);

#endif /* HG_CAPTURE_H */
