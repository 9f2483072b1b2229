// SPDX-License-Identifier: Apache-2.0
// Firmware co-simulation: the testbench around the Verilated hapgate_top (tick/reset, ADC
// stimulus, DAC monitor, irq edge) shared by the co-sim HAL (hal_cosim.cpp) and the scenario
// runner (cosim_harness.cpp). ZipCPU testb.h / ibex simulator_ctrl style.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "Vhapgate_top.h"
#include "bus_hal.h"
#include "harness_common.h"
#include "testb.h"

#ifndef CLK_HZ
#error "CLK_HZ must be defined (-DCLK_HZ=...) to match the RTL parameter"
#endif

namespace cosim {

// EMIF-like access timing in FPGA clocks (bus_hal.h; rtl/bus/README.md: strobe >= 5, recovery
// >= 3, setup >= 0; or wait for ready). Set from the scene's [bus] (run key cosim_bus), never on a grid.
using BusTiming = hg_bus::Timing;

struct DacLoad {
    uint64_t edge;  // clock edge at which dac_wr_n rose (the DAC load)
    int addr;       // channel 0..5 (m0a, m0b, m1a, m1b, m2a, m2b)
    int code;       // signed DAC code (dac_word.h)
};

struct BusWrite {
    uint64_t fall, rise;  // strobe fall / rise edges
    uint32_t addr, data;
    bool dropped;         // not issued (a fault injected by the scenario)
    int64_t isr;          // index of the ISR it was issued from (-1: background)
};

// The testbench: the shared wrapper (testb.h: the model, reset, the edges since the last edge
// that sampled rst high) with the top's monitors and the ADC stimulus.
class Testbench : public hg_tb::TestB<Vhapgate_top> {
public:
    Testbench();
    void reset();
    void tick();  // one full clock: posedge (monitors run) then negedge (stimulus presented)
    void pins() { top->eval(); }   // a bus pin changed (bus_hal.h)

    // stimulus: called in the clock-low phase of an adc_strobe cycle; the words are captured
    // at the next posedge (edge + 1). Writes a, b (packed 3 x int8) and index (3 bits).
    std::function<void(uint64_t capture_edge, uint32_t& a, uint32_t& b, uint32_t& idx)> adc;

    // monitors
    std::vector<DacLoad> loads;
    bool irq_rose = false;          // set on a rising edge of irq; the runner clears it
    uint64_t irq_rise_edge = 0;
    uint64_t wdog_expired_edge = 0; // first edge at which the top's wdog_expired is high (0: never)
    uint64_t fault_edge[3] = {0, 0, 0};  // first edge with the top's fault[i] high (0: never)

private:
    int prev_wr_n_ = 1;
    int prev_irq_ = 0;
};

extern Testbench* tb;  // the one the HAL drives

struct BusStats {
    uint64_t reads = 0, writes = 0, dropped = 0, not_oe = 0;
};
extern BusTiming bus_timing;
extern BusStats bus_stats;
extern std::vector<BusWrite> bus_writes;
extern int64_t current_isr;
// the scenario engine (harness_common.h; null: none): the writes its faults lose, the key writes
extern hg_dev::Scenario* scenario;

}  // namespace cosim
