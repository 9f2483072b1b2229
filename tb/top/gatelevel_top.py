"""Gate-level runs of the whole top that are not part of `make test` (`make gatelevel`): the
generic-gate netlist (Yosys `synth`, simcells.v on Icarus; about 80 s of CPU). The iCE40
netlist runs in `make test` (tb/top/test_top_netlist.py); both run the same check."""

from __future__ import annotations

import pytest
from test_top_netlist import run_netlist


@pytest.mark.parametrize("target", ["generic"])
def test_top_netlist_bit_exact(target: str) -> None:
    run_netlist(target)
