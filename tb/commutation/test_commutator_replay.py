"""`hapgate replay commutation`: CSV in, CSV out, on the model and on the RTL (Verilator); bad
input names its line."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import pytest
from hapgate.commands import replay_commutation as rc
from hapgate.golden import commutation as cm


def _args(**kw: object) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    rc.add_arguments(p)
    argv = []
    for k, v in kw.items():
        argv += [f"--{k}", str(v)] if v is not True else [f"--{k}"]
    return p.parse_args(argv)


def _write(path: Path, header: list[str], rows: list[list[object]]) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return path


def _frames_csv(path: Path, n: int, seed: int = 5) -> tuple[Path, cm.Frames]:
    rng = np.random.default_rng(seed)
    pos = rng.integers(-(1 << 31), 1 << 31, (n, 3))
    tq = rng.integers(-32768, 32768, (n, 3))
    off = rng.integers(0, 1024, (n, 3))
    mode = rng.integers(0, 4, (n, 3))
    header = [f"pos{i}" for i in range(3)] + [f"torque{i}" for i in range(3)] + \
        [f"offset{i}" for i in range(3)] + [f"mode{i}" for i in range(3)]
    names = np.array(["sine", "six_step", "align", "off"])
    rows = [[*pos[i], *tq[i], *off[i], *names[mode[i]]] for i in range(n)]
    return _write(path, header, rows), cm.Frames.make(pos, tq, offset=off, mode=mode)


def _read(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with open(path, newline="") as f:
        r = list(csv.reader(f))
    assert r[0] == ["frame"] + [f"dac{k}" for k in range(6)] + [f"t{k}_ns" for k in range(6)]
    a = np.array(r[1:], dtype=float)
    return a[:, 1:7].astype(np.int64), a[:, 7:]


@pytest.mark.parametrize("engine", ["model", "rtl"])
def test_replay_roundtrip(tmp_path: Path, engine: str) -> None:
    src, frames = _frames_csv(tmp_path / "frames.csv", 60)
    out = tmp_path / "dac.csv"
    assert rc.main(_args(**{"in": src, "out": out, "engine": engine})) == 0
    codes, t = _read(out)
    assert np.array_equal(codes, cm.commutate(frames, cm.CommutationConfig(clk_hz=50_000_000)))
    # loads 2 us apart, the first 8 clocks of 20 ns after the frame start
    assert np.allclose(t, 160.0 + 2000.0 * np.arange(6), atol=1e-6)


@pytest.mark.parametrize("cell, line, words", [
    ("12x", 4, "is not an integer"), ("40000", 4, "is outside -32768..32767")])
def test_replay_bad_input_names_the_line(tmp_path: Path, capsys, cell: str, line: int,
                                         words: str) -> None:
    header = [f"pos{i}" for i in range(3)] + [f"torque{i}" for i in range(3)]
    rows = [[0, 0, 0, 1, 2, 3]] * 5
    rows[2] = [0, 0, 0, 1, cell, 3]
    src = _write(tmp_path / "bad.csv", header, rows)
    assert rc.main(_args(**{"in": src, "out": tmp_path / "o.csv", "engine": "model"})) == 2
    err = capsys.readouterr().err
    # FILE:LINE:COL, the column named, the cell as written (no numpy reprs)
    assert f"bad.csv:{line}:9:" in err and "'torque1'" in err and words in err, err
    assert f"{cell!r}" in err and "np." not in err
    assert not (tmp_path / "o.csv").exists()


def test_replay_missing_column_and_short_row(tmp_path: Path, capsys) -> None:
    src = _write(tmp_path / "a.csv", ["pos0", "pos1", "torque0"], [[1, 2, 3]])
    assert rc.main(_args(**{"in": src, "out": tmp_path / "o.csv", "engine": "model"})) == 2
    assert "a.csv:1:" in capsys.readouterr().err
    header = [f"pos{i}" for i in range(3)] + [f"torque{i}" for i in range(3)]
    src = _write(tmp_path / "b.csv", header, [[0] * 6, [0] * 5])
    assert rc.main(_args(**{"in": src, "out": tmp_path / "o.csv", "engine": "model"})) == 2
    assert "b.csv:3:" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()
