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


def test_replay_roundtrip(tmp_path: Path) -> None:
    sc = encsig.scenario("dropout_controls", 20_000)
    sc.clear_at = sc.arm_at = np.array([], dtype=np.int64)   # a capture has no control pulses
    cap = tmp_path / "cap.csv"
    np.savetxt(cap, np.stack([sc.b, sc.a, sc.a, sc.index, sc.truth_lines * 1024], 1),
               fmt=["%d", "%d", "%d", "%d", "%.5f"], delimiter=",",
               header="note,a,b,index,truth_counts", comments="")   # 'note' is ignored
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--compare")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "agree on every sample" in r.stdout
    assert "rms [el deg]" in r.stdout
    header = out.read_text().splitlines()[0].split(",")
    assert header[:3] == ["pos", "vel", "fault"]
    got = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64)
    model = interp.run(sc.a, sc.a, sc.index)    # columns a and b of the file are (sc.a, sc.a)
    assert np.array_equal(got[:, 0], model.pos)
    assert np.array_equal(got[:, 1], model.vel)
    assert np.array_equal(got[:, 2], model.faults)


@pytest.mark.parametrize("text, line, words", [
    ("a,b\n1,2\n3,x\n", 3, "malformed"),
    ("a,b\n1,2\n3,4\n5\n", 4, "malformed"),
    ("a,b\n1,2\n300,4\n", 3, "'a'"),
    ("a,b,index\n1,2,0\n3,4,2\n", 3, "'index'"),
    ("a,b\n1,2\n1.5,4\n", 3, "'a'"),
    ("x,y\n1,2\n", 1, "lacks"),
    ("a,b\n", 2, "no data"),
])
def test_malformed_capture(tmp_path: Path, text: str, line: int, words: str) -> None:
    cap = tmp_path / "bad.csv"
    cap.write_text(text)
    out = tmp_path / "res.csv"
    r = replay("--in", str(cap), "--out", str(out), "--engine", "model")
    assert r.returncode == 2
    assert f"bad.csv:{line}:" in r.stderr and words in r.stderr, r.stderr
    assert not out.exists()
