/* SPDX-License-Identifier: Apache-2.0 */
/* Single-precision add, subtract, multiply and divide on the SoC's float unit (rtl/soc/
 * hg_fpu_cfu.v, on VexRiscv's custom-function port): the four libgcc soft-float entry points
 * the compiler calls for float arithmetic with -mabi=ilp32, here, so that the linker takes
 * these and not libgcc's members. Same ABI (operands and result as bit patterns in a0, a1), and
 * the same results bit for bit: IEEE-754 binary32, round to nearest even, subnormals, and
 * libgcc's canonical NaN 0x7FC00000 (tb/soc/test_fpu_cfu.py, tb/soc/test_soc_fpu.py). The
 * comparisons and conversions stay libgcc's. The unit answers only once start.S has set the
 * port's enable (CSR 0xBC0 bit 31); before that each of these traps as an illegal instruction.
 * Each is one R-type instruction of the CUSTOM_0 opcode, funct3 naming the operation. */
#include "fpu.h"

#define SOC_FPU_STR(x) #x
#define SOC_FPU_XSTR(x) SOC_FPU_STR(x)
/* r = a op b: no side effect, so the compiler may move or merge it like any arithmetic */
#define SOC_FPU_OP(funct3, r, a, b) \
    __asm__(".insn r CUSTOM_0, " SOC_FPU_XSTR(funct3) ", 0, %0, %1, %2" : "=r"(r) : "r"(a), "r"(b))

float __addsf3(float a, float b)
{
    float r;
    SOC_FPU_OP(SOC_FPU_ADD, r, a, b);
    return r;
}

float __subsf3(float a, float b)
{
    float r;
    SOC_FPU_OP(SOC_FPU_SUB, r, a, b);
    return r;
}

float __mulsf3(float a, float b)
{
    float r;
    SOC_FPU_OP(SOC_FPU_MUL, r, a, b);
    return r;
}

float __divsf3(float a, float b)
{
    float r;
    SOC_FPU_OP(SOC_FPU_DIV, r, a, b);
    return r;
}
