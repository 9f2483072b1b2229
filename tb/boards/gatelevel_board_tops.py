"""Gate-level runs of the board tops (a dedicated target, not part of `make test`: the ECP5
run alone takes minutes): `make gatelevel` (= pytest tb/boards/gatelevel_board_tops.py).

The board top's post-synthesis netlist beside its RTL on the same pins (tb/boards/
board_gl_harness.v), compared at every clock edge, while the whole-FPGA test
(tb/top/cocotb_top.py) checks the RTL against the chained golden models: on that run the netlist
is bit-exact against the model. The HX8K's netlist is made of iCE40 cells (synth_ice40,
simulated with Yosys's cell models); the ECP5's of Yosys's generic gates (its block-RAM cell
model ships only as a black box; Icarus 11 cannot parse the rest), flat, tri-states kept,
flip-flops powering up at 0. The fast one (HX8K) also runs in `make test`:
tb/boards/test_board_tops.py::test_board_netlist_hx8k."""

from __future__ import annotations

import os

import pytest
from hapgate.base.block import Block
from hapgate.flows import boards
from hapgate.runners import sim
from test_board_tops import CASES, HERE, TOP_TESTS, config, env, harness_block, harness_params

GL_SAMPLES = 600   # a short run: the netlists are 10-20k cells


def run_netlist(board: str) -> None:
    """The board top's post-synthesis netlist (iCE40 cells for the HX8K; Yosys's generic gates
    for the ECP5, whose block-RAM cell model Yosys ships as a black box) beside its RTL on the
    same pins, compared at every clock edge, while the whole-FPGA test checks the RTL against
    the model: the netlist is bit-exact against the model on that run. Icarus (Verilator's C++
    compile of a flat netlist takes minutes: HG_NETLIST_SIM=verilator runs it there)."""
    simulator = os.environ.get("HG_NETLIST_SIM") or (
        "icarus" if "icarus" in sim.simulators() else "verilator")
    b = boards.BOARDS[board]
    hp = harness_params(board)
    net = boards.gate_netlist(b, {k: v for k, v in hp.items() if k != "BOARD"})
    blk = harness_block(board)
    gl = Block(name=f"board_gl_{board}", top="board_gl_harness",
               sources=(*blk.sources, str(net), *map(str, boards.cell_models(b))), params=dict,
               doc="board top: RTL and netlist side by side")
    define = "GL_HX8K" if CASES[board][0] == 0 else "GL_ECP5"
    args = {"icarus": [f"-D{define}", "-DNO_ICE40_DEFAULT_ASSIGNMENTS"],
            "verilator": [f"-D{define}", "--output-split", "0", "-MAKEFLAGS",
                          "OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0"]}[simulator]
    sim.run_cocotb(gl, simulator, "cocotb_top", TOP_TESTS, params=hp, config=config(board),
                   testcase="firmware_like_run",
                   extra_sources=[HERE / "board_harness.v", HERE / "board_gl_harness.v"],
                   build_args=args, extra_env=env(board, GL_SAMPLES, prefix="u_rtl."))


@pytest.mark.parametrize("board", list(CASES))
def test_board_netlist_matches_rtl_and_model(board: str) -> None:
    run_netlist(board)
