"""The whole FPGA (rtl/top/hapgate_top.v): DAC codes bit-exact against the chained golden models,
every bus read against the register model, interrupt period, and zero torque within one frame
after a watchdog expiry, an axis fault or a disable; both simulators (shorter on Icarus)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import top
from hapgate.runners import sim

HERE = Path(__file__).parent
SAMPLES = {"verilator": 10000, "icarus": 2500}   # 1 MSPS: microseconds of simulated time


@pytest.mark.parametrize("simulator", sim.simulators())
def test_top_bit_exact(simulator: str) -> None:
    cfg = top.TopConfig(clk_hz=50_000_000)
    sim.run_cocotb(blocks.get("hapgate_top"), simulator, "cocotb_top", HERE,
                   params=cfg.rtl_params(), testcase="firmware_like_run",
                   extra_env={"HG_SAMPLES": str(SAMPLES[simulator])})


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_top_homed_truth(seed: int) -> None:
    """DAC codes against the float angle of the homed shaft, three random power-up positions per
    seed (one per axis) over the whole revolution (Verilator; 5000 samples = 5 ms each)."""
    cfg = top.TopConfig(clk_hz=50_000_000)
    sim.run_cocotb(blocks.get("hapgate_top"), "verilator", "cocotb_top", HERE,
                   params=cfg.rtl_params(), testcase="homed_truth",
                   extra_env={"HG_SAMPLES": "5000", "HG_SEED": str(seed)})
