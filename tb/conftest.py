"""pytest setup for every test under tb/: the pinned tool environment first, and the longest
tests scheduled first (with `-n auto` a long test collected last would run alone at the end)."""

from __future__ import annotations

import os
import re

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


# The second tier (`make regress`, run by CI after `make test`): tests whose length is their
# point, or that repeat on a second simulator or a netlist what the first tier proves on the
# RTL. Node-id pattern (re.search) -> why it is long and what the first tier keeps. `make test`
# deselects them (-m "not regress"), `make regress` runs only them (-m regress); an entry that
# matches no test fails the collection, so a renamed test cannot drop out of both tiers.
REGRESS: dict[str, str] = {
    r"\[(.*-)?icarus(-.*)?\]$":
        "Icarus, the second simulator: the same bit-exact checks run on Verilator in tier 1",
    r"^tb/top/test_top_netlist\.py::":
        "the top's post-synthesis netlists beside the RTL; tier 1 keeps the RTL bit-exact runs",
    r"^tb/interp/test_enc_interp_netlist\.py::":
        "the interpolator's netlist; tier 1 keeps the RTL bit-exact runs and lint's synthesis",
    r"^tb/boards/test_board_tops\.py::test_board_netlist_":
        "a board top's netlist; tier 1 keeps the board tops' RTL bit-exact runs",
    r"^tb/device/test_closed_loop\.py::test_pgo_build_changes_nothing":
        "builds the profile-guided device harness (a second, slower build of the same RTL)",
    r"^tb/interp/test_calib_native\.py::test_ten_million_samples":
        "10^7 samples for divergence; tier 1 keeps the calibration's bit-exact and truth tests",
    r"^tb/device/test_soak\.py::test_soak_1e7":
        "a 10^7-sample soak; tier 1 keeps the shorter no-slip runs",
}


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "regress: the second tier (make regress; tb/conftest.py "
                                       "REGRESS says why each test is there)")


@pytest.hookimpl(tryfirst=True)   # before -m deselects by the marker added here
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    used = dict.fromkeys(REGRESS, 0)
    for item in items:
        for pattern in REGRESS:
            if re.search(pattern, item.nodeid):
                item.add_marker(pytest.mark.regress)
                used[pattern] += 1
                break
    whole = not config.args or all(a.rstrip("/") in ("tb", str(config.rootpath / "tb"))
                                   for a in config.args)
    stale = [p for p, n in used.items() if n == 0]
    if whole and stale and not config.getoption("keyword"):
        raise pytest.UsageError("tb/conftest.py REGRESS entries that match no test: "
                                + ", ".join(stale))
    items.sort(key=_rank)   # stable: the rest keep their order
