// SPDX-License-Identifier: Apache-2.0
// The UART of the virtual device (uart_link.h): a byte takes 10 bit-times on the line in each
// direction; what the PC wrote to the pty is read every byte time and arrives at the firmware
// one byte time after the line is free; the firmware's frames leave the same way. Everything
// happens at 1 us grid points, so the link is independent of the simulated clock. At the soc
// fidelity (HG_SOC) the firmware's side is the SoC's UART pins (hg_uart::UartPins): a PC byte
// starts on rx one byte time before the native link would hand it over, and the bytes decoded
// from tx go to the pty as they are complete.
#ifndef HG_SOC
#define HG_SOC 0
#endif
#include "uart_link.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

extern "C" {
#include "hg_link.h"
}

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Byte {
    double t_us;  // grid time at which the byte has crossed the line
    uint8_t b;
};

}  // namespace

struct UartLink {
    hg_link_t link;
    hg_servo_t* servo = nullptr;
    int fd = -1;
    uint32_t baud = 1000000;
    bool realtime = true;
    double byte_us = 10.0;
    uint64_t poll_us = 10;
    std::deque<Byte> rx, tx;  // bytes on the line, towards the firmware / the PC
    std::string out;          // bytes that have crossed the line, not yet written to the pty
    double rx_free_us = 0, tx_free_us = 0;
    uint64_t next_read_us = 0;
    // pacing
    bool started = false;
    uint64_t g0_us = 0;
    std::chrono::steady_clock::time_point w0;
    uint64_t next_pace_us = 0;
    std::chrono::steady_clock::time_point last_slow_note;
    double worst_lag_s = 0;
    // counters
    uint64_t bytes_in = 0, bytes_out = 0, bytes_lost = 0;
    // scripted PC (script = PATH): bursts at scene times, relative to grid point origin_us
    struct Burst { uint64_t t_us; std::string bytes; };
    std::deque<Burst> script;
    bool scripted = false;
    uint64_t origin_us = 0;
    // soc fidelity: the pins, the clock, and the firmware's own counters
    hg_uart::UartPins* pins = nullptr;
    uint64_t clocks_per_us = 0;
    void (*counters)(void*, uint32_t[4]) = nullptr;
    void* counters_ctx = nullptr;
};

namespace {

[[noreturn]] void cfg_fail(const char* path, int line, const std::string& why) {
    std::fprintf(stderr, "error: %s: line %d: %s\n", path, line, why.c_str());
    std::exit(2);
}

int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

void read_script(UartLink* u, const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        std::fprintf(stderr, "error: %s: cannot read\n", path.c_str());
        std::exit(2);
    }
    std::string line;
    int n = 0;
    uint64_t last = 0;
    while (std::getline(in, line)) {
        ++n;
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        std::string t, hex, extra;
        if (!(ls >> t >> hex) || (ls >> extra)) cfg_fail(path.c_str(), n, "expected T_US HEX");
        char* end = nullptr;
        const unsigned long long tu = std::strtoull(t.c_str(), &end, 10);
        if (*end || t[0] == '-' || tu < last) cfg_fail(path.c_str(), n, "T_US " + t + ": expected a non-decreasing whole number");
        if (hex.size() % 2) cfg_fail(path.c_str(), n, "HEX: an even number of hex digits");
        UartLink::Burst b{tu, {}};
        for (size_t i = 0; i < hex.size(); i += 2) {
            const int hi = hex_digit(hex[i]), lo = hex_digit(hex[i + 1]);
            if (hi < 0 || lo < 0) cfg_fail(path.c_str(), n, "HEX: not a hex digit");
            b.bytes.push_back(static_cast<char>(hi * 16 + lo));
        }
        last = tu;
        u->script.push_back(std::move(b));
    }
}

}  // namespace

UartLink* uart_link_open(const char* cfg_path, hg_servo_t* s, uint32_t servo_hz) {
    auto* u = new UartLink;
    std::ifstream in(cfg_path);
    if (!in) {
        std::fprintf(stderr, "error: %s: cannot read\n", cfg_path);
        std::exit(2);
    }
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
        ++n;
        const auto eq = line.find('=');
        if (line.empty() || line[0] == '#') continue;
        auto fail = [&](const std::string& why) { cfg_fail(cfg_path, n, why); };
        if (eq == std::string::npos) fail("expected key = value");
        std::string key = line.substr(0, eq), val;
        key.erase(key.find_last_not_of(" \t") + 1);
        std::istringstream vs(line.substr(eq + 1));
        vs >> val;
        if (key == "fd") u->fd = std::atoi(val.c_str());
        else if (key == "script") {
            read_script(u, val);
            u->scripted = true;
            u->realtime = false;
        }
        else if (key == "baud") {
            const long b = std::atol(val.c_str());
            if (b < 1200 || b > 12000000) fail("baud " + val + ": expected 1200..12000000");
            u->baud = static_cast<uint32_t>(b);
        } else if (key == "pace") {
            if (val != "realtime" && val != "free") fail("pace " + val + ": expected realtime or free");
            u->realtime = val == "realtime";
        } else fail("unknown key " + key);
    }
    if (u->scripted && u->fd >= 0) {
        std::fprintf(stderr, "error: %s: fd and script exclude each other\n", cfg_path);
        std::exit(2);
    }
    if (!u->scripted) {
        if (u->fd < 0 || fcntl(u->fd, F_GETFD) < 0) {
            std::fprintf(stderr, "error: %s: fd %d is not open\n", cfg_path, u->fd);
            std::exit(2);
        }
        fcntl(u->fd, F_SETFL, fcntl(u->fd, F_GETFL) | O_NONBLOCK);
    }
    u->servo = s;
    u->byte_us = 10.0 * 1e6 / u->baud;
    u->poll_us = u->byte_us >= 2 ? static_cast<uint64_t>(u->byte_us) : 1;
#if !HG_SOC
    hg_link_init(&u->link, s);
    u->link.cfg.baud = u->baud;
#endif
    (void)servo_hz;
    if (u->scripted) return u;       // ends with the run, like any scene
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    prctl(PR_SET_PDEATHSIG, SIGTERM);  // a server never outlives the process that started it
    if (getppid() == 1) g_stop = 1;
    return u;
}

bool uart_link_scripted(const UartLink* u) { return u->scripted; }
void uart_link_set_origin(UartLink* u, uint64_t g0_us) { u->origin_us = g0_us; }

void uart_link_summary(const UartLink* u, FILE* out) {
    uint32_t c[4];
    uart_link_counters(u, c);
    std::fprintf(out, "link_good=%u link_bad=%u link_timeouts=%u link_bytes_in=%llu link_bytes_out=%llu\n",
                 c[0], c[1], c[3], static_cast<unsigned long long>(u->bytes_in),
                 static_cast<unsigned long long>(u->bytes_out));
    if (u->pins) std::fprintf(out, "link_tx_framing=%llu\n", static_cast<unsigned long long>(u->pins->framing));
}

void uart_link_attach_pins(UartLink* u, hg_uart::UartPins* pins, uint32_t clk_hz,
                           void (*counters)(void*, uint32_t[4]), void* ctx) {
    u->pins = pins;
    u->clocks_per_us = clk_hz / 1000000u;
    pins->bit = static_cast<double>(clk_hz) / u->baud;
    u->counters = counters;
    u->counters_ctx = ctx;
}

void uart_link_counters(const UartLink* u, uint32_t out[4]) {
    if (u->counters) {
        u->counters(u->counters_ctx, out);
        return;
    }
    const hg_link_stats_t& st = u->link.st;
    out[0] = st.good;
    out[1] = st.bad_framing + st.bad_crc + st.bad_version + st.bad_type + st.bad_len;
    out[2] = st.replayed;
    out[3] = st.timeouts;
}

[[maybe_unused]] static void queue_tx(UartLink* u, const uint8_t* b, size_t n, double g) {
    double t = std::max(u->tx_free_us, g);
    for (size_t i = 0; i < n; ++i) {
        t += u->byte_us;
        u->tx.push_back({t, b[i]});
    }
    u->tx_free_us = t;
}

static void pace(UartLink* u, uint64_t g) {
    const auto now = std::chrono::steady_clock::now();
    if (!u->started) {
        u->started = true;
        u->g0_us = g;
        u->w0 = now;
        u->last_slow_note = now;
        return;
    }
    const double sim = static_cast<double>(g - u->g0_us) * 1e-6;
    const double wall = std::chrono::duration<double>(now - u->w0).count();
    if (sim > wall + 200e-6) {
        std::this_thread::sleep_for(std::chrono::duration<double>(sim - wall));
    } else if (wall - sim > 0.1) {
        u->worst_lag_s = std::max(u->worst_lag_s, wall - sim);
        if (std::chrono::duration<double>(now - u->last_slow_note).count() > 5.0) {
            u->last_slow_note = now;
            std::fprintf(stderr, "pace: cannot keep real time: the device runs at %.2fx real time "
                         "(%.2f s behind)\n", sim / wall, wall - sim);
        }
    }
}

void uart_link_service(UartLink* u, uint64_t g_us) {
    const double g = static_cast<double>(g_us);
    if (g_stop && u->pins) {
        uint32_t c[4];
        uart_link_counters(u, c);
        std::fprintf(stderr, "link: bytes in %llu out %llu lost %llu | frames good %u bad %u replayed %u "
                     "timeouts %u | tx framing errors %llu\n",
                     static_cast<unsigned long long>(u->bytes_in), static_cast<unsigned long long>(u->bytes_out),
                     static_cast<unsigned long long>(u->bytes_lost), c[0], c[1], c[2], c[3],
                     static_cast<unsigned long long>(u->pins->framing));
        std::fflush(stderr);
        std::_Exit(0);
    }
    if (g_stop) {
        const hg_link_stats_t& st = u->link.st;
        std::fprintf(stderr, "link: bytes in %llu out %llu lost %llu | frames good %u bad %u "
                     "rejected %u replayed %u pushed %u push_dropped %u timeouts %u\n",
                     static_cast<unsigned long long>(u->bytes_in),
                     static_cast<unsigned long long>(u->bytes_out),
                     static_cast<unsigned long long>(u->bytes_lost), st.good,
                     st.bad_framing + st.bad_crc + st.bad_version + st.bad_type + st.bad_len,
                     st.rejected, st.replayed, st.pushed, st.push_dropped, st.timeouts);
        std::fflush(stderr);
        std::_Exit(0);
    }
    if (u->scripted) {  // the scripted PC's bursts, due at their scene times
        while (!u->script.empty() && u->origin_us + u->script.front().t_us <= g_us) {
            for (const char c : u->script.front().bytes) {
                u->rx_free_us = std::max(u->rx_free_us, g) + u->byte_us;
                u->rx.push_back({u->rx_free_us, static_cast<uint8_t>(c)});
                ++u->bytes_in;
            }
            u->script.pop_front();
        }
    } else if (g_us >= u->next_read_us) {  // the PC's bytes, at most a FIFO's worth ahead
        u->next_read_us = g_us + u->poll_us;
        if (u->rx.size() < 64) {
            uint8_t buf[64];
            const ssize_t n = read(u->fd, buf, sizeof buf);
            for (ssize_t i = 0; i < n; ++i) {
                u->rx_free_us = std::max(u->rx_free_us, g) + u->byte_us;
                u->rx.push_back({u->rx_free_us, buf[i]});
            }
            if (n > 0) u->bytes_in += static_cast<uint64_t>(n);
        }
        if (u->realtime && g_us >= u->next_pace_us) {
            u->next_pace_us = g_us + 1000;
            pace(u, g_us);
        }
    }
#if HG_SOC
    // the byte starts on the rx pin one byte time before it has crossed the line
    while (!u->rx.empty() && u->rx.front().t_us - u->byte_us <= g) {
        u->pins->send(u->rx.front().b, g_us * u->clocks_per_us);
        u->rx.pop_front();
    }
    for (const char c : u->pins->decoded) u->tx.push_back({g, static_cast<uint8_t>(c)});
    u->pins->decoded.clear();
#else
    uint8_t frame[HG_LINK_MAX_FRAME];
    while (!u->rx.empty() && u->rx.front().t_us <= g) {
        const size_t m = hg_link_rx_byte(&u->link, u->rx.front().b, frame);
        u->rx.pop_front();
        if (m) queue_tx(u, frame, m, g);
    }
    const size_t m = hg_link_poll(&u->link, u->tx.empty(), frame);
    if (m) queue_tx(u, frame, m, g);
#endif
    // Bytes that have crossed the line are handed to the pty a frame at a time (at its
    // delimiter): the PC's decoder sees nothing before the delimiter anyway.
    bool flush = false;
    while (!u->tx.empty() && u->tx.front().t_us <= g) {
        u->out.push_back(u->tx.front().b);
        flush = flush || u->tx.front().b == 0;
        u->tx.pop_front();
    }
    if (u->scripted) {                 // nobody listens: count what the firmware sent
        u->bytes_out += u->out.size();
        u->out.clear();
    } else if (flush || u->out.size() >= 256) {
        const ssize_t w = write(u->fd, u->out.data(), u->out.size());
        const size_t done = w > 0 ? static_cast<size_t>(w) : 0;
        u->bytes_out += done;
        u->bytes_lost += u->out.size() - done;  // no PC on the pty, or its buffer is full
        u->out.clear();
    }
}

void uart_link_set_bringup(UartLink* u, hg_bringup_t* b) { u->link.bu = b; }
