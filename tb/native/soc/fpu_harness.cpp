// SPDX-License-Identifier: Apache-2.0
// The SoC's float unit (rtl/soc/hg_fpu_cfu.v) alone, driven through its custom-function port as
// VexRiscv's CfuPlugin drives it: a command held with valid until ready, the response taken when
// valid and ready are both high. The pacing is random (seeded): gaps before a command and clocks
// with the response not taken, so that a result must wait.
//
//   fpu_harness in=FILE out=FILE [seed=N] [stall=0|1]
//
// in: records of three little-endian 32-bit words (function id, rs1, rs2); out: per record the
// result word and the clocks from the command's acceptance to its response's first valid clock.
// stdout: key=value lines (commands, responses, clocks, the longest latency per function id,
// protocol errors: a response with no command outstanding, a command accepted while one is).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "Vhg_fpu_cfu.h"
#include "testb.h"

int main(int argc, char** argv) {
    std::string in_path, out_path;
    unsigned seed = 1;
    bool stall = true;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto eq = a.find('=');
        const std::string k = a.substr(0, eq), v = eq == std::string::npos ? "" : a.substr(eq + 1);
        if (k == "in") {
            in_path = v;
        } else if (k == "out") {
            out_path = v;
        } else if (k == "seed") {
            seed = static_cast<unsigned>(std::strtoul(v.c_str(), nullptr, 0));
        } else if (k == "stall") {
            stall = v == "1";
        } else {
            std::fprintf(stderr, "error: unknown argument %s\n", a.c_str());
            return 2;
        }
    }
    FILE* in = std::fopen(in_path.c_str(), "rb");
    if (!in) {
        std::fprintf(stderr, "error: cannot read %s\n", in_path.c_str());
        return 2;
    }
    std::vector<uint32_t> rec;
    uint32_t w[3];
    while (std::fread(w, sizeof w, 1, in) == 1) rec.insert(rec.end(), w, w + 3);
    std::fclose(in);
    const size_t n = rec.size() / 3;
    std::vector<uint32_t> out(2 * n, 0);

    hg_tb::TestB<Vhg_fpu_cfu> tb;
    auto* top = tb.top.get();
    top->cmd_valid = 0;
    top->rsp_ready = 0;
    tb.reset(4);

    std::mt19937 rng(seed);
    size_t sent = 0, got = 0;
    uint64_t accepted_at = 0, errors = 0, latency_max[4] = {0, 0, 0, 0};
    bool outstanding = false, seen_valid = false;
    int gap = 0;
    while (got < n) {
        if (tb.edge > 200ull * (n + 16)) {
            std::fprintf(stderr, "error: no response to command %zu\n", got);
            return 1;
        }
        // this clock's inputs
        if (!top->cmd_valid && sent < n) {
            if (gap > 0) {
                --gap;
            } else {
                top->cmd_valid = 1;
                top->cmd_function_id = rec[3 * sent] & 0x3FFU;
                top->cmd_inputs_0 = rec[3 * sent + 1];
                top->cmd_inputs_1 = rec[3 * sent + 2];
            }
        }
        top->rsp_ready = stall ? (rng() % 4 != 0) : 1;
        top->eval();
        // what the rising edge takes
        const bool cmd_fire = top->cmd_valid && top->cmd_ready;
        const bool rsp_fire = top->rsp_valid && top->rsp_ready;
        if (top->rsp_valid && !seen_valid) {
            seen_valid = true;
            if (!outstanding) {
                ++errors;
            } else if (got < n) {
                const uint64_t lat = tb.edge - accepted_at;
                out[2 * got + 1] = static_cast<uint32_t>(lat);
                const unsigned f = rec[3 * got] & 3U;
                if (lat > latency_max[f]) latency_max[f] = lat;
            }
        }
        if (rsp_fire) {
            if (!outstanding || got >= n) {
                ++errors;
            } else {
                out[2 * got] = top->rsp_outputs_0;
                ++got;
            }
            outstanding = false;
            seen_valid = false;
        }
        tb.rise();
        if (cmd_fire) {
            if (outstanding) ++errors;
            outstanding = true;
            accepted_at = tb.edge;
            ++sent;
            top->cmd_valid = 0;
            gap = stall ? static_cast<int>(rng() % 3) : 0;
        }
        tb.fall();
    }
    FILE* o = std::fopen(out_path.c_str(), "wb");
    if (!o || std::fwrite(out.data(), sizeof(uint32_t), out.size(), o) != out.size()) {
        std::fprintf(stderr, "error: cannot write %s\n", out_path.c_str());
        return 2;
    }
    std::fclose(o);
    std::printf("commands=%zu\nresponses=%zu\nclocks=%llu\nprotocol_errors=%llu\n", sent, got,
                static_cast<unsigned long long>(tb.edge), static_cast<unsigned long long>(errors));
    for (unsigned f = 0; f < 4; ++f)
        std::printf("latency_max_%u=%llu\n", f, static_cast<unsigned long long>(latency_max[f]));
    return 0;
}
