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

size_t hg_frame_encode(uint8_t version, uint8_t type, uint8_t seq, const uint8_t *data, size_t n,
                       uint8_t out[HG_LINK_MAX_FRAME])
{
    uint8_t raw[HG_LINK_MAX_RAW];
    if (n > HG_LINK_MAX_DATA)
        return 0;
    raw[0] = version;
    raw[1] = type;
    raw[2] = seq;
    for (size_t i = 0; i < n; i++)
        raw[HG_LINK_HDR + i] = data[i];
    const uint16_t crc = hg_crc16(raw, HG_LINK_HDR + n);
    raw[HG_LINK_HDR + n] = (uint8_t)(crc >> 8);
    raw[HG_LINK_HDR + n + 1] = (uint8_t)crc;
    const size_t m = hg_cobs_encode(raw, HG_LINK_HDR + n + 2, out, HG_LINK_MAX_FRAME - 1);
    if (m == 0)
        return 0;
    out[m] = 0;
    return m + 1;
}

int hg_frame_check(const uint8_t *chunk, size_t n, uint8_t raw[HG_LINK_MAX_RAW], size_t *raw_n)
{
    const size_t m = hg_cobs_decode(chunk, n, raw, HG_LINK_MAX_RAW);
    if (m == HG_COBS_ERR || m < HG_LINK_HDR + 2)
        return HG_FRAME_BAD_FRAMING;
    *raw_n = m;
    if (hg_crc16(raw, m - 2) != (uint16_t)(raw[m - 2] << 8 | raw[m - 1]))
        return HG_FRAME_BAD_CRC;
    return HG_FRAME_OK;
}
