"""The whole FPGA (rtl/top/hapgate_top.v) in every named configuration
(models/hapgate/configs.toml): DAC codes bit-exact against the chained golden models, every bus
read against the register model, interrupt period, and zero torque within one frame after a
watchdog expiry, an axis fault or a disable; and the DAC codes against the float angle of the
homed shaft. The paper's on both simulators (shorter on Icarus), the others on Verilator."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent
SAMPLES = {"verilator": 10000, "icarus": 2500}   # 1 MSPS: microseconds of simulated time
OTHER_SAMPLES = 4000      # the other configurations: 4 ms, past the homing, fault and watchdog
CLK_HZ = 50_000_000       # a whole number of ps per clock (cocotb's precision)


def point(name: str) -> configs.Config:
    """The configuration as simulated here: at CLK_HZ; the calibration block of one line
    (`hires`: the build tb/top/test_top_calib.py and test_top_harm.py share)."""
    cfg = configs.get(name).replace(clk_hz=CLK_HZ)
    return cfg.replace(cal_lines_log2=0) if cfg.cal else cfg


CASES = [("paper", s) for s in sim.simulators()] + [
    (n, "verilator") for n in configs.names() if n != "paper"]


@pytest.mark.parametrize("name, simulator", CASES)
def test_top_bit_exact(name: str, simulator: str, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = point(name)
    if cfg.cal:   # the larger model needs the precompiled-header flag (docs/design/TOOLCHAIN.md)
        monkeypatch.setenv("MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include")
    n = SAMPLES[simulator] if name == "paper" else OTHER_SAMPLES
    sim.run_cocotb(blocks.get("hapgate_top"), simulator, "cocotb_top", HERE, config=cfg,
                   testcase="firmware_like_run", extra_env={"HG_SAMPLES": str(n)})


TRUTH = [("paper", s) for s in (1, 2, 3)] + [(n, 1) for n in configs.names() if n != "paper"]


@pytest.mark.parametrize("name, seed", TRUTH)
def test_top_homed_truth(name: str, seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """DAC codes against the float angle of the homed shaft, three random power-up positions per
    seed (one per axis) over the whole revolution (Verilator; 5000 samples = 5 ms each)."""
    cfg = point(name)
    if cfg.cal:
        monkeypatch.setenv("MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include")
    sim.run_cocotb(blocks.get("hapgate_top"), "verilator", "cocotb_top", HERE, config=cfg,
                   testcase="homed_truth",
                   extra_env={"HG_SAMPLES": "5000", "HG_SEED": str(seed)})
