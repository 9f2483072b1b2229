"""The per-stage timing flow (`hapgate pnr up5k-interp`, hapgate.flows.stage) and the seed
sweep's bookkeeping (hapgate.flows.boards), without a place and route: the generated wrapper
elaborates around every variant (Icarus), the verdict and critical path come out of a real
nextpnr report of the arcsine variant on the UP5K (tb/boards/data, trimmed to its fmax, its
utilisation and the two ends of its critical path), the seed report and the per-seed timeout."""

from __future__ import annotations

import copy
import csv
import dataclasses
import json
import subprocess
from pathlib import Path

import pytest
from hapgate.base import report as base_report
from hapgate.flows import boards, flow, stage
from hapgate.golden.interp import interp3_params

HERE = Path(__file__).parent
REPORT = json.loads((HERE / "data" / "up5k_interp_arcsine.report.json").read_text())


@pytest.mark.parametrize("variant", sorted(stage.VARIANTS))
def test_wrapper_elaborates_around_every_variant(variant: str, tmp_path: Path) -> None:
    """Every input and output port of enc_interp3 (AXES = 1) is wired (Icarus -Wall: a port
    the wrapper names that does not exist, or a width mismatch, is an error or a warning)."""
    params = interp3_params(stage.VARIANTS[variant], clk_hz=stage.CLK_HZ, axes=1)
    wrap = tmp_path / "wrap.v"
    wrap.write_text(stage.wrapper_text(params))
    name = "stage_wrap_" + "".join(c for c in variant if c.isalnum())
    blk = dataclasses.replace(stage._block(), name=name,
                              sources=(*stage._block().sources, str(wrap)))
    f = flow.lint_icarus(blk, {})
    assert f.ok, f.detail


def test_critical_path_and_verdict_from_a_real_report() -> None:
    fmax, a, b = stage.critical_path(REPORT)
    assert fmax == pytest.approx(27.69, abs=0.01)
    assert ".b_a_" in a and "lut_ext" in b        # stage B: magnitude register -> table
    run = stage.StageRun("arcsine", 1, True, fmax, a, b, 1194, 10.0, 8.0)
    row = stage.summary_rows([run])[0]
    assert row[2] == "27.7/27.7/27.7" and row[4] == "FAILS"
    fast = dataclasses.replace(run, fmax_mhz=48.0, seed=2)
    assert stage.summary_rows([fast])[0][4] == "meets"
    assert stage.summary_rows([run, fast])[0][4] == "FAILS"   # the slowest seed decides
    empty = copy.deepcopy(REPORT)
    empty["critical_paths"] = []
    assert stage.critical_path(empty)[1:] == ("", "")


def test_seed_report(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(base_report, "REPORTS", tmp_path)
    runs = [boards.PnrResult(1, True, 61.6, 40.0, cpu_s=38.0),
            boards.PnrResult(2, False, 0.0, 595.0, "did not finish", cpu_s=479.0),
            boards.PnrResult(3, True, 67.0, 41.0, cpu_s=39.0)]
    assert boards.seed_summary([61.6, 67.0, 63.0]) == (61.6, 63.0, 67.0)
    path = boards.write_seed_report(boards.BOARDS["ice40-hx8k"], runs, 24.0)
    rows = list(csv.reader(path.open()))
    assert rows[0][:3] == ["board", "seed", "fmax_mhz"] and len(rows) == 5
    assert rows[2][5] == "FAIL" and rows[-1][1] == "min/median/max over 2 of 3"
    assert rows[-1][2] == "61.60/64.30/67.00" and rows[-1][5] == "FAIL"
    with pytest.raises(ValueError):
        boards.seed_summary([])


def test_place_route_timeout_is_a_failure(monkeypatch: pytest.MonkeyPatch) -> None:
    """A nextpnr that does not finish (router1 livelocked on the HX8K, seed 2) fails the seed
    instead of hanging the sweep."""
    def slow(*args, **kwargs):
        raise subprocess.TimeoutExpired(args[0], kwargs.get("timeout"))
    monkeypatch.setattr(boards.subprocess, "run", slow)
    r, res = boards.place_route(boards.BOARDS["ice40-hx8k"], 99, timeout_s=0.01)
    assert not r.ok and "did not finish within 0.01 s" in r.detail and res == {}
