"""Capture buffer (rtl/capture/hg_capture.v) against hapgate.golden.capture, clock by clock:
immediate and index triggers, decimation, every axis select, read-back, re-arm, stop and reset
mid-capture. At 4 clocks per sample (the least the all-axes writes allow) on Verilator and at 5
on Icarus; a 256-entry buffer keeps it short."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import capture
from hapgate.runners import sim

HERE = Path(__file__).parent
CLOCKS = {"verilator": 4_000_000, "icarus": 5_000_000}


@pytest.mark.parametrize("simulator", sim.simulators())
def test_capture_bit_exact(simulator: str) -> None:
    sim.run_cocotb(blocks.get("hg_capture"), simulator, "cocotb_hg_capture", HERE,
                   params=capture.capture_params(depth_log2=8, clk_hz=CLOCKS[simulator]),
                   testcase="capture_bit_exact")
