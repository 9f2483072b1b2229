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


def _row(module: str, folder: str, lines: list[int], toggles: list[int]) -> coverage.Row:
    return coverage.Row(module, str(RTL / folder / f"{module}.v"),
                        {"line": [(f"line {i}", i, c) for i, c in enumerate(lines)],
                         "branch": [],
                         "toggle": [(f"t{i}", 1, c) for i, c in enumerate(toggles)]}, 0)


def test_block_table_sums_a_folders_modules() -> None:
    rs = [_row("enc_interp", "interp", [1, 0, 3, 4], [1, 1]),      # 3 of 4 lines
          _row("enc_calib", "interp", [0, 2, 2, 2, 2, 2], [0, 1]),  # 5 of 6
          _row("dac_sched", "dac_sched", [1], [])]
    fg = [coverage.FuncGroup("interp", 7, 8, ("x",)), coverage.FuncGroup("dac_sched", 0, 0, ())]
    lines = coverage.block_table(rs, fg).splitlines()
    assert lines[2] == "| `rtl/dac_sched/` | 100.0 % | — | — | — | 0 |"
    # interp: 8 of 10 lines, 3 of 4 toggles, 7 of 8 bins
    assert lines[3] == "| `rtl/interp/` | 80.0 % | — | 75.0 % | 87.5 % of 8 | 0 |"


def test_readme_table_is_replaced_between_its_markers(tmp_path: Path) -> None:
    f = tmp_path / "README.md"
    f.write_text(f"a\n{coverage.README_BEGIN}\nold\n{coverage.README_END}\nb\n")
    coverage.write_readme_table("| new |\n", f)
    assert f.read_text() == f"a\n{coverage.README_BEGIN}\n| new |\n{coverage.README_END}\nb\n"
    f.write_text("no markers\n")
    with pytest.raises(coverage.BadInput, match="README.md"):
        coverage.write_readme_table("| new |\n", f)


def test_the_readme_carries_a_generated_table() -> None:
    text = coverage.README.read_text()
    body = text[text.index(coverage.README_BEGIN) + len(coverage.README_BEGIN):
                text.index(coverage.README_END)].strip().splitlines()
    assert body[0].startswith("| block | lines | branches | port toggles | functional bins")
    assert {r.split("|")[1].strip() for r in body[2:]} >= {
        f"`rtl/{b}/`" for b in ("interp", "commutation", "dac_sched", "bus", "top")}
