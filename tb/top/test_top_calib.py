"""The calibration path through the whole FPGA (hapgate_top with CAL = 1): enable, freeze and
read-back of the live estimates over the bus, and the calibrated positions, against the models;
both simulators (Verilator with the ratio angle stage and the harmonic table built: `config`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent
SAMPLES = {"verilator": 2000, "icarus": 600}


def config(simulator: str) -> configs.Config:
    """`hires` with a calibration block of one line, at 50 MHz. Verilator: as it is (the ratio
    stage and the harmonic table too: the issue-13 chain), one build shared with
    tb/top/test_top_harm.py and test_top.py; Icarus: the paper's arcsine after the calibration."""
    cfg = configs.get("hires").replace(clk_hz=50_000_000, cal_lines_log2=0)
    return cfg if simulator == "verilator" else cfg.replace(angle="arcsine")


@pytest.mark.parametrize("simulator", sim.simulators())
def test_top_calibration(simulator: str, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = config(simulator)
    if simulator == "verilator":
        # the larger model needs the precompiled-header flag (docs/design/TOOLCHAIN.md); cocotb's
        # runner calls make itself, which reads variable assignments from MAKEFLAGS
        monkeypatch.setenv("MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include")
    sim.run_cocotb(blocks.get("hapgate_top"), simulator, "cocotb_top_calib", HERE,
                   config=cfg, extra_env={"HG_SAMPLES": str(SAMPLES[simulator])})
