"""The FPGA's converter pins against the converters' datasheet timing, in simulation time, at
every clock we ship or document (rtl/top/README.md, "Converter timing"): 12 MHz (the HX8K
board's oscillator), 24 MHz, 48 MHz (the default and the ECP5 board's PLL clock). Icarus: the
build is instant and a few frames are all it takes."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import top
from hapgate.runners import sim

HERE = Path(__file__).parent


@pytest.mark.parametrize("clk_hz", [12_000_000, 24_000_000, 48_000_000])
def test_converter_timing(clk_hz: int) -> None:
    cfg = top.TopConfig(clk_hz=clk_hz)
    # the strobe is derived from the DAC's t_WCS: 1, 2, 3 clocks (83, 83, 62.5 ns)
    assert cfg.comm.wr_cycles == {12_000_000: 1, 24_000_000: 2, 48_000_000: 3}[clk_hz]
    sim.run_cocotb(blocks.get("hapgate_top"), "icarus", "cocotb_converter_timing", HERE,
                   params=cfg.rtl_params(), testcase="converter_timing")
