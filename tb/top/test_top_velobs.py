"""The velocity observer through the whole FPGA (hapgate_top with VEL_OBS = 1, VEL_OBS_SEL = 1):
VEL_CTRL reset values, write/read-back, and the VEL snapshot (observer or FIR per axis) against
the models. Icarus (a quick build of the whole top; the Verilator top builds are the other
tests')."""

from __future__ import annotations

from pathlib import Path

from hapgate.flows import blocks
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent


def test_top_velocity_observer() -> None:
    simulator = sim.one_simulator()   # (Verilator in a coverage run)
    cfg = configs.get("observer").replace(clk_hz=8_000_000)
    sim.run_cocotb(blocks.get("hapgate_top"), simulator, "cocotb_top_velobs", HERE,
                   config=cfg, extra_env={"HG_SAMPLES": "700"})
