"""The FPGA's torque clamp, per axis through the TQ_LIMIT registers of the whole top, at its
boundaries (issue 29, "Boundaries"): torque commands L - 1, L, L + 1, their negatives and far
past L, on three axes with three limits at once (10000 and 10003: limits where one command unit
changes the code below and above; 3: near zero), in ALIGN mode at code 255 (sin next to 1).
Verilator, on the build of tb/top/test_top.py; every code against the spec and the model.

Spec: rtl/regs/hapgate.rdl TORQUE ("+-32767 is DAC full scale at sin = 1. Clamped to
+-TQ_LIMIT") and TQ_LIMIT ("|torque| clamp in command units (0: no torque; >= 32768: no
clamp)"), rtl/top/README.md ("TQ_LIMIT is per axis"), docs/blocks/commutator.md steps 2, 3
and 5 (ALIGN, channel b 341 codes behind, clamp, round half away from zero, saturation),
docs/blocks/sine-rom.md (the ROM's formula)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent


def test_top_torque_limit_bounds() -> None:
    cfg = configs.get("paper").replace(clk_hz=50_000_000)
    sim.run_cocotb(blocks.get("hapgate_top"), "verilator", "cocotb_top_bounds", HERE,
                   config=cfg, testcase="torque_limit_bounds")


@pytest.mark.parametrize("name", ["paper", "observer", "hires"])
def test_top_fault_kinds_zero_torque(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Overspeed on one axis and signal loss on another zero those motors only, within one
    frame and the output stage, then a second reset restores the reset state
    (tb/top/cocotb_top_bounds.py says how); the top test covers clipping, the watchdog and the
    disable. In the paper's configuration and in the two whose interpolators add state that a
    reset must clear (the velocity observer; the calibration and harmonic table), each on the
    build of tb/top/test_top.py (50 MHz; `hires` with one-line calibration blocks)."""
    cfg = configs.get(name).replace(clk_hz=50_000_000)
    if cfg.cal:   # as tb/top/test_top.py: its build, and the precompiled-header flag
        cfg = cfg.replace(cal_lines_log2=0)
        monkeypatch.setenv("MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include")
    sim.run_cocotb(blocks.get("hapgate_top"), "verilator", "cocotb_top_bounds", HERE,
                   config=cfg, testcase="fault_kinds_zero_torque")
