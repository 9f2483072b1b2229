"""`hapgate pnr` fails on a fit or timing failure, and names it, without a place and route:
the verdict (hapgate.flows.boards.judge) on a real nextpnr report of an HX8K build that used
76.6 % of the logic cells (tb/boards/data, trimmed to its fmax and utilisation), on the same
report with its figures moved across each limit, and the command's exit code."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from hapgate.commands import cli
from hapgate.flows import boards
from hapgate.flows.flow import Finding

HERE = Path(__file__).parent
REPORT = json.loads((HERE / "data" / "hx8k_76pct.report.json").read_text())
HX8K = boards.BOARDS["ice40-hx8k"]
CLK = "clk$SB_IO_IN_$glb_clk"


def _report(lc: int | None = None, fmax: float | None = None) -> dict:
    r = copy.deepcopy(REPORT)
    if lc is not None:
        r["utilization"]["ICESTORM_LC"]["used"] = lc
    if fmax is not None:
        r["fmax"][CLK]["achieved"] = fmax
    return r


def test_real_report_fails_the_fit() -> None:
    fmax, res, problems = boards.judge(HX8K, 0, "", REPORT)
    assert res["ICESTORM_LC"] == 5881 and res["ICESTORM_LC/avail"] == 7680
    assert fmax == pytest.approx(65.83, abs=0.01)
    assert problems == ["fit: ICESTORM_LC 5881/7680 = 76.6% > 75%"]


@pytest.mark.parametrize("lc, ok", [(5760, True), (5761, False)])  # 75 % of 7680 = 5760
def test_fit_limit_is_75_percent(lc: int, ok: bool) -> None:
    _, _, problems = boards.judge(HX8K, 0, "", _report(lc=lc))
    assert (problems == []) == ok, problems


@pytest.mark.parametrize("fmax, ok", [(14.4, True), (14.39, False)])  # 1.2 x 12 MHz
def test_timing_margin_is_20_percent(fmax: float, ok: bool) -> None:
    _, _, problems = boards.judge(HX8K, 0, "", _report(lc=5000, fmax=fmax))
    assert (problems == []) == ok, problems
    if not ok:
        assert problems[0].startswith("timing margin: fmax 14.4 MHz < 1.20 x 12 MHz")


def test_nextpnr_exit_code_decides() -> None:
    """nextpnr exits 1 on a timing failure but still writes its report: the code fails it."""
    _, _, problems = boards.judge(HX8K, 1, "ERROR: Max frequency for clock ... FAIL", _report(5000))
    assert problems == ["nextpnr exit 1: ERROR: Max frequency for clock ... FAIL"]
    _, _, problems = boards.judge(HX8K, 1, "crashed", None)
    assert problems == ["nextpnr exit 1: crashed", "nextpnr wrote no report"]


def test_command_exits_1_and_names_the_failure(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    def fake_pnr(board: boards.Board, seeds: int = 1, timeout_s: float = 0.0) -> Finding:
        fmax, res, problems = boards.judge(board, 0, "", REPORT)
        return Finding("nextpnr", board.name, not problems, 0.0,
                       f"fmax {fmax:.1f} MHz\nseed 1: " + "\n".join(problems), res)

    monkeypatch.setattr(boards, "pnr", fake_pnr)
    assert cli.main(["pnr", "ice40-hx8k"]) == 1
    out = capsys.readouterr()
    assert "FAIL" in out.out and "ICESTORM_LC 5881/7680 (77%)" in out.out
    assert "fit: ICESTORM_LC 5881/7680 = 76.6% > 75%" in out.err
    assert cli.main(["pnr", "no-such-board"]) == 2
    assert cli.main(["pnr", "ice40-hx8k", "--timeout", "0"]) == 2
    assert "up5k-interp" in capsys.readouterr().err   # the unknown-board message names it
