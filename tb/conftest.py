"""pytest setup for every test under tb/: the pinned tool environment first, and the longest
tests scheduled first (with `-n auto` a long test collected last would run alone at the end)."""

from __future__ import annotations

import os

import pytest
from hapgate.base import toolenv

toolenv.apply()
# The device builds' profile-guided optimisation doubles each build's compile time and changes no
# result: the suite builds without it, and test_closed_loop.py::test_pgo_build_changes_nothing
# builds it on purpose (hapgate.device.runner.pgo_enabled).
os.environ.setdefault("HG_PGO", "0")

# Tests of 15 s or more on this machine (`pytest --durations=40`), longest first: collection
# order puts them wherever their file sorts, and xdist hands tests out in that order.
LONG_FIRST = (
    "tb/boards/test_board_tops.py::test_board_netlist_hx8k",
    "tb/bus/test_hg_bus.py::test_random_accesses",
    "tb/bus/test_hg_bus.py::test_directed",
    "tb/bus/test_hg_bus.py::test_random_accesses_16mhz",
    "tb/top/test_top_netlist.py",
    "tb/interp/test_calib_native.py::test_ten_million_samples_disturbed_no_divergence",
    "tb/boards/test_board_tops.py::test_board_top_bit_exact",
    "tb/device/test_soak.py",
    "tb/interp/test_enc_interp_netlist.py",
    "tb/commutation/test_commutator.py::test_commutator_rtl",
    "tb/cosim/test_cosim.py::test_wall_normal_run",
    "tb/dac_sched/test_dac_sched.py::test_schedule_timing_rtl",
)


def _rank(item: pytest.Item) -> int:
    for i, prefix in enumerate(LONG_FIRST):
        if item.nodeid.startswith(prefix):
            return i
    return len(LONG_FIRST)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=_rank)   # stable: the rest keep their order
