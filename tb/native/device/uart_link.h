// SPDX-License-Identifier: Apache-2.0
// The firmware's PC link on a UART, for the virtual device: bytes from a (pseudo-terminal) fd
// reach hg_link_rx_byte() and the firmware's replies and pushes leave at the configured baud,
// 10 bit-times per byte each way, all in simulated time on the 1 us grid. The harness calls
// uart_link_service() from its background loop (between ISRs). Pacing: realtime | free.
#ifndef UART_LINK_H
#define UART_LINK_H

#include <cstdint>

extern "C" {
#include "hg_servo.h"
}

struct UartLink;

// Read the link config (lines "fd = N", "baud = N", "pace = realtime|free") and attach the
// firmware link to servo s. On a bad config it prints "error: FILE: line N: ..." and exits 2.
UartLink* uart_link_open(const char* cfg_path, hg_servo_t* s, uint32_t servo_hz);
// One background-loop pass at grid point g_us (between ISRs). On SIGINT/SIGTERM it prints the
// link summary and ends the process with exit status 0.
void uart_link_service(UartLink* u, uint64_t g_us);

#endif  // UART_LINK_H
