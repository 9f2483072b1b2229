/* SPDX-License-Identifier: Apache-2.0 */
/* CRC-16/CCITT-FALSE and COBS. Bitwise CRC: frames are < 80 bytes, a table is not worth 512 B. */
#include "hg_frame.h"

uint16_t hg_crc16(const uint8_t *d, size_t n)
{
    uint16_t crc = 0xFFFFu;
    for (size_t i = 0; i < n; i++) {
        crc = (uint16_t)(crc ^ (uint16_t)(d[i] << 8));
        for (int b = 0; b < 8; b++)
            crc = (uint16_t)((crc & 0x8000u) ? ((uint32_t)crc << 1) ^ 0x1021u : (uint32_t)crc << 1);
    }
    return crc;
}

size_t hg_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap)
{
    size_t o = 1, code_at = 0;
    uint8_t code = 1;
    if (cap == 0)
        return 0;
    for (size_t i = 0; i < n; i++) {
        if (o >= cap)
            return 0;
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = o++;
            code = 1;
            continue;
        }
        out[o++] = in[i];
        if (++code == 0xFFu && i + 1 < n) {
            if (o >= cap)
                return 0;
            out[code_at] = code;
            code_at = o++;
            code = 1;
        }
    }
    out[code_at] = code;
    return o;
}

size_t hg_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap)
{
    size_t i = 0, o = 0;
    while (i < n) {
        const uint8_t code = in[i++];
        if (code == 0)
            return HG_COBS_ERR;
        for (uint8_t j = 1; j < code; j++) {
            if (i >= n || in[i] == 0 || o >= cap)
                return HG_COBS_ERR;
            out[o++] = in[i++];
        }
        if (code != 0xFFu && i < n) {
            if (o >= cap)
                return HG_COBS_ERR;
            out[o++] = 0;
        }
    }
    return o;
}
