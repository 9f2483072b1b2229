"""The coverage report's inputs (hapgate.commands.coverage): port names read from the RTL
header (toggle coverage counts ports only), and the exclusions file refused when an entry lacks
its category or reason."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.base.paths import RTL
from hapgate.commands import coverage


def test_ports_of_a_parameterised_module() -> None:
    assert coverage.module_ports(RTL / "dac_sched" / "dac_sched.v", "dac_sched") == [
        "clk", "rst", "m_frame", "m_req", "m_req_ch", "s_valid", "s_ch", "s_data",
        "dac_data", "dac_addr", "dac_wr_n"]


def test_the_shipped_exclusions_load() -> None:
    for e in coverage.load_exclusions():
        assert e.category in coverage.CATEGORIES and e.reason.strip()


GOOD = 'module = "dac_sched"\nmetric = "branch"\nline = 168\n'


@pytest.mark.parametrize("body, message", [
    (GOOD + 'category = "UNR"\n', "`reason` must be"),
    (GOOD + 'category = "WHATEVER"\nreason = "r"\n', "category 'WHATEVER'"),
    (GOOD + 'category = "UNR"\nreason = "r"\nwho = "me"\n', "unknown keys"),
    ('module = "dac_sched"\nmetric = "toggle"\ncategory = "UNR"\nreason = "r"\n', "port"),
])
def test_bad_exclusion_is_refused(tmp_path: Path, body: str, message: str) -> None:
    f = tmp_path / "exclusions.toml"
    f.write_text("[[exclude]]\n" + body)
    with pytest.raises(coverage.BadInput, match=message):
        coverage.load_exclusions(f)
