// SPDX-License-Identifier: Apache-2.0
// The DAC word, one definition for every harness and the plant: the shipped coding is 14-bit
// two's complement (the top's DAC_BITS = 14, OFFSET_BINARY = 0), full scale +-8191 (the
// commutator saturates symmetrically: hapgate.golden.commutation). A harness built with the
// top's configuration passes -DHG_DAC_BITS and -DHG_DAC_OFFSET_BINARY (runner) and is refused at compile time if it differs.
#pragma once

#include <stdint.h>

namespace hg_dac {

constexpr int kBits = 14;
constexpr int kFullScale = (1 << (kBits - 1)) - 1;   // code at full scale, both signs

// The signed code of a word on the DAC's data pins.
constexpr int decode(uint32_t word) {
    const int w = static_cast<int>(word & ((1u << kBits) - 1));
    return w >= (1 << (kBits - 1)) ? w - (1 << kBits) : w;
}

static_assert(decode(0x1FFF) == kFullScale && decode(0x2001) == -kFullScale && decode(0) == 0,
              "14-bit two's complement");
#ifdef HG_DAC_BITS
static_assert(HG_DAC_BITS == kBits, "the top's DAC_BITS is not the coding the harnesses decode");
#endif
#ifdef HG_DAC_OFFSET_BINARY
static_assert(HG_DAC_OFFSET_BINARY == 0, "the top's DAC coding is offset binary: the harnesses decode two's complement");
#endif

}  // namespace hg_dac
