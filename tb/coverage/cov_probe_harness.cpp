// SPDX-License-Identifier: MIT
// Harness of cov_probe.v (tb/coverage/test_covdat.py): RESET clocks in reset, then ON clocks
// with sel = 1 and OFF clocks with sel = 0 (argv[1..3]). Zeroing at reset release and writing
// the counts at final() are done by the bound hg_cov_zero (cov_zero.sv), as in every coverage
// build of the suite.
#include <cstdlib>
#include <memory>
#include "Vcov_probe.h"
#include "verilated.h"

int main(int argc, char** argv) {
    if (argc != 4) return 2;
    const int n_reset = std::atoi(argv[1]), n_on = std::atoi(argv[2]), n_off = std::atoi(argv[3]);
    auto ctx = std::make_unique<VerilatedContext>();
    auto top = std::make_unique<Vcov_probe>(ctx.get());
    auto clock = [&]() { top->clk = 0; top->eval(); top->clk = 1; top->eval(); };
    top->rst = 1;
    top->sel = 1;
    for (int i = 0; i < n_reset; ++i) clock();
    top->clk = 0;
    top->rst = 0;
    top->eval();
    for (int i = 0; i < n_on; ++i) clock();
    top->sel = 0;
    for (int i = 0; i < n_off; ++i) clock();
    top->final();
    return 0;
}
