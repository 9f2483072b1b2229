"""`hapgate replay interp` end to end: a capture CSV in, RESULT.csv out, both engines agree,
truth error printed; malformed captures give a clear error naming the line and write nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapgate.golden import encsig, interp


def replay(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", "interp", *args],
                          capture_output=True, text=True)


def _capture(path: Path, n: int = 20_000, start: float = 0.37) -> np.ndarray:
    """Ideal R = 127 signals at 37.3 rev/s with the index, truth_counts in the capture's unit
    (1024 counts per line); a column the replay ignores. Returns the truth in lines."""
    x = encsig.constant(37.3, n, start=start)
    a, b = encsig.adc_codes(x)
    np.savetxt(path, np.stack([np.arange(n), a, b, encsig.index_bit(x), x * 1024], 1),
               fmt=["%d", "%d", "%d", "%d", "%.6f"], delimiter=",",
               header="note,a,b,index,truth_counts", comments="")
    return x


def _printed(stdout: str) -> dict[str, list[str]]:
    """The replay's table: engine -> its cells."""
    rows = [ln.split() for ln in stdout.splitlines()]
    return {r[0]: r for r in rows if len(r) > 4 and r[0] in ("rtl", "model") and r[1].isdigit()}


def test_replay_roundtrip(tmp_path: Path) -> None:
    """Real signals through both engines: RESULT.csv is the model's output sample for sample,
    and the printed offset/RMS/max equal the error computed here from RESULT.csv against the
    truth, inside the interpolator's budget (0.19 deg RMS, 0.6 deg max electrical)."""
    cap = tmp_path / "cap.csv"
    x = _capture(cap, start=1023.37)          # through the index (line 0 of the next turn)
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--compare")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "agree on every sample" in r.stdout and "ignored column(s) note" in r.stderr
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["pos", "vel", "fault", "pos_homed", "index_pos", "index_count", "homed",
                      "overspeed_count"]
    got = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64)
    a, b = encsig.adc_codes(x)
    model = interp.run(a, b, encsig.index_bit(x))
    for j, col in enumerate(("pos", "vel", "faults", "pos_homed", "index_pos", "index_count",
                             "homed", "overspeed_count")):
        assert np.array_equal(got[:, j], np.asarray(getattr(model, col), dtype=np.int64)), col
    assert got[-1, 5] >= 1 and got[-1, 6] == 0                  # index seen (no arm: not homed)
    err = got[:, 0] - x * 1024
    off = err.mean()
    err = err - off
    rms, mx = np.sqrt(np.mean(err**2)) * 360 / 1024, np.abs(err).max() * 360 / 1024
    assert rms <= 0.19 and mx <= 0.6, (rms, mx)
    for engine, cells in _printed(r.stdout).items():
        assert int(cells[1]) == x.size
        assert abs(float(cells[4]) - off) < 1e-3, (engine, cells)
        assert abs(float(cells[7]) - rms) < 1e-4 and abs(float(cells[8]) - mx) < 1e-4, cells
    assert set(_printed(r.stdout)) == {"rtl", "model"}


@pytest.mark.parametrize("lut_bits", range(5, 10))
def test_truth_counts_unit_at_every_lut_bits(tmp_path: Path, lut_bits: int) -> None:
    """truth_counts is 1024 counts per line whatever --lut-bits; the replay compares it with
    positions of 8 * 2**lut_bits counts per line. The printed error equals the one computed here
    in the run's own counts, and stays a fraction of a degree (with the unit wrong it would grow
    with the angle: hundreds of degrees)."""
    cap = tmp_path / "cap.csv"
    x = _capture(cap, 8000)
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--engine", "model", "--lut-bits",
               str(lut_bits))
    assert r.returncode == 0, r.stderr
    cpl = 8 << lut_bits
    pos = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64)[:, 0]
    err = pos - x * cpl
    off = err.mean()
    rms = np.sqrt(np.mean((err - off) ** 2)) * 360 / cpl
    cells = _printed(r.stdout)["model"]
    assert f"[1/{cpl} line]" in r.stdout
    assert abs(float(cells[4]) - off) < 1e-3 and abs(off) < 1.0, (cells, off)
    assert abs(float(cells[7]) - rms) < 1e-4, (cells, rms)
    assert rms < 0.6, rms


@pytest.mark.parametrize("text, line, words", [
    ("a,b\n1,2\n3,x\n", 3, "not an integer"),
    ("a,b\n1,2\n3,4\n5\n", 4, "1 fields, the header has 2"),
    ("a,b\n1,2\n300,4\n", 3, "'a'"),
    ("a,b,index\n1,2,0\n3,4,2\n", 3, "'index'"),
    ("a,b\n1,2\n1.5,4\n", 3, "'a'"),
    ("x,y\n1,2\n", 1, "lacks"),
    ("a,b\n", 2, "no data lines"),
])
def test_malformed_capture(tmp_path: Path, text: str, line: int, words: str) -> None:
    cap = tmp_path / "bad.csv"
    cap.write_text(text)
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--engine", "model")
    assert r.returncode == 2
    assert f"bad.csv:{line}:" in r.stderr and words in r.stderr, r.stderr
    assert not out.exists()


def test_replay_ratio_angle(tmp_path: Path) -> None:
    """--angle ratio (model engine: no build): RESULT.csv is the ratio stage's model output,
    and its error against the capture's truth is below the arcsine's (0.1635 vs 0.180 deg RMS
    on these signals)."""
    cap = tmp_path / "cap.csv"
    x = _capture(cap)
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--engine", "model", "--angle", "ratio")
    assert r.returncode == 0, r.stdout + r.stderr
    got = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64)
    a, b = encsig.adc_codes(x)
    model = interp.run(a, b, encsig.index_bit(x), interp.InterpConfig(ratio=True))
    assert np.array_equal(got[:, 0], model.pos.astype(np.int64))
    err = got[:, 0] - x * 1024
    paper = interp.run(a, b).pos - x * 1024
    assert np.std(err) * 360 / 1024 <= 0.165 < np.std(paper) * 360 / 1024
