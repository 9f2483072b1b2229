"""Functional coverage (runners/funcov.py): the bins a known stimulus must hit, the shipped
clocks, the merge across processes, and nothing written outside a coverage run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapgate.commands import coverage
from hapgate.flows import boards
from hapgate.golden import commutation as cm
from hapgate.runners import covbuild, funcov

Q = 256                 # counts per quadrant of the default interpolator (1024 counts per line)
REV = 1 << 20           # counts per revolution (1024 lines)


def _run(tmp: Path, code: str) -> None:
    """Sample in a fresh process (the cover items are per-process singletons)."""
    prog = "import numpy as np\nfrom hapgate.runners import funcov as f\n" + code + \
        "\nf.flush()\n"
    out = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True,
                         env={**__import__("os").environ, covbuild.ENV: str(tmp)})
    assert out.returncode == 0, out.stderr


def _groups(tmp: Path) -> dict[str, coverage.FuncGroup]:
    return {g.name: g for g in coverage.functional(tmp)}


def test_shipped_clocks_are_the_paper_design_and_the_boards():
    shipped = {cm.CommutationConfig().clk_hz} | {b.clk_hz for b in boards.BOARDS.values()}
    assert set(funcov.SHIPPED_HZ) == shipped


def test_speed_bands_at_their_edges():
    # the spec's capture limit: 1 MSPS / (4 samples/line x 1024 lines) = 244.14 rev/s
    assert funcov.SPEED_EDGES[-1] >= 1e6 / 4 / 1024
    got = funcov.speed_band(np.array([0.5, 1.0, 1.01, 10.0, 99.0, 100.5, 244.1, 244.3]))
    assert got.tolist() == [0, 0, 1, 1, 2, 3, 3, 4]


def test_a_known_sweep_hits_exactly_its_bins(tmp_path):
    # up through quadrants 0 -> 1 -> 2 at 1 count/sample (1e6 / 2^20 = 0.95 rev/s: band "<1"),
    # then down 521 -> 421 -> 321 -> 221 at 100 counts/sample (95.4 rev/s: band "10-100"), which
    # leaves quadrant 2 and then quadrant 1 downwards; the index rises once,
    # in quadrant 1; a clipping fault rises once
    up = np.arange(0, 2 * Q + 10)
    down = up[-1] - 100 * np.arange(1, 4)
    pos = np.concatenate([up, down])
    faults = np.zeros(pos.size, dtype=int)
    faults[400:] = 2
    index = np.zeros(pos.size, dtype=int)
    index[300:310] = 1
    _run(tmp_path, f"f.sample_interp(np.array({pos.tolist()}), np.array({faults.tolist()}), "
                   f"np.array({index.tolist()}), {Q}, {REV}, 1_000_000)")
    g = _groups(tmp_path)["interp"]
    missing = set(g.uncovered)
    hit = {"interp.transition.cross: (0, 'up', '<1')", "interp.transition.cross: (1, 'up', '<1')",
           "interp.transition.cross: (2, 'down', '10-100')",
           "interp.transition.cross: (1, 'down', '10-100')", "interp.index.quadrant: 1",
           "interp.fault.kind: clip"}
    assert not hit & missing
    assert "interp.transition.cross: (2, 'up', '<1')" in missing   # never left 2 upwards
    assert "interp.fault.kind: loss" in missing and "interp.index.quadrant: 0" in missing
    # the cross: 4 quadrants x 2 directions x 4 bands; 4 hit
    assert sum(1 for b in missing if b.startswith("interp.transition.cross")) == 32 - 4


def test_commutation_bins_and_the_impossible_ones(tmp_path):
    # motor 0 sine +, over the limit; motor 1 six-step -, under; motor 2 off, zero
    _run(tmp_path, "f.sample_commutation(np.array([[0, 1, 3]]), np.array([[900, -5, 0]]), "
                   "np.array([100]))")
    g = _groups(tmp_path)["commutation"]
    cross = [b for b in g.uncovered if b.startswith("commutation.frame.cross")]
    # 4 modes x 6 channels x 3 signs x 2 clamp states, less (zero, clamp) = 120; 6 hit
    assert len(cross) == 120 - 6
    for b in ("('sine', 'm0a', 'pos', True)", "('six_step', 'm1b', 'neg', False)",
              "('off', 'm2a', 'zero', False)"):
        assert f"commutation.frame.cross: {b}" not in g.uncovered


def test_processes_merge(tmp_path):
    _run(tmp_path, "f.sample_dac([0, 1, 2], 12_000_000)")
    _run(tmp_path, "f.sample_dac([3, 4, 5], 12_000_000)\nf.sample_device([('hang', 'all')])")
    g = _groups(tmp_path)
    assert g["dac_sched"].uncovered == tuple(
        f"dac_sched.load.{b}" for b in ["clock: 48000000",
                                        *(f"cross: ({s}, 48000000)" for s in range(6))])
    assert g["device"].covered == 1 and g["device"].total == 6
    assert g["bus"].covered == 0 and g["bus"].total > 100    # declared by every process


def test_nothing_outside_a_coverage_run(tmp_path, monkeypatch):
    monkeypatch.delenv(covbuild.ENV, raising=False)
    funcov.sample_dac([0], 12_000_000)
    funcov.flush()
    assert not funcov._items                      # cocotb-coverage never declared
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("bad", ["not: [valid", "7"])
def test_a_corrupt_database_is_named(tmp_path, bad):
    _run(tmp_path, "f.sample_dac([0], 12_000_000)")
    (tmp_path / "func" / "zz.yml").write_text(bad)
    with pytest.raises(coverage.BadInput, match="zz.yml"):
        coverage.functional(tmp_path)
