"""What synthesis made of the interpolator: Yosys's gate-level netlists of rtl/interp/enc_interp.v
(generic gates; and iCE40 cells, with the velocity history in an SB_RAM40_4K), simulated with
Yosys's own cell models, bit-exact against the golden model like the RTL itself (picorv32's
test_synth habit: it catches a simulation/synthesis mismatch, e.g. a block RAM's read-during-
write behaviour). On Icarus, which compiles a 14k-gate flat netlist at once; Verilator's C++
compile of it takes about two minutes, beyond this suite's budget (it passes too: run this file
with HG_NETLIST_SIM=verilator)."""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import pytest
from hapgate.base.block import Block
from hapgate.flows import blocks, flow
from hapgate.golden import interp
from hapgate.runners import sim

HERE = Path(__file__).parent
SIMULATOR = os.environ.get("HG_NETLIST_SIM") or (
    "icarus" if "icarus" in sim.simulators() else "verilator")
SAMPLES = {"verilator": 3000, "icarus": 800}
BUILD_ARGS = {
    # one C++ file (a precompiled header races in a parallel make), no optimisation
    "verilator": ["--output-split", "0", "-MAKEFLAGS", "OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0"],
    # Icarus 11 has no default values on input ports, which iCE40 cells_sim.v uses
    "icarus": ["-DNO_ICE40_DEFAULT_ASSIGNMENTS"],
}


@pytest.mark.parametrize("target", ["generic", "ice40"])
def test_netlist_bit_exact(target: str) -> None:
    rtl = blocks.get("enc_interp")
    cfg = interp.InterpConfig()
    net = flow.netlist(rtl, cfg.rtl_params(), target)
    gate = Block(name=f"enc_interp_{target}_netlist", top=rtl.top,
                 sources=(str(net), str(flow.simlib(target))), params=dict, doc="netlist")
    sim.run_cocotb(gate, SIMULATOR, "cocotb_enc_interp", HERE, params={},
                   testcase="scenario_bit_exact", build_args=BUILD_ARGS[SIMULATOR],
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg)),
                              "HG_SCENARIO": "dropout_controls",
                              "HG_SAMPLES": str(SAMPLES[SIMULATOR])})
