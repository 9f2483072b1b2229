// SPDX-License-Identifier: Apache-2.0
// The testbench wrapper of the Verilated harnesses (ZipCPU testb.h style): the model and its
// context, reset, the clock's edges and the edge count. Used by the co-simulation
// (tb/native/cosim/cosim.h), the interpolator and the commutation harnesses; every top it wraps
// has the ports clk and rst (active high). The device harness keeps its own Bench (its stage
// clocks evaluate each edge with the generated scheduler, README "Stage clocks").
#pragma once

#include <cstdint>
#include <memory>

#include "verilated.h"

namespace hg_tb {

template <class Top>
class TestB {
public:
    TestB() : ctx(new VerilatedContext), top(new Top(ctx.get())) {
        top->clk = 0;
        top->rst = 1;
    }
    ~TestB() { top->final(); }
    TestB(const TestB&) = delete;
    TestB& operator=(const TestB&) = delete;

    // rst high for n full clocks (not counted), the other inputs as they are; starts and ends
    // with clk low
    void hold_reset(int n) {
        top->rst = 1;
        for (int i = 0; i < n; ++i) cycle();
    }
    // rst low: the last edge above sampled rst high, edge 0 of the count
    void release() {
        edge = 0;
        top->rst = 0;
        top->eval();
    }
    void reset(int n = 4) {
        hold_reset(n);
        release();
    }
    // the clock's rising edge (counted) and falling edge, each evaluated
    void rise() {
        top->clk = 1;
        top->eval();
        ++edge;
    }
    void fall() {
        top->clk = 0;
        top->eval();
    }
    // one full clock, not counted (reset, table loading before the release)
    void cycle() {
        top->clk = 1;
        top->eval();
        top->clk = 0;
        top->eval();
    }

    std::unique_ptr<VerilatedContext> ctx;
    std::unique_ptr<Top> top;
    uint64_t edge = 0;   // rising edges since the release
};

}  // namespace hg_tb
