"""The capture buffer through the whole FPGA (hapgate_top CAPTURE = 1, a 256-entry buffer to keep
it short): armed, polled and read back over the DSP bus; every read against the register model
with the capture model, every entry against the ADC stream, and a captured encoder signal with
3 % 2nd harmonic through the signal-quality analysis (Verilator, 50 MHz)."""

from __future__ import annotations

from pathlib import Path

from hapgate.flows import blocks
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent


def test_top_capture() -> None:
    params = configs.get("paper").replace(clk_hz=50_000_000).rtl_params() | {"CAP_DEPTH_LOG2": 8}
    sim.run_cocotb(blocks.get("hapgate_top"), "verilator", "cocotb_top_capture", HERE,
                   params=params, testcase="capture_over_bus")
