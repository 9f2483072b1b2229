"""DSP bus + register file (rtl/bus/): RDL conformance, >= 10^5 random accesses against the
register model (Verilator; 10^4 on Icarus, the slow second opinion), too-short strobes, the
servo-tick period, the watchdog and snapshot coherence, on both simulators; and a second FPGA
clock (16 MHz: other bus-to-FPGA clock ratios)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import regmap
from hapgate.runners import sim

HERE = Path(__file__).parent
ACCESSES = {"verilator": 100_000, "icarus": 10_000}
DIRECTED = ["rdl_conformance", "short_strobes", "tick_period", "watchdog", "snapshot_coherence",
            "same_clock_coincidences"]


def _run(simulator: str, testcase: str | list[str], clk_hz: int = 50_000_000,
         accesses: int = 2000, seed: int = 1, extra: dict[str, int] | None = None) -> None:
    sim.run_cocotb(blocks.get("hg_bus"), simulator, "cocotb_hg_bus", HERE,
                   params=regmap.bus_params(clk_hz) | (extra or {}), testcase=testcase,
                   extra_env={"HG_ACCESSES": str(accesses), "HG_SEED": str(seed)})


@pytest.mark.parametrize("simulator", sim.simulators())
def test_directed(simulator: str) -> None:
    _run(simulator, DIRECTED)


@pytest.mark.parametrize("simulator", sim.simulators())
def test_random_accesses(simulator: str) -> None:
    _run(simulator, "random_accesses", accesses=ACCESSES[simulator])


def test_random_accesses_16mhz() -> None:
    """A slower FPGA clock: the same bus timings are now 0.08..1 FPGA clocks per bus clock."""
    _run("verilator", ["random_accesses", "rdl_conformance"], clk_hz=16_000_000,
         accesses=20_000, seed=2)


def test_random_accesses_vel_bits() -> None:
    """VEL_BITS = 19 (the interpolator's stored velocity width, which hapgate_top passes: the
    velocity snapshot and its conversion only 19 bits wide) with an odd SAMPLE_HZ, whose
    canonical signed digits include a subtracted least significant one: every VEL read of the
    random run (velocities over the whole 19-bit range) against the model's floor(v * SAMPLE_HZ
    / 2**VEL_LOG2W). The default run above checks the shift-adds of 1 MHz at VEL_BITS = 32."""
    _run("icarus", "random_accesses", accesses=2500, seed=3,
         extra={"VEL_BITS": 19, "SAMPLE_HZ": 999_999})
