/* SPDX-License-Identifier: Apache-2.0 */
/* The SoC's float unit behind libgcc's soft-float entry points (fpu.c): the compiler calls these
 * for float +, -, * and /. The operation codes are the unit's function ids (funct3, funct7 0;
 * rtl/soc/README.md). */
#ifndef HG_FPU_H
#define HG_FPU_H

#define SOC_FPU_ADD 0 /* rs1 + rs2 */
#define SOC_FPU_SUB 1 /* rs1 - rs2 */
#define SOC_FPU_MUL 2 /* rs1 * rs2 */
#define SOC_FPU_DIV 3 /* rs1 / rs2 */

float __addsf3(float a, float b);
float __subsf3(float a, float b);
float __mulsf3(float a, float b);
float __divsf3(float a, float b);

#endif /* HG_FPU_H */
