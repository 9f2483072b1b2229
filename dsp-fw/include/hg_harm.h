/* SPDX-License-Identifier: Apache-2.0 */
/* Harmonic correction table of the FPGA's ratio angle stage (hapgate_top HARM = 1): load one
 * axis's table through HARM_ADDR / HARM_DATA (one address write, then auto-incrementing data
 * writes), verify it by reading it back the same way, and switch the correction on or off.
 * The table is learned off-chip from a constant-speed run (`hapgate harm fit`, which writes the
 * entries: signed, 1/4 count each); rtl/interp/README.md, "Harmonic table". */
#ifndef HG_HARM_H
#define HG_HARM_H

#include <stdbool.h>
#include <stdint.h>

enum {
    HG_HARM_OK = 0,
    HG_HARM_ERR_NO_STAGE = 1, /* HARM_CTRL.LOG2 = 0: the FPGA has no harmonic stage      */
    HG_HARM_ERR_SIZE = 2,     /* n is not the FPGA's 2^LOG2 entries (or table is NULL)  */
    HG_HARM_ERR_AXIS = 3,     /* axis >= HG_NAXES                                        */
    HG_HARM_ERR_VERIFY = 4,   /* an entry read back differs from the one written        */
};

/* Entries per line of the FPGA's table (0: no harmonic stage). */
uint32_t hg_harm_size(void);

/* Switch axis's correction off, write its n entries, read them back. Returns HG_HARM_*; the
 * correction stays off (hg_harm_enable switches it on). Not for the servo ISR: 2n + 2 bus
 * writes and n + 1 reads. */
int hg_harm_load(uint32_t axis, const int8_t *table, uint32_t n);

/* The correction of axis on or off (from the next ADC sample); the other axes unchanged. */
int hg_harm_enable(uint32_t axis, bool on);

#endif /* HG_HARM_H */
