/* SPDX-License-Identifier: Apache-2.0 */
/* PLACEHOLDER register map of the FPGA, as seen by the DSP firmware. To be REPLACED by the
 * header generated from the SystemRDL map (issue 5); every register address and bit position
 * the firmware uses lives here and nowhere else. Word addresses, 32-bit data. */
#ifndef HG_FPGA_REGS_H
#define HG_FPGA_REGS_H

#define HG_NAXES 3u

/* 0x00 ID (RO): [31:16] magic, [15:0] register-map version. */
#define HG_REG_ID            0x00u
#define HG_ID_MAGIC          0x4847u          /* "HG" */
#define HG_ID_MAGIC_SHIFT    16u

/* 0x01 CTRL (RW). */
#define HG_REG_CTRL          0x01u
#define HG_CTRL_GLOBAL_EN    (1u << 0)
#define HG_CTRL_AXIS_EN(i)   (1u << (1u + (i)))  /* i = 0..2 -> bits 3:1 */
#define HG_CTRL_FAULT_CLR    (1u << 4)           /* write 1: clear FPGA fault and watchdog flags */
#define HG_CTRL_HOME_ARM     (1u << 5)           /* arm the index latch */

/* 0x02 STATUS (RO). */
#define HG_REG_STATUS        0x02u
#define HG_STAT_FAULT(i)     (1u << (i))         /* bits 2:0  axis fault (signal lost, overspeed) */
#define HG_STAT_FAULT_ALL    0x7u
#define HG_STAT_INDEX(i)     (1u << (4u + (i)))  /* bits 6:4  index seen */
#define HG_STAT_HOMED(i)     (1u << (8u + (i)))  /* bits 10:8 index latched since HOME_ARM */
#define HG_STAT_WDOG         (1u << 12)          /* watchdog expired (DACs forced to zero) */

/* 0x03 SEQ (RO): snapshot sequence, +1 each servo tick when the snapshot registers are latched. */
#define HG_REG_SEQ           0x03u
/* 0x04 TICK_DIV (RW): FPGA clock cycles per servo tick. */
#define HG_REG_TICK_DIV      0x04u
/* 0x05 IRQ (RW1C): bit 0 servo tick pending; write 1 to acknowledge. */
#define HG_REG_IRQ           0x05u
#define HG_IRQ_TICK          (1u << 0)
/* 0x06 WDOG (WO): write HG_WDOG_KEY to restart the watchdog. */
#define HG_REG_WDOG          0x06u
#define HG_WDOG_KEY          0x5AFEC0DEu
/* 0x07 SCRATCH (RW). */
#define HG_REG_SCRATCH       0x07u

/* Per-axis block at 0x10 + 8*i. */
#define HG_REG_AXIS(i, r)    (0x10u + 8u * (i) + (r))
#define HG_AX_POS            0u  /* RO  snapshot position, signed counts (2^20 per rev)     */
#define HG_AX_VEL            1u  /* RO  snapshot velocity, signed counts per second          */
#define HG_AX_IDX_POS        2u  /* RO  position latched at the index pulse                  */
#define HG_AX_FAULT_CNT      3u  /* RO  encoder error counter                                */
#define HG_AX_TORQUE         4u  /* RW  torque command, signed 16-bit in [15:0], +-32767 FS  */
#define HG_AX_OFFSET         5u  /* RW  commutation offset (index -> winding)                */
#define HG_AX_MODE           6u  /* RW  0 off, 1 sinusoidal torque                           */
#define HG_AX_TQ_LIMIT       7u  /* RW  |torque code| clamp applied by the FPGA              */
#define HG_MODE_OFF          0u
#define HG_MODE_TORQUE       1u

#define HG_TORQUE_FS         32767

#endif /* HG_FPGA_REGS_H */
