/* SPDX-License-Identifier: Apache-2.0 */
/* The PC-link protocol's constants: versions, frame sizes, message types, NAK reasons, data
 * lengths and flag bits. One header for both ends: the firmware (hg_link.c) and the PC-side C
 * library (host/). The layouts are tabled in dsp-fw/README.md, "PC link protocol". */
#ifndef HG_PROTO_H
#define HG_PROTO_H

#define HG_PROTO_V1 1u         /* the first protocol: frames with it are answered as in v1 */
#define HG_PROTO_VERSION 2u    /* the highest version this firmware speaks                 */
#define HG_LINK_HDR 3u        /* version, type, seq */
#define HG_LINK_MAX_DATA 64u
#define HG_LINK_MAX_RAW (HG_LINK_HDR + HG_LINK_MAX_DATA + 2u)
#define HG_LINK_MAX_FRAME (HG_LINK_MAX_RAW + HG_LINK_MAX_RAW / 254u + 2u) /* COBS + 0x00 */

/* Request types; a reply has type | HG_MSG_REPLY and the request's seq. */
enum {
    HG_MSG_PING = 0x01,
    HG_MSG_GET_STATE = 0x02,
    HG_MSG_SET_FORCE = 0x03,
    HG_MSG_SET_SCENE = 0x04,
    HG_MSG_ENABLE = 0x05,
    HG_MSG_GET_STATS = 0x06,
    HG_MSG_CLEAR_ERROR = 0x07,
    HG_MSG_INFO = 0x08,      /* v2: identity, rates and limits                          */
    HG_MSG_STREAM = 0x09,    /* v2: push STATE_PUSH every N servo ticks (0 = stop)      */
    HG_MSG_FORCE = 0x0A,     /* v2: PC force with TTL, counter and the state it answers */
    HG_MSG_SET_CALIB = 0x0B, /* v2: one axis's calibration (hg_calib.h); only while disabled */
    HG_MSG_GET_CALIB = 0x0C, /* v2: read one axis's calibration                            */
    HG_MSG_BU_START = 0x0D,  /* v2: start a bring-up step (hg_bringup.h)                   */
    HG_MSG_BU_PROGRESS = 0x0E, /* v2: the running step's state, ticks and error            */
    HG_MSG_BU_RESULT = 0x0F, /* v2: one page of an axis's bring-up results                 */
    HG_MSG_BU_CHECK = 0x10,  /* v2: one check {name, value, limit, unit, pass} of an axis  */
    HG_MSG_BU_ABORT = 0x11,  /* v2: stop the running step at once (zero torque)            */
    HG_MSG_CAP_READ = 0x12,  /* v2: entries of the FPGA's capture buffer (hg_capture.h)     */
    HG_MSG_STATE_PUSH = 0x8A, /* v2, device -> PC only: the compact streamed state       */
    HG_MSG_REPLY = 0x80,     /* reply bit                                          */
    HG_MSG_NAK = 0xFF,       /* reply refusing a good frame: data = type, reason   */
};

enum {
    HG_NAK_RANGE = 1,
    HG_NAK_ERROR_LATCHED = 2,
    HG_NAK_REPLAY = 3,
    HG_NAK_UNCALIBRATED = 4, /* ENABLE or a force while an axis is not homed and aligned     */
    HG_NAK_ENABLED = 5,      /* SET_CALIB while the forces are enabled                       */
    HG_NAK_BRINGUP = 6,      /* ENABLE 1 or SET_CALIB while a bring-up step runs, or a bring-up
                              * message to a device without bring-up                         */
};

/* Reply data lengths (HG_FORCE_LEN: the FORCE request) */
#define HG_PING_LEN 8u
#define HG_STATE_LEN 60u
#define HG_STATS_LEN 28u
#define HG_STATS2_LEN 44u      /* GET_STATS in a version-2 frame */
#define HG_INFO_LEN 56u
#define HG_STREAM_ACK_LEN 2u
#define HG_PUSH_LEN 54u
#define HG_FORCE_LEN 20u
#define HG_CALIB_LEN 11u       /* SET_CALIB request = GET_CALIB reply */
#define HG_BU_START_ACK_LEN 9u  /* u8 result, f32 value, f32 limit */
#define HG_BU_PROGRESS_LEN 26u
#define HG_BU_RESULT0_LEN 54u   /* page 0: ALIGN, HOME, GUIDED */
#define HG_BU_RESULT1_LEN 52u   /* page 1: IDENT and the step durations */
#define HG_BU_RESULT2_LEN HG_CALIB_LEN /* page 2: the calibration bring-up found (SET_CALIB's) */
#define HG_BU_RESULT3_LEN 40u   /* page 3: IDENT's pose, held excursion, lag, standard errors */
#define HG_BU_RESULT4_LEN 44u   /* page 4: ENCODER's capture and the CAL_* registers */
#define HG_CAP_READ_MAX 30u     /* CAP_READ: entries per reply (u16 each, after 4 bytes) */
#define HG_BU_CHECK_LEN 56u
#define HG_BU_NAME_LEN 32u      /* BU_CHECK: NUL-padded name */
#define HG_BU_UNIT_LEN 12u      /* BU_CHECK: NUL-padded unit */
/* Request data lengths */
#define HG_SET_FORCE_LEN 12u
#define HG_SET_SCENE_LEN 37u
#define HG_ENABLE_LEN 1u
#define HG_STREAM_LEN 2u
#define HG_GET_CALIB_LEN 1u
#define HG_BU_START_LEN 9u     /* u8 step, u8 axis, i8 expect[3], u32 seed */
#define HG_BU_RESULT_LEN 2u    /* u8 axis, u8 page */
#define HG_BU_CHECK_REQ_LEN 2u /* u8 axis, u8 check */
#define HG_CAP_READ_LEN 3u     /* u16 first entry, u8 entries */
#define HG_STREAM_MAX_PERIOD 1000u  /* ticks */
#define HG_LINK_TIMEOUT_MS 250u     /* default link-silence timeout */

/* Scene kinds: SET_SCENE's type byte (the laws are in hg_scene.h and dsp-fw/README.md) */
enum {
    HG_SCENE_NONE = 0,     /* F = 0                                                     */
    HG_SCENE_WALL = 1,     /* plane through p0, normal n into free space:               */
                           /*   depth d = (p0 - p).n; F = n max(0, k d - b v.n) if d > 0 */
    HG_SCENE_SPRING = 2,   /* PID to the point p0: F = -k e - b v - ki int(e), e = p - p0 */
    HG_SCENE_VISCOUS = 3,  /* F = -b v                                                  */
    HG_SCENE_PC_FORCE = 4, /* F = the force last sent by the PC (until it times out)     */
    HG_SCENE_COUNT
};

/* flags byte of GET_STATE (bits 0-2) and STATE_PUSH (bits 0-3) */
enum {
    HG_FLAG_ENABLED = 1u << 0,
    HG_FLAG_ERROR = 1u << 1,
    HG_FLAG_PC_FORCE = 1u << 2, /* GET_STATE: a PC force is live; push: that tick rendered one */
    HG_FLAG_ARMED = 1u << 3,    /* push only: the link-silence timeout is armed              */
};

#endif /* HG_PROTO_H */
