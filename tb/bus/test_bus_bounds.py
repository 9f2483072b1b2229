"""The FPGA watchdog at its documented boundaries (issue 29, "Boundaries"), on the bus + register
file RTL (cocotb, both simulators, the build of tb/bus/test_hg_bus.py) with the register model
replaying the same accesses: WDOG_TIMEOUT's reset value and both ends of its range (each end
accepted, one microsecond past it refused with STATUS.CFG_ERR), and the expiry exactly
WDOG_TIMEOUT x CLK_HZ / 10^6 clocks after the restarting clock at the 100 us minimum, with a key
one clock before, on and after the expiry clock.

Spec: rtl/regs/hapgate.rdl WDOG_TIMEOUT ("Microseconds without a WDOG key write before all
torque is forced to zero ... Range 100 .. 1000000; a write outside it is refused
(STATUS.CFG_ERR)", reset 10000); rtl/bus/README.md "Watchdog" ("It expires exactly
WDOG_TIMEOUT x CLK_HZ/10^6 clocks after the restarting clock; a restart on that same clock
wins")."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import regmap
from hapgate.runners import sim

HERE = Path(__file__).parent


@pytest.mark.parametrize("simulator", sim.simulators())
def test_watchdog_bounds(simulator: str) -> None:
    sim.run_cocotb(blocks.get("hg_bus"), simulator, "cocotb_bus_bounds", HERE,
                   params=regmap.bus_params(50_000_000), testcase="watchdog_bounds")
