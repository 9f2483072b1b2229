// SPDX-License-Identifier: Apache-2.0
// The testbench wrapper of every Verilated harness (ZipCPU testb.h style): the model and its
// context, reset, the clock's edges and their count, and the VCD trace (a build with Verilator's
// --trace). Used by the virtual device (device_harness.cpp), the co-simulation
// (tb/native/cosim/cosim.h), the interpolator and the commutation harnesses; every top it wraps
// has the ports clk and rst (active high). A top with simulation-only stage clocks beside clk
// (docs/design/SIMULATION.md) passes their driver to the edge functions: clocks(true) raises
// the ones that tick with this edge, clocks(false) lowers them all.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "verilated.h"
#if VM_TRACE
#include "verilated_vcd_c.h"
#endif

namespace hg_tb {

// No clocks besides clk.
struct NoClocks {
    void operator()(bool) const {}
};

template <class Top>
class TestB {
public:
    TestB() : ctx(new VerilatedContext), top(new Top(ctx.get())) {
        top->clk = 0;
        top->rst = 1;
    }
    ~TestB() {
        top->final();
#if VM_TRACE
        if (tfp) tfp->close();
#endif
    }
    TestB(const TestB&) = delete;
    TestB& operator=(const TestB&) = delete;

    // rst high for n full clocks (not counted), the other inputs as they are; starts and ends
    // with clk low
    template <class Clocks = NoClocks>
    void hold_reset(int n, Clocks clocks = {}) {
        top->rst = 1;
        for (int i = 0; i < n; ++i) cycle(clocks);
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
    // the clock's rising edge (counted) and falling edge, each evaluated (and traced: the
    // rising edge n at time 2n, the falling edge after it at 2n + 1)
    template <class Clocks = NoClocks>
    void rise(Clocks clocks = {}) {
        top->clk = 1;
        clocks(true);
        top->eval();
        ++edge;
        dump(2 * edge);
    }
    template <class Clocks = NoClocks>
    void fall(Clocks clocks = {}) {
        top->clk = 0;
        clocks(false);
        top->eval();
        dump(2 * edge + 1);
    }
    // one full clock, not counted (reset, table loading before the release)
    template <class Clocks = NoClocks>
    void cycle(Clocks clocks = {}) {
        top->clk = 1;
        clocks(true);
        top->eval();
        top->clk = 0;
        clocks(false);
        top->eval();
    }

#if VM_TRACE
    // Trace every signal to a VCD file from now on (call before the first evaluation).
    void trace(const std::string& path) {
        Verilated::traceEverOn(true);
        tfp.reset(new VerilatedVcdC);
        top->trace(tfp.get(), 99);
        tfp->open(path.c_str());
    }
    void dump(uint64_t t) {
        if (tfp) tfp->dump(t);
    }
    std::unique_ptr<VerilatedVcdC> tfp;
#else
    void dump(uint64_t) {}
#endif

    std::unique_ptr<VerilatedContext> ctx;
    std::unique_ptr<Top> top;
    uint64_t edge = 0;   // rising edges since the release
};

}  // namespace hg_tb
