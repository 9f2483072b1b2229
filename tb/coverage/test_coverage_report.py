"""The coverage report's inputs (hapgate.commands.coverage): port names read from the RTL
header (toggle coverage counts ports only), and the exclusions file refused when an entry lacks
its category or reason."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.base import covdat
from hapgate.base.paths import ROOT, RTL
from hapgate.commands import coverage


def test_ports_of_a_parameterised_module() -> None:
    assert coverage.module_ports(RTL / "dac_sched" / "dac_sched.v", "dac_sched") == [
        "clk", "rst", "m_frame", "m_req", "m_req_ch", "s_valid", "s_ch", "s_data",
        "dac_data", "dac_addr", "dac_wr_n"]


def test_the_shipped_exclusions_load() -> None:
    """Each shipped exclusion still points at the RTL (load_exclusions checks its file, module,
    exact source text on one line, or port): an RTL move or edit fails here, in `make test`,
    rather than leaving the item silently uncovered or excluded."""
    for e in coverage.load_exclusions():
        assert e.category in coverage.CATEGORIES and e.reason.strip()
        assert (ROOT / e.file).resolve().is_relative_to(RTL.resolve())


GOOD = ('module = "dac_sched"\nmetric = "branch"\nfile = "rtl/dac_sched/dac_sched.v"\n'
        'text = "module dac_sched"\n')


@pytest.mark.parametrize("body, message", [
    (GOOD + 'category = "UNR"\n', "`reason` must be"),
    (GOOD + 'category = "WHATEVER"\nreason = "r"\n', "category 'WHATEVER'"),
    (GOOD + 'category = "UNR"\nreason = "r"\nwho = "me"\n', "unknown keys"),
    (GOOD + 'category = "UNR"\nreason = "r"\nline = 120\n', "unknown keys"),  # no bare lines
    (GOOD.replace("text", "signal") + 'category = "UNR"\nreason = "r"\n', "exact source"),
    ('module = "dac_sched"\nmetric = "toggle"\nfile = "rtl/dac_sched/dac_sched.v"\n'
     'category = "UNR"\nreason = "r"\n', "port"),
    ('module = "dac_sched"\nmetric = "toggle"\nfile = "rtl/dac_sched/dac_sched.v"\n'
     'signal = "clk"\nbits = "0:3"\ncategory = "UNR"\nreason = "r"\n', "HI below LO"),
])
def test_bad_exclusion_is_refused(tmp_path: Path, body: str, message: str) -> None:
    f = tmp_path / "exclusions.toml"
    f.write_text("[[exclude]]\n" + body)
    with pytest.raises(coverage.BadInput, match=message):
        coverage.load_exclusions(f)


# A tiny RTL module and the coverage points a run of it could give: `if` arm never taken, the
# `else` arm 5 times; d[3] never toggled.
PROBE = """module m (
    input wire clk,
    input wire [3:0] d,
    output reg q
);
    always @(posedge clk) begin
        if (d == 4'd15) q <= 1'b1;  // the arm the stimulus never takes
        else q <= 1'b0;
    end
endmodule
"""


@pytest.fixture
def probe(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """rtl/blk/m.v under tmp_path, which stands for rtl/ (coverage.RTL) in these tests."""
    src = tmp_path / "rtl" / "blk" / "m.v"
    src.parent.mkdir(parents=True)
    src.write_text(PROBE)
    monkeypatch.setattr(coverage, "RTL", tmp_path / "rtl")
    return src


def _points(src: Path) -> list[covdat.Point]:
    def pt(kind: str, line: int, col: int, comment: str, count: int) -> covdat.Point:
        return covdat.Point((("f", str(src)), ("l", str(line)), ("n", str(col)),
                             ("page", f"v_{kind}/m"), ("o", comment)), count)
    return ([pt("line", 6, 5, "block", 5), pt("line", 7, 9, "if", 0),
             pt("line", 8, 9, "else", 5)]
            + [pt("toggle", 3, 22, f"d[{b}]:{e}", 0 if b == 3 else 2)
               for b in range(4) for e in ("0->1", "1->0")])


def _load(tmp_path: Path, *entries: str) -> list[coverage.Exclusion]:
    f = tmp_path / "exclusions.toml"
    f.write_text("".join(f"[[exclude]]\nmodule = \"m\"\nfile = \"{tmp_path}/rtl/blk/m.v\"\n"
                         f"category = \"LOW_RISK\"\nreason = \"r\"\n{e}" for e in entries))
    return coverage.load_exclusions(f)


IF_ARM = 'metric = "branch"\ntext = "if (d == 4\'d15)"\narm = "if"\n'
D3 = 'metric = "toggle"\nsignal = "d"\nbits = "3"\n'


def test_exclusions_are_applied_and_counted(tmp_path: Path, probe: Path) -> None:
    pts = _points(probe)
    [row] = coverage.rows(pts, [])
    assert (row.tally("branch"), row.tally("toggle"), row.excluded) == (
        covdat.Tally(1, 2), covdat.Tally(6, 8), 0)
    [row] = coverage.checked_rows(pts, _load(tmp_path, IF_ARM, D3))
    # the `if` arm and d[3]'s rise and fall are out: 3 items excluded, the rest all covered
    assert (row.tally("branch"), row.tally("toggle"), row.excluded) == (
        covdat.Tally(1, 1), covdat.Tally(6, 6), 3)
    assert row.tally("line") == covdat.Tally(2, 3)   # a branch exclusion leaves lines alone
    fg = [coverage.FuncGroup("blk", 0, 0, ())]
    assert coverage.summary([row], fg)["m"]["excluded"] == 3
    assert coverage.blocks([row], fg)["blk"]["excluded"] == 3
    assert coverage.block_table([row], fg).splitlines()[2].split("|")[6].strip() == "3"


def test_a_stale_exclusion_is_an_error(tmp_path: Path, probe: Path) -> None:
    # the `else` line has no `cond_then` arm: the exclusion matches nothing in the run
    stale = 'metric = "branch"\ntext = "else q <= 1\'b0;"\narm = "cond_then"\n'
    with pytest.raises(coverage.BadInput, match=r"stale.*#2 \(m branch \"else q <= 1'b0;\""):
        coverage.checked_rows(_points(probe), _load(tmp_path, IF_ARM, stale))
    # in a partial run (--only, -k) it is only a warning: the run may lack the parameter set
    assert len(coverage.checked_rows(_points(probe), _load(tmp_path, stale), full=False)) == 1
    # and an exclusion of a module the run did not build is not judged
    assert coverage.checked_rows([], _load(tmp_path, stale)) == []


def test_an_exclusion_whose_source_moved_is_an_error(tmp_path: Path, probe: Path) -> None:
    exs = _load(tmp_path, IF_ARM, D3)
    probe.write_text(PROBE.replace("4'd15", "4'hf"))     # the excluded line was edited
    with pytest.raises(coverage.BadInput, match=r"#1: `text` .* is on no line of .*m\.v"):
        _load(tmp_path, IF_ARM)
    with pytest.raises(coverage.BadInput, match="no line"):
        coverage.checked_rows(_points(probe), exs)
    probe.write_text(PROBE.replace("d == 4'd15", "d == 4'd15) q <= 1'b1;\n    if (d == 4'd15"))
    with pytest.raises(coverage.BadInput, match=r"is on lines \[7, 8\]"):
        _load(tmp_path, IF_ARM)                            # now ambiguous
    probe.write_text(PROBE)
    # a text of several lines (indentation included) is one place and covers each line
    both = 'metric = "line"\ntext = """q <= 1\'b1;  // the arm the stimulus never takes\n' \
           '        else q <= 1\'b0;"""\n'
    [row] = coverage.checked_rows(_points(probe), _load(tmp_path, both))
    assert row.excluded == 2 and row.tally("line") == covdat.Tally(1, 1)
    probe.write_text(PROBE.replace("[3:0] d", "[3:0] e"))   # the port was renamed
    with pytest.raises(coverage.BadInput, match="'d' is not a port of m"):
        _load(tmp_path, D3)
    probe.write_text(PROBE.replace("module m", "module n"))
    with pytest.raises(coverage.BadInput, match="module 'm' is not declared"):
        _load(tmp_path, D3)


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
    assert lines[2] == "| `rtl/dac_sched/` | 100.0 % | — | — | — | 0 | met |"
    # interp: 8 of 10 lines, 3 of 4 toggles, 7 of 8 bins
    assert lines[3] == ("| `rtl/interp/` | 80.0 % | — | 75.0 % | 87.5 % of 8 | 0 | "
                        "line, toggle, functional |")


def test_block_table_is_put_between_its_markers() -> None:
    b, e = coverage.TABLE_BEGIN, coverage.TABLE_END
    assert coverage.put_block_table(f"a\n{b}\nold\n{e}\nb\n", "| new |\n", coverage.DOC) \
        == f"a\n{b}\n| new |\n{e}\nb\n"
    with pytest.raises(coverage.BadInput, match="coverage.md"):
        coverage.put_block_table("no markers\n", "| new |\n", coverage.DOC)


def test_the_coverage_page_carries_a_generated_block_table() -> None:
    """docs/coverage.md, as `make coverage` writes it: the block table between its markers,
    before the per-configuration tables (and the README carries none)."""
    text = coverage.DOC.read_text()
    i, j = text.index(coverage.TABLE_BEGIN), text.index(coverage.TABLE_END)
    assert i < text.index("## Configuration `suite`")
    body = text[i + len(coverage.TABLE_BEGIN):j].strip().splitlines()
    assert body[0].startswith("| block | lines | branches | port toggles | functional bins")
    assert coverage.TABLE_BEGIN not in (ROOT / "README.md").read_text()
    assert {r.split("|")[1].strip() for r in body[2:]} >= {
        f"`rtl/{b}/`" for b in ("interp", "commutation", "dac_sched", "bus", "top")}
