/* SPDX-License-Identifier: Apache-2.0 */
/* What bring-up finds about one device, per axis: homing (index_to_zero), commutation
 * (offset, phase order, pole pairs) and the encoder's direction against the joint angle.
 * The firmware gates torque on it: an axis without HG_CAL_HOMED and HG_CAL_ALIGNED refuses
 * ENABLE and every force (issue 26). The PC sets it with SET_CALIB; bring-up writes it. */
#ifndef HG_CALIB_H
#define HG_CALIB_H

#include <stdint.h>

enum {
    HG_CAL_HOMED = 1u << 0,   /* index_to_zero is known                                 */
    HG_CAL_ALIGNED = 1u << 1, /* comm_offset, phases_swapped and pole_pairs are known   */
    HG_CAL_DIR_SEEN = 1u << 2 /* enc_dir was confirmed by a guided move (else configured) */
};

typedef struct {
    uint8_t flags;          /* HG_CAL_* bits                                             */
    int8_t enc_dir;         /* +1 / -1: encoder counts against the joint angle           */
    uint8_t phases_swapped; /* 1: amplifier inputs a and b swapped; corrected in firmware */
    uint8_t pole_pairs;     /* electrical cycles per mechanical revolution               */
    int32_t index_to_zero;  /* counts from the index pulse to q = 0                      */
    uint32_t comm_offset;   /* the FPGA's OFFSET register: index -> winding, in its units */
} hg_axis_calib_t;

typedef struct {
    hg_axis_calib_t axis[3];
} hg_calib_t;

#endif /* HG_CALIB_H */
