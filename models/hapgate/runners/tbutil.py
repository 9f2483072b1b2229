"""Small helpers shared by the cocotb testbenches (imported inside the simulator process)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge
from cocotb.utils import get_sim_time

from ..golden import configs, emif
from . import cocotb_emif


def config() -> configs.Config:
    """The named configuration (or sweep point of one) the runner built the DUT with
    (`sim.run_cocotb(config=...)`)."""
    text = os.environ.get(CONFIG_ENV)
    if not text:
        raise RuntimeError(f"{CONFIG_ENV} is not set: run this module through "
                           "hapgate.runners.sim.run_cocotb(..., config=...)")
    return configs.from_json(text)


CONFIG_ENV = "HG_CONFIG"


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


class TopBus:
    """The whole FPGA top brought out of reset with its bus ready (the calibration, velocity
    observer and harmonic-table benches share it): clock started, ADC inputs zero, reset for 4
    clocks, the bus monitor recording from the reset edge `ref`. `wr` / `rd` access a register
    by name with random EMIF timing from `rng`."""

    def __init__(self, dut, period_ps: int, words: dict[str, int], rng) -> None:
        self.dut, self.period_ps, self.words, self.rng = dut, period_ps, words, rng
        self.master = cocotb_emif.EmifMaster(dut)
        self.mon: cocotb_emif.Monitor | None = None
        self.ref = 0

    async def start(self, *watch: str) -> TopBus:
        dut = self.dut
        cocotb.start_soon(Clock(dut.clk, self.period_ps, unit="ps").start())
        dut.adc_a.value = 0
        dut.adc_b.value = 0
        dut.enc_index.value = 0
        dut.rst.value = 1
        await ClockCycles(dut.clk, 4)
        self.ref = int(get_sim_time(unit="ps"))
        dut.rst.value = 0
        self.mon = cocotb_emif.Monitor(dut, self.period_ps, self.ref, scope=dut.u_bus)
        self.mon.start(*watch)
        return self

    async def wr(self, name: str, v: int) -> None:
        await self.master.write(self.words[name], v, emif.random_timing(self.rng, self.period_ps))

    async def rd(self, name: str) -> int:
        return await self.master.read(self.words[name], emif.random_timing(self.rng,
                                                                           self.period_ps))


async def drive_top_adc(dut, a, b) -> None:
    """Present sample k of every axis (a, b: shape (n, 3) signed codes) at the k-th ADC strobe."""
    for k in range(a.shape[0]):
        await RisingEdge(dut.adc_strobe)
        dut.adc_a.value = sum((int(a[k, i]) & 0xFF) << (8 * i) for i in range(3))
        dut.adc_b.value = sum((int(b[k, i]) & 0xFF) << (8 * i) for i in range(3))
