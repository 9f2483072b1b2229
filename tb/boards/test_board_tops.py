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

from pathlib import Path

import pytest
from hapgate.base.block import Block
from hapgate.flows import boards
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent
TOP_TESTS = HERE.parent / "top"
CLK_HZ = 16_000_000
SAMPLES = {"verilator": 4000, "icarus": 1500}   # 1 MSPS: microseconds of simulated time
RESET_SYNC_CLOCKS = 4                           # both board tops: 4-stage reset release
# board name -> (harness BOARD, ADC lead in samples)
CASES = {"ice40-hx8k": (0, 1), "ecp5-evn": (1, 0)}


def harness_block(board: str) -> Block:
    # every bus board's sources: the harness names both board tops (one per generate branch);
    # the SoC board has no DSP bus (its own test: tb/boards/test_soc_board.py)
    srcs = dict.fromkeys(s for b in boards.BOARDS.values() if not b.soc
                         for s in boards.block(b).sources)
    return Block(name=f"board_harness_{board}", top="board_harness", sources=tuple(srcs),
                 params=lambda: {}, doc=f"{board} board top in the simulation harness")


def config(board: str) -> configs.Config:
    """The board's named configuration at the simulated clock."""
    return configs.get(boards.BOARDS[board].config).replace(clk_hz=CLK_HZ)


def harness_params(board: str) -> dict[str, object]:
    """The board top's simulation parameters (flows/boards.py, from its configuration) that
    the harness passes on."""
    takes = boards.module_params(HERE / "board_harness.v")
    p = boards.board_params(boards.BOARDS[board], sim=True, clk_hz=CLK_HZ)
    return {"BOARD": CASES[board][0], **{k: v for k, v in p.items() if k in takes}}


def env(board: str, samples: int, prefix: str = "") -> dict[str, str]:
    sel, lead = CASES[board]
    scope = prefix + ("g_hx8k" if sel == 0 else "g_ecp5") + ".u_board.u_top.u_bus"
    return {"HG_SAMPLES": str(samples), "HG_RESET_CYCLES": "24",
            "HG_RESET_DELAY": str(RESET_SYNC_CLOCKS), "HG_ADC_LEAD": str(lead),
            "HG_BUS_SCOPE": scope}


def test_every_bus_board_runs_here() -> None:
    assert set(CASES) == {n for n, b in boards.BOARDS.items() if not b.soc}


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("board", list(CASES))
def test_board_top_bit_exact(simulator: str, board: str) -> None:
    # the board top's check: the firmware-like run through its pins, bit-exact against the
    # model (the power-up truth check homed_truth runs on the core in tb/top/test_top.py)
    sim.run_cocotb(harness_block(board), simulator, "cocotb_top", TOP_TESTS,
                   testcase="firmware_like_run",
                   params=harness_params(board), config=config(board),
                   extra_sources=[HERE / "board_harness.v"],
                   extra_env=env(board, SAMPLES[simulator]))


def test_board_netlist_hx8k() -> None:
    """The HX8K board top's iCE40 netlist beside its RTL, 600 samples (about a minute on
    Icarus): see tb/boards/gatelevel_board_tops.py, where both boards run (`make gatelevel`)."""
    from gatelevel_board_tops import run_netlist

    run_netlist("ice40-hx8k")
