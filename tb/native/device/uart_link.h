// SPDX-License-Identifier: Apache-2.0
// The firmware's PC link on a UART, for the virtual device: bytes from a (pseudo-terminal) fd
// reach hg_link_rx_byte() and the firmware's replies and pushes leave at the configured baud,
// 10 bit-times per byte each way, all in simulated time on the 1 us grid. The harness calls
// uart_link_service() from its background loop (between ISRs). Pacing: realtime | free.
#ifndef UART_LINK_H
#define UART_LINK_H

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <string>

extern "C" {
#include "hg_bringup.h"
#include "hg_servo.h"
}

struct UartLink;

namespace hg_uart {
// The line itself, for the soc fidelity (HG_SOC: the firmware runs on the SoC's CPU, whose UART
// pins the harness drives): 8N1 at `bit` clocks per bit (CLK_HZ / baud, fractional: each bit's
// edge rounded from the byte's start, as a PC's UART times it from its own clock). The PC's
// bytes go out on rx back to back; tx is sampled in the middle of each bit from the falling
// edge of its start bit; a byte whose stop bit is low is counted as a framing error, dropped.
struct UartPins {
    double bit = 48.0;
    // towards the SoC
    std::deque<uint8_t> rxq;
    uint64_t rx_next = UINT64_MAX;   // the next edge rx changes (or a byte may start)
    uint64_t rx_t0 = 0;
    int rx_k = -1;                   // bit in progress (-1: idle)
    unsigned rx_frame = 0;
    // from the SoC
    bool tx_busy = false;
    uint64_t tx_start = 0, tx_next = 0;
    int tx_k = 0;
    unsigned tx_bits = 0;
    std::string decoded;             // bytes received whole, not yet taken
    uint64_t framing = 0;

    uint64_t at_bit(uint64_t t0, int k) const {
        return t0 + static_cast<uint64_t>(std::llround(bit * k));
    }
    // A byte for the SoC, from edge e on (after those queued).
    void send(uint8_t b, uint64_t e) {
        rxq.push_back(b);
        if (rx_k < 0 && rx_next == UINT64_MAX) rx_next = e + 1;
    }
    // At rising edge e, before the next evaluation: rx (the level to drive), tx (the pin now).
    __attribute__((always_inline)) void at(uint64_t e, uint8_t& rx, int tx) {
        if (e >= rx_next) rx_step(e, rx);
        if (tx_busy ? e >= tx_next : tx == 0) tx_step(e, tx);
    }
    void rx_step(uint64_t e, uint8_t& rx) {
        if (rx_k < 0) {                      // start a byte, if any
            if (rxq.empty()) { rx_next = UINT64_MAX; return; }
            rx_frame = (static_cast<unsigned>(rxq.front()) << 1) | (1u << 9);
            rxq.pop_front();
            rx_t0 = e;
            rx_k = 0;
        } else if (++rx_k == 10) {           // the stop bit has ended
            rx_k = -1;
            rx_next = rxq.empty() ? UINT64_MAX : e;
            if (!rxq.empty()) rx_step(e, rx);
            return;
        }
        rx = static_cast<uint8_t>((rx_frame >> rx_k) & 1u);
        rx_next = at_bit(rx_t0, rx_k + 1);
    }
    void tx_step(uint64_t e, int tx) {
        if (!tx_busy) {                      // the start bit's falling edge
            tx_busy = true;
            tx_start = e;
            tx_k = 0;
            tx_bits = 0;
            tx_next = tx_start + static_cast<uint64_t>(std::llround(bit * 0.5));
            return;
        }
        tx_bits |= static_cast<unsigned>(tx & 1) << tx_k;
        if (++tx_k == 10) {
            tx_busy = false;
            if ((tx_bits & 1u) == 0 && (tx_bits >> 9) & 1u) decoded.push_back(static_cast<char>((tx_bits >> 1) & 0xFFu));
            else ++framing;
            return;
        }
        tx_next = tx_start + static_cast<uint64_t>(std::llround(bit * (tx_k + 0.5)));
    }
};
}  // namespace hg_uart

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

// The soc fidelity (HG_SOC): the link's firmware side is the SoC's UART pins. The harness calls
// uart_link_service at grid points as above (s is null at open); the PC's bytes are handed to
// `pins` one byte time before they have crossed the line, its decoded bytes go to the PC. The
// link's counters are the firmware's own (in the CPU's RAM): `counters` reads them.
void uart_link_attach_pins(UartLink* u, hg_uart::UartPins* pins, uint32_t clk_hz,
                           void (*counters)(void* ctx, uint32_t out[4]), void* ctx);

#endif  // UART_LINK_H
