/* SPDX-License-Identifier: Apache-2.0 */
/* A test image for the hapgate SoC (tb/soc/test_soc_fpu.py): the float unit (rtl/soc/hg_fpu_cfu.v,
 * through dsp-fw/board/riscv/fpu.c) against libgcc's own soft float, on the simulated CPU. The
 * test links libgcc's addsf3.o, subsf3.o, mulsf3.o and divsf3.o with their entry points renamed
 * __soft_addsf3 ...; each operand pair runs through both and the result words are compared. The
 * pairs: every pair of a list of corner values, then pseudo-random pairs of four kinds (any bit
 * pattern, a subnormal operand, exponents close together, exponents at the range's ends). The
 * counts and the first difference stay in RAM, where the harness reads them at the end. */
#include <stdint.h>
#include "fpu.h"
#include "soc.h"

float __soft_addsf3(float a, float b);
float __soft_subsf3(float a, float b);
float __soft_mulsf3(float a, float b);
float __soft_divsf3(float a, float b);
int main(void);

#ifndef FPU_CHECK_RANDOM
#define FPU_CHECK_RANDOM 1000u /* pairs per kind and operation */
#endif

typedef float (*fop_t)(float, float);
static const fop_t soft[4] = { __soft_addsf3, __soft_subsf3, __soft_mulsf3, __soft_divsf3 };
static const fop_t hard[4] = { __addsf3, __subsf3, __mulsf3, __divsf3 };

volatile uint32_t check_done;          /* 1: every pair ran */
volatile uint32_t check_count[4];      /* pairs per operation (add, sub, mul, div) */
volatile uint32_t check_bad[4];        /* ... whose results differ */
volatile uint32_t check_first[5];      /* the first difference: operation, a, b, soft, unit */
volatile uint32_t check_nan[4];        /* pairs whose result is a NaN (libgcc's) */
volatile uint32_t check_subnormal[4];  /* ... a subnormal */
volatile uint32_t soc_trap_cause, soc_trap_pc, soc_trap_value;

static const uint32_t corners[] = {
    0x00000000u, 0x80000000u, 0x00000001u, 0x80000001u, 0x00000002u, 0x00000003u,
    0x00400000u, 0x007FFFFFu, 0x807FFFFFu, 0x00555555u, 0x00800000u, 0x80800000u,
    0x00800001u, 0x00FFFFFFu, 0x01000000u, 0x3F800000u, 0xBF800000u, 0x3F800001u,
    0x3F7FFFFFu, 0x3FC00000u, 0x40400000u, 0x3EAAAAABu, 0x40000000u, 0x34000000u,
    0x33800000u, 0x33000000u, 0x4B000000u, 0x4B800000u, 0x4B7FFFFFu, 0x1F800000u,
    0x5F800000u, 0x20000000u, 0x5E800000u, 0x7F7FFFFFu, 0xFF7FFFFFu, 0x7F000000u,
    0x7E800000u, 0x7F7FFFFEu, 0x7F800000u, 0xFF800000u, 0x7FC00000u, 0xFFC00000u,
    0x7F800001u, 0xFF800001u, 0x7FBFFFFFu, 0xFFFFFFFFu,
};

static uint32_t rng_state = 0x2545F491u;
static uint32_t rnd(void) /* xorshift32 */
{
    uint32_t x = rng_state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    rng_state = x;
    return x;
}

static void one(unsigned op, uint32_t a, uint32_t b)
{
    union { uint32_t u; float f; } x, y, s, h;
    x.u = a;
    y.u = b;
    s.f = soft[op](x.f, y.f);
    h.f = hard[op](x.f, y.f);
    check_count[op] = check_count[op] + 1u;
    if ((s.u & 0x7FFFFFFFu) > 0x7F800000u)
        check_nan[op] = check_nan[op] + 1u;
    else if ((s.u & 0x7F800000u) == 0u && (s.u & 0x007FFFFFu) != 0u)
        check_subnormal[op] = check_subnormal[op] + 1u;
    if (s.u != h.u) {
        if (check_bad[0] + check_bad[1] + check_bad[2] + check_bad[3] == 0u) {
            check_first[0] = op;
            check_first[1] = a;
            check_first[2] = b;
            check_first[3] = s.u;
            check_first[4] = h.u;
        }
        check_bad[op] = check_bad[op] + 1u;
    }
}

/* an exponent field (0..254) near one end of the range, either end */
static uint32_t end_exp(void)
{
    const uint32_t r = rnd();
    const uint32_t e = (r >> 8) % 31u;
    return (r & 1u) ? e : 254u - e;
}

int main(void)
{
    __asm__ volatile(SOC_CSR_ASM("csrc mstatus, %0") : : "r"(SOC_MSTATUS_MIE) : "memory");
    const unsigned nc = sizeof corners / sizeof corners[0];
    for (unsigned op = 0; op < 4u; op++)
        for (unsigned i = 0; i < nc; i++)
            for (unsigned j = 0; j < nc; j++)
                one(op, corners[i], corners[j]);
    for (unsigned op = 0; op < 4u; op++) {
        for (uint32_t k = 0; k < FPU_CHECK_RANDOM; k++) {
            one(op, rnd(), rnd());                                   /* any bit pattern */
            const uint32_t s = rnd() & 0x807FFFFFu, o = rnd();       /* a subnormal operand */
            if (o & 1u)
                one(op, s, o & 0xFF7FFFFFu);
            else
                one(op, o & 0xFF7FFFFFu, s);
            const uint32_t a = rnd() & 0xFF7FFFFFu;                  /* exponents close */
            int32_t eb = (int32_t)((a >> 23) & 0xFFu) + (int32_t)(rnd() % 61u) - 30;
            eb = eb < 0 ? 0 : (eb > 254 ? 254 : eb);
            one(op, a, (rnd() & 0x807FFFFFu) | ((uint32_t)eb << 23));
            one(op, (rnd() & 0x807FFFFFu) | (end_exp() << 23),       /* the range's ends */
                (rnd() & 0x807FFFFFu) | (end_exp() << 23));
        }
    }
    check_done = 1u;
    for (;;)
        ;
}

/* start.S's trap entry: nothing is expected (interrupts are off from main's first line) */
void soc_trap(uint32_t mcause, uint32_t mepc)
{
    uint32_t mtval;
    __asm__ volatile(SOC_CSR_ASM("csrr %0, mtval") : "=r"(mtval));
    soc_trap_cause = mcause;
    soc_trap_pc = mepc;
    soc_trap_value = mtval;
    for (;;)
        ;
}
