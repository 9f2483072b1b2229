// SPDX-License-Identifier: Apache-2.0
// The firmware's PC link on a UART, for the virtual device: bytes from a (pseudo-terminal) fd
// reach hg_link_rx_byte() and the firmware's replies and pushes leave at the configured baud,
// 10 bit-times per byte each way, all in simulated time on the 1 us grid. The harness calls
// uart_link_service() from its background loop (between ISRs). Pacing: realtime | free.
#ifndef UART_LINK_H
#define UART_LINK_H

#include <cstdint>
#include <cstdio>

extern "C" {
#include "hg_bringup.h"
#include "hg_servo.h"
}

struct UartLink;

// Read the link config (lines "fd = N", "baud = N", "pace = realtime|free", or instead of fd
// "script = PATH": a scripted PC) and attach the firmware link to servo s. On a bad config it
// prints "error: FILE: line N: ..." and exits 2.
//   A script has one line per burst, "T_US HEX": the bytes HEX (two hex digits each) are put
//   on the line at scene time T_US (us from scene time 0, non-decreasing), one byte time
//   apart, after whatever is still on the line. A scripted link reads no pty, writes nothing
//   (the firmware's bytes are counted and dropped), is never paced and ends with the run.
UartLink* uart_link_open(const char* cfg_path, hg_servo_t* s, uint32_t servo_hz);
// Scripted link: its times are scene times; g0_us is the grid point of scene time 0.
bool uart_link_scripted(const UartLink* u);
void uart_link_set_origin(UartLink* u, uint64_t g0_us);
// "link_good=N link_bad=N link_timeouts=N link_bytes_in=N link_bytes_out=N" (key=value words).
void uart_link_summary(const UartLink* u, FILE* out);
// The firmware's link counters: good, bad (all causes), replayed, timeouts.
void uart_link_counters(const UartLink* u, uint32_t out[4]);
// One background-loop pass at grid point g_us (between ISRs). On SIGINT/SIGTERM it prints the
// link summary and ends the process with exit status 0.
void uart_link_service(UartLink* u, uint64_t g_us);
// Make bring-up reachable over the link (its messages, and its abort on disable and silence).
void uart_link_set_bringup(UartLink* u, hg_bringup_t* b);

#endif  // UART_LINK_H
