/* SPDX-License-Identifier: Apache-2.0 */
/* PC-link framing: CRC-16/CCITT-FALSE and COBS (0x00 is the frame delimiter). */
#ifndef HG_FRAME_H
#define HG_FRAME_H

#include <stddef.h>
#include <stdint.h>

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, xorout 0; "123456789" -> 0x29B1 */
uint16_t hg_crc16(const uint8_t *d, size_t n);

#define HG_COBS_ERR ((size_t)-1)
/* Encode n bytes (no delimiter appended). Returns the length, or 0 if cap is too small. */
size_t hg_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);
/* Decode one frame without its delimiter. Returns the length, or HG_COBS_ERR if the frame is
 * malformed (a zero byte, a code running past the end) or does not fit in cap. */
size_t hg_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);

#endif /* HG_FRAME_H */
