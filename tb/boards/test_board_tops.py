"""Board tops (rtl/boards/) simulated through their real pins: the whole-FPGA test
(tb/top/cocotb_top.py: DAC words and load times bit-exact against the chained golden models,
every bus read against the register model, interrupt period, zero torque after watchdog, fault
and disable) runs on tb/boards/board_harness.v, which drives the board top's reset pin (through
its synchroniser and power-on reset), its bidirectional data pins and, for the HX8K, the ADC
pair adapter with three-state converter models. Both simulators.

The boards' own clocks are 12 MHz (HX8K) and 48 MHz (ECP5 PLL output); neither period is a
whole number of ps (cocotb's 1 ps precision), so the tops run at 16 MHz here (CLK_HZ is the
only way the RTL knows its clock; the ECP5 PLL is bypassed, USE_PLL=0)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hapgate.base.block import Block
from hapgate.flows import boards
from hapgate.golden.top import TopConfig
from hapgate.runners import sim

HERE = Path(__file__).parent
TOP_TESTS = HERE.parent / "top"
CLK_HZ = 16_000_000
SAMPLES = {"verilator": 4000, "icarus": 1500}   # 1 MSPS: microseconds of simulated time
RESET_SYNC_CLOCKS = 4                           # both board tops: 4-stage reset release
# board name -> (harness BOARD, extra parameters, ADC lead in samples)
CASES = {"ice40-hx8k": (0, {"SERIAL_MUL": 1}, 1), "ecp5-evn": (1, {"USE_PLL": 0}, 0)}


def harness_block(board: str) -> Block:
    # every board's sources: the harness names both board tops (one per generate branch)
    srcs = dict.fromkeys(s for b in boards.BOARDS.values() for s in boards.block(b).sources)
    return Block(name=f"board_harness_{board}", top="board_harness", sources=tuple(srcs),
                 params=lambda: {}, doc=f"{board} board top in the simulation harness")


def harness_params(board: str) -> dict[str, object]:
    sel, extra, _ = CASES[board]
    p = TopConfig(clk_hz=CLK_HZ).rtl_params()
    return {"BOARD": sel, "CLK_HZ": CLK_HZ, **extra, "ASIN_FILE": p["ASIN_FILE"],
            "SINE_FILE": p["SINE_FILE"]}


def env(board: str, samples: int, prefix: str = "") -> dict[str, str]:
    sel, _, lead = CASES[board]
    scope = prefix + ("g_hx8k" if sel == 0 else "g_ecp5") + ".u_board.u_top.u_bus"
    return {"HG_SAMPLES": str(samples), "HG_RESET_CYCLES": "24",
            "HG_RESET_DELAY": str(RESET_SYNC_CLOCKS), "HG_ADC_LEAD": str(lead),
            "HG_BUS_SCOPE": scope}


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("board", list(CASES))
def test_board_top_bit_exact(simulator: str, board: str) -> None:
    sim.run_cocotb(harness_block(board), simulator, "cocotb_top", TOP_TESTS,
                   params=harness_params(board), extra_sources=[HERE / "board_harness.v"],
                   extra_env=env(board, SAMPLES[simulator]))


GL_SAMPLES = 600   # a short run: the netlists are 10-20k cells


@pytest.mark.parametrize("board", list(CASES))
def test_board_netlist_matches_rtl_and_model(board: str) -> None:
    """The board top's post-synthesis netlist (device cells) beside its RTL on the same pins,
    compared at every clock edge, while the whole-FPGA test checks the RTL against the model:
    the netlist is bit-exact against the model on that run. Icarus (Verilator's C++ compile of
    a flat netlist takes minutes: HG_NETLIST_SIM=verilator runs it there)."""
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
    sim.run_cocotb(gl, simulator, "cocotb_top", TOP_TESTS, params=hp,
                   extra_sources=[HERE / "board_harness.v", HERE / "board_gl_harness.v"],
                   build_args=args, extra_env=env(board, GL_SAMPLES, prefix="u_rtl."))
