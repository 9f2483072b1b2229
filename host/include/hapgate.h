/* SPDX-License-Identifier: Apache-2.0 */
/* hapgate host library: the PC side of the dsp-fw PC link in C (docs/native-host.md).
 *
 * It mirrors the Python API `hapgate.host`. A reader thread owns the port from hg_open() to
 * hg_close(): it decodes every frame, answers the waiting request, keeps the newest streamed
 * state and records the loop latency the device reports. Requests may come from any thread.
 * hg_loop_start() runs an HDAPI-style servo loop on a thread of its own: at each new streamed
 * state it calls the user's callback and sends the force it returns as FORCE with a TTL.
 *
 *     hg_dev_t *dev;
 *     if (hg_open(&dev, "/dev/pts/5", 1000000, 1.0) != HG_OK) ...   forces are off after open
 *     hg_set_scene(dev, HG_SCENE_PC_FORCE, NULL, NULL, 0, 0, 0);
 *     hg_enable(dev, 1);
 *     hg_loop_start(dev, 1000.0, 10, my_force, &my_world);           1 kHz, 10 ms TTL
 *     ...
 *     hg_loop_stop(dev, &stats);
 *     hg_close(dev);                                                 forces off, then closed
 *
 * Every call returns HG_OK or a negative hg_status; hg_strerror() names it. Once the link is
 * lost (the port fails or closes, or a running stream goes silent) every call returns
 * HG_E_LINK_LOST and a running loop stops; the device switches its forces off by itself (the
 * force's TTL, then its link-silence timeout). Device time is the FPGA tick counter carried by
 * every state (seq / servo rate), so figures do not depend on how fast the PC runs. */
#ifndef HAPGATE_H
#define HAPGATE_H

#include <stddef.h>
#include <stdint.h>
#include "hg_calib.h" /* hg_axis_calib_t and the HG_CAL_* flags, shared with the firmware */
#include "hg_proto.h" /* the protocol constants, shared with the firmware */

#ifdef __cplusplus
extern "C" {
#endif

#define HG_HOST_VERSION "1.0"

typedef struct hg_dev hg_dev_t;   /* one device on one port */

typedef enum {
    HG_OK = 0,
    HG_E_ARG = -1,       /* a bad argument (NULL, non-finite, out of range)              */
    HG_E_OPEN = -2,      /* the port could not be opened or configured                    */
    HG_E_TIMEOUT = -3,   /* no reply within the timeout on a live port                    */
    HG_E_LINK_LOST = -4, /* the port failed or closed, or a running stream went silent    */
    HG_E_PROTOCOL = -5,  /* the device answered something this library does not expect   */
    HG_E_REFUSED = -6,   /* the device refused a good request (NAK), or the link cannot
                            carry the rate asked for                                      */
    HG_E_FAULT = -7,     /* the device has latched a safety error (hg_clear_error)        */
    HG_E_BUSY = -8,      /* a servo loop is already running on this device                */
    HG_E_NOMEM = -9,     /* out of memory (hg_open only)                                  */
} hg_status;

/* The message of a status (never NULL; "unknown status" for a value not listed above). */
const char *hg_strerror(int status);

/* Scene kinds HG_SCENE_NONE, _WALL, _SPRING, _VISCOUS, _PC_FORCE: hg_proto.h. */

typedef struct {
    unsigned fw_version;     /* major << 8 | minor                                         */
    unsigned protocol;       /* 2                                                          */
    uint32_t fpga_id;
    unsigned servo_hz;
    unsigned link_timeout_ms; /* silence beyond this disables forces (0: never)           */
    uint32_t baud;           /* the device UART's rate (0: unknown, e.g. USB)              */
    double box_lo[3], box_hi[3]; /* m, the workspace box                                   */
    double f_max_n, k_max_n_per_m, b_max_ns_per_m;
    unsigned ttl_max_ms;     /* longest TTL a FORCE may carry                              */
    uint16_t force_counter;  /* counter of the last FORCE the device accepted              */
    double max_loop_hz;      /* highest stream rate the link carries with 30 % headroom    */
    unsigned max_loop_period; /* the same as a period in servo ticks                       */
} hg_dev_info_t;

typedef struct {
    uint32_t seq;            /* FPGA tick of the sample                                    */
    double t_s;              /* device time: seq / servo rate                              */
    double p[3], v[3];       /* m, m/s (device frame)                                      */
    double q[3];             /* rad (hg_get_state only; NaN in pushes)                     */
    double f[3];             /* N, the force the device rendered at that tick              */
    int enabled, error, error_axis, pc_force_live, scene;
    unsigned flags;          /* HG_FLAG_* of dsp-fw/include/hg_proto.h                     */
    uint32_t fpga_status;    /* hg_get_state only                                          */
    int16_t code[3];         /* torque codes written at that tick (pushes only)            */
    uint16_t force_counter;  /* pushes: the FORCE that tick rendered                       */
    uint16_t force_latency_ticks; /* pushes: its first tick - the SEQ it answered          */
    int is_push;
} hg_dev_state_t;

/* No motor is driven: pushes, every torque code zero; states, disabled or faulted. */
int hg_torque_zero(const hg_dev_state_t *s);

typedef struct {
    /* the firmware's counters (GET_STATS, version 2) */
    uint32_t good, bad_framing, bad_crc, bad_version, bad_type, bad_len, rejected;
    uint32_t replayed, pushed, push_dropped, timeouts;
    /* frames this library dropped, by cause, and replies nobody waited for */
    uint32_t host_bad_framing, host_bad_crc, host_bad_version, host_stray;
    uint64_t pushes;         /* STATE_PUSH frames received                                 */
    uint32_t push_gaps;      /* pushes lost on the way (gaps in the push frame counter)    */
} hg_dev_stats_t;

/* Open a serial device or pty path: raw mode, `baud` (a standard rate; a pty ignores it),
 * low latency where the OS has it; then INFO within timeout_s, stop a stream left running and
 * switch forces off. timeout_s is also the wait for every later reply. */
int hg_open(hg_dev_t **out, const char *path, uint32_t baud, double timeout_s);
/* Stop the loop and the stream, switch forces off and wait until the device reports zero
 * torque for a whole tick, then close the port and free dev (also on a lost link). */
int hg_close(hg_dev_t *dev);

int hg_get_info(hg_dev_t *dev, hg_dev_info_t *out);
int hg_get_state(hg_dev_t *dev, hg_dev_state_t *out);
int hg_enable(hg_dev_t *dev, int on);
int hg_clear_error(hg_dev_t *dev);
/* Wall (p0 on the plane, n into free space), spring/PID to p0, viscous field, or PC_FORCE.
 * p0 and n may be NULL (zero). */
int hg_set_scene(hg_dev_t *dev, int kind, const double p0[3], const double n[3], double k,
                 double b, double ki);
/* A PC force [N] lasting ttl_ms on the device, computed from the state with seq `answers`
 * (for the latency). No reply: a refusal surfaces as HG_E_REFUSED from a later call.
 * Non-finite values are HG_E_ARG and nothing is sent. *counter (may be NULL) gets its
 * counter. */
int hg_set_force(hg_dev_t *dev, const double f[3], unsigned ttl_ms, uint32_t answers,
                 uint16_t *counter);
/* STATE_PUSH at rate_hz (<= 0: the highest the link carries). HG_E_REFUSED if the link cannot
 * carry it. *rate_set (may be NULL) gets the rate set: servo rate / whole ticks. */
int hg_stream_start(hg_dev_t *dev, double rate_hz, double *rate_set);
int hg_stream_stop(hg_dev_t *dev);
/* The next streamed state in order (a bounded queue; the oldest are dropped when it is full),
 * waiting at most timeout_s; a silent stream is HG_E_LINK_LOST. */
int hg_next_push(hg_dev_t *dev, hg_dev_state_t *out, double timeout_s);
/* The newest streamed state without waiting; HG_E_TIMEOUT if none has arrived yet. */
int hg_latest_push(hg_dev_t *dev, hg_dev_state_t *out);
/* Wait until a push newer than seq `after` arrives (at most timeout_s), and return it. */
int hg_wait_push(hg_dev_t *dev, uint32_t after, hg_dev_state_t *out, double timeout_s);
int hg_get_stats(hg_dev_t *dev, hg_dev_stats_t *out);
/* Called by the reader thread for every push, before any waiter sees it (diagnostic logs),
 * with the library's lock held: it must return quickly and must not call this library.
 * NULL removes it. */
typedef void (*hg_push_hook)(const hg_dev_state_t *s, void *user);
int hg_set_push_hook(hg_dev_t *dev, hg_push_hook hook, void *user);
/* ---------------------------------------------------------------- calibration and bring-up
 * One axis's calibration (SET_CALIB / GET_CALIB; dsp-fw/README.md, "Calibration"): flags
 * HG_CAL_HOMED | HG_CAL_ALIGNED (| HG_CAL_DIR_SEEN), enc_dir +1/-1, phases_swapped 0/1,
 * pole_pairs, index_to_zero counts, comm_offset the FPGA's OFFSET code 0..1023. The device
 * applies it at once; it refuses (HG_E_REFUSED) a field out of range, pole pairs other than
 * the FPGA's, or any SET_CALIB while the forces are enabled or a bring-up step runs. An axis
 * other than 0..2, or a field that does not fit its byte, is HG_E_ARG and nothing is sent. */
int hg_set_calib(hg_dev_t *dev, unsigned axis, const hg_axis_calib_t *cal);
int hg_get_calib(hg_dev_t *dev, unsigned axis, hg_axis_calib_t *out);
/* n raw entries {B, A} (A in bits 7:0, B in 15:8, signed codes) of the FPGA's capture buffer
 * from entry `start` (CAP_READ, HG_CAP_READ_MAX per request). HG_E_REFUSED past the buffer's
 * end (or without one) and while a bring-up step runs. */
int hg_read_capture(hg_dev_t *dev, unsigned start, unsigned n, uint16_t *words);
/* Start a bring-up step (BU_START; `hapgate bringup` drives the whole sequence): step 1 ALIGN,
 * 2 HOME, 3 RESTART, 4 GUIDED, 5 IDENT, 6 ENCODER (dsp-fw/README.md, "Bring-up"); expect (may
 * be NULL: zeros) the joint signs GUIDED watches; seed IDENT's. *result gets 0 (started) or the
 * firmware's refusal (HG_BU_ERR_*), *value and *limit its figures (each may be NULL). The step
 * runs on the device; ask hg_bu_progress at least every 250 ms (silence aborts it). */
int hg_bu_start(hg_dev_t *dev, unsigned step, unsigned axis, const int expect[3], uint32_t seed,
                int *result, double *value, double *limit);
typedef struct {
    int state;               /* hg_bu_state_t: 0 idle (the last step has ended)             */
    int step, axis;
    int err;                 /* HG_BU_* of the last step (0 OK)                             */
    uint32_t ticks, tick_limit; /* servo ticks into the step, and its bound                 */
    double value, limit;     /* the error's figures                                        */
    uint32_t seq;            /* FPGA SEQ of the step's last snapshot                       */
    unsigned servo_hz;
    double t_s;              /* device time into the step: ticks / servo_hz                */
} hg_bu_progress_t;
int hg_bu_progress(hg_dev_t *dev, hg_bu_progress_t *out);
/* Stop a running bring-up step at once (BU_ABORT: zero torque before the reply);
 * HG_E_REFUSED from a device without bring-up. */
int hg_bu_abort(hg_dev_t *dev);
/* Bytes written as they are, for tests of the device's frame checks. */
int hg_write_raw(hg_dev_t *dev, const void *bytes, size_t n);

/* ---------------------------------------------------------------- the servo loop
 * The callback gets the newest streamed state and writes the force [N, device frame] to f.
 * It returns 0 to go on, anything else to end the loop (status HG_OK). A force longer than
 * the device's f_max is scaled to 0.999 f_max (counted); a non-finite one ends the loop with
 * HG_E_ARG and is not sent. The loop thread never allocates; states that arrive while the
 * callback runs are skipped (counted as missed ticks), so a slow callback never stalls the
 * link. Where the OS allows it, the loop and the reader run at a real-time priority while a
 * loop runs (stats.realtime says whether it was granted). */
typedef int (*hg_loop_fn)(const hg_dev_state_t *s, double f[3], void *user);

typedef struct {
    int running;
    int status;              /* why it ended: HG_OK, HG_E_LINK_LOST, HG_E_FAULT, ...       */
    double rate_hz;          /* the stream rate set                                        */
    uint64_t calls;          /* callbacks run = FORCE frames sent                          */
    double device_s;         /* device time from the first to the last callback's state    */
    double achieved_hz;      /* (calls - 1) / device_s                                     */
    uint64_t missed_ticks;   /* stream periods whose state no callback saw                 */
    uint64_t clamped;        /* forces scaled down to 0.999 f_max                          */
    double interval_ms[3];   /* p50, p99, max: device time between the callbacks' states   */
    double latency_ms[3];    /* p50, p99, max: state tick -> the first tick rendering the
                                force computed from it (reported by the device)            */
    uint64_t latency_n;
    int realtime;            /* the loop and reader threads got SCHED_FIFO priority (root,
                                CAP_SYS_NICE or an rtprio limit), as HDAPI's scheduler has */
} hg_loop_stats_t;

int hg_loop_start(hg_dev_t *dev, double rate_hz, unsigned ttl_ms, hg_loop_fn fn, void *user);
/* Stop the loop (if running), wait for its thread, and return its stats (may be NULL). The
 * return value is the loop's own status: why it ended. */
int hg_loop_stop(hg_dev_t *dev, hg_loop_stats_t *stats);
/* The stats so far, the loop running or not. */
int hg_loop_get_stats(hg_dev_t *dev, hg_loop_stats_t *stats);

#ifdef __cplusplus
}
#endif

#endif /* HAPGATE_H */
