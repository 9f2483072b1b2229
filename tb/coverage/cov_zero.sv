// SPDX-License-Identifier: MIT
// Coverage builds only (make coverage): bound into each block's top by a generated
// `bind <top> hg_cov_zero ...` so that the RTL stays untouched. Zeroes every coverage count of
// the model at the first release of `rst` (Verilator's manual: counts before reset are noise).
// Later resets keep their counts. At the model's final(), it writes the counts to a new file
// in $HG_COVERAGE_RUN_DIR, else $HG_COVERAGE_DIR (if set): one file per simulation process,
// cocotb or native harness alike (every harness calls final()). Its own lines are not measured.
`timescale 1ns / 1ps
`default_nettype none
/*verilator coverage_off*/
module hg_cov_zero (
    input wire rst  // the block's synchronous active-high reset
);
    reg zeroed = 1'b0;
    always @(negedge rst) begin
        if (!zeroed) begin
            $c("Verilated::threadContextp()->coveragep()->zero();");
            zeroed <= 1'b1;
        end
    end
    final begin
        $c("{ const char* d = std::getenv(\"HG_COVERAGE_RUN_DIR\");",
           "  if (!d) d = std::getenv(\"HG_COVERAGE_DIR\");",
           "  if (d) { std::string f = std::string(d) + \"/sim-XXXXXX\";",
           "    int fd = mkstemp(&f[0]); if (fd >= 0) { close(fd);",
           "      Verilated::threadContextp()->coveragep()->write(f); } } }");
    end
endmodule
/*verilator coverage_on*/
`default_nettype wire
