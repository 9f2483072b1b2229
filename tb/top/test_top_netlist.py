"""What synthesis made of the whole FPGA: Yosys gate-level netlists of rtl/top/hapgate_top.v
(generic gates, and iCE40 cells with block RAM and the sine/arcsine ROMs as synthesized),
simulated with Yosys's own cell models on Icarus, running the top's firmware-like cocotb test
(tb/top/cocotb_top.py) on a short run: every DAC load (time, channel, word) bit-exact against
the chained golden models, every bus read against the register model, the watchdog, fault and
disable paths to zero torque. The hierarchy is kept (every module at gate level) so the test
can watch the bus wrapper's observation ports, as it does on the RTL."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hapgate.base.block import Block
from hapgate.flows import blocks, flow
from hapgate.flows.flow import param_text
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent
# 4 MHz (the top accepts any multiple of 1 MHz and of SAMPLE_HZ): 4 clocks per 1 MSPS sample,
# a 64-clock DAC frame; 600 samples = 2400 clocks, enough for the watchdog to expire. Icarus
# runs the gate-level top at a few hundred clocks per second, so 48 or 50 MHz (12x the
# clocks for the same run) stays in tb/top/test_top.py on the RTL.
CLK_HZ = 4_000_000
SAMPLES = 600
BUILD_ARGS = ["-DNO_ICE40_DEFAULT_ASSIGNMENTS"]   # Icarus 11: no defaults on input ports


# The generic-gate netlist (80 s of CPU) runs in `make gatelevel` (tb/top/gatelevel_top.py);
# `make test` keeps the iCE40 one, the cells a board is built from (and the HX8K board top's
# netlist in tb/boards/test_board_tops.py).
TARGETS_IN_MAKE_TEST = ["ice40"]


@pytest.mark.parametrize("target", TARGETS_IN_MAKE_TEST)
def test_top_netlist_bit_exact(target: str) -> None:
    run_netlist(target)


def run_netlist(target: str) -> None:
    if "icarus" not in sim.simulators():
        pytest.fail("the gate-level top runs on Icarus (apt-get install iverilog)")
    rtl = blocks.get("hapgate_top")
    cfg = configs.get("paper").replace(clk_hz=CLK_HZ)
    params = cfg.rtl_params()
    net = flow.netlist(rtl, params, target, flatten=False)
    gate = Block(name=f"hapgate_top_{target}_netlist_{net.parent.name[-10:]}", top=rtl.top,
                 sources=(str(net), str(flow.simlib(target))), params=dict, doc="netlist")
    # the netlist's own check: the firmware-like run bit-exact against the model (homed_truth,
    # the power-up-anywhere truth check, runs on the RTL in test_top.py)
    sim.run_cocotb(gate, "icarus", "cocotb_top", HERE, params={}, build_args=BUILD_ARGS,
                   testcase="firmware_like_run",
                   extra_env={"HG_SAMPLES": str(SAMPLES), "HG_CONFIG": cfg.to_json(),
                              "HG_PARAMS": json.dumps({k: param_text(v)
                                                       for k, v in params.items()})})
