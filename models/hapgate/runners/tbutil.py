"""Small helpers shared by the cocotb testbenches (imported inside the simulator process)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge


def params() -> dict[str, object]:
    """The parameter set the runner built the DUT with (strings unquoted, numbers as int)."""
    raw: dict[str, str] = json.loads(os.environ.get("HG_PARAMS", "{}"))
    out: dict[str, object] = {}
    for k, v in raw.items():
        out[k] = Path(v[1:-1]) if v.startswith('"') else int(v)
    return out


def model_config() -> dict[str, object]:
    """The golden-model configuration the pytest side passed along (HG_MODEL, JSON)."""
    return json.loads(os.environ.get("HG_MODEL", "{}"))


async def start(dut, period_ns: float, reset_cycles: int = 4) -> None:
    """Start the clock on dut.clk and pulse dut.rst (synchronous, active high)."""
    cocotb.start_soon(Clock(dut.clk, period_ns, unit="ns").start())
    dut.rst.value = 1
    await ClockCycles(dut.clk, reset_cycles)
    dut.rst.value = 0
    await RisingEdge(dut.clk)


# The interpolator's result ports, in the native harness's column order (native.COLUMNS), and
# how each is read: "s" signed, "u" unsigned, "b" a single bit.
INTERP_OUTPUTS = (("pos", "m_pos", "s"), ("pos_homed", "m_pos_homed", "s"),
                  ("vel", "m_vel", "s"), ("index_pos", "m_index_pos", "s"),
                  ("index_count", "m_index_count", "u"), ("homed", "m_homed", "b"),
                  ("faults", "m_faults", "u"), ("overspeed_count", "m_overspeed_count", "u"))


def append_interp_outputs(dut, cols: dict[str, list[int]]) -> None:
    """Append the interpolator's result ports (enc_interp / enc_interp3 of one axis) to cols."""
    for col, port, kind in INTERP_OUTPUTS:
        v = getattr(dut, port).value
        cols[col].append(v.to_signed() if kind == "s" else v.to_unsigned() if kind == "u"
                         else int(v))
