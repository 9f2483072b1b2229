"""Both replays stream in chunks, both engines: `replay interp` (the model carries its state from
chunk to chunk, the RTL harness reads a pipe) and `replay commutation --engine rtl` write the
same bytes whatever the chunk size, on captures whose state crosses the chunk boundaries (index
edges, sticky faults, online calibration, the ratio angle with a harmonic table)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapgate.golden import enccal, encsig, interp
from test_outputs import frames_csv

N = 3000
CHUNKS = ("1", "997", "1000", "100000")   # mid-stream at odd places, and the whole file


def capture_csv(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fast and slow motion with reversals, an index edge per revolution (several per chunk),
    a clipping burst (a sticky fault after row 1000) and a dropout (signal loss)."""
    x = 0.2 + np.cumsum(np.where(np.arange(N) < 2000, 0.17, -0.05))  # lines; 6 samples/line
    x = x + 300.0 * np.sin(np.arange(N) / 400.0) / 400.0
    a, b = encsig.adc_codes(x, encsig.PAPER_LIKE)
    a, b = a.copy(), b.copy()
    a[1500:1506] = 127
    a[2400:2460] = 0
    b[2400:2460] = 0
    index = (np.mod(x, 64.0) < 0.25).astype(np.int64)
    rows = [",".join(map(str, r)) for r in zip(a.tolist(), b.tolist(), index.tolist())]
    path.write_text("a,b,index\n" + "\n".join(rows[:800]) + "\n\n" + "\n".join(rows[800:]) + "\n")
    return a, b, index.astype(bool)


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", *args],
                          capture_output=True, text=True)


VARIANTS = {
    "asin": ((), interp.InterpConfig(), {}),
    "calib": (("--calib",), interp.InterpConfig(cal=True), {"cal_en": True}),
    "ratio-harm": (("--angle", "ratio", "--harm", "HARM"),
                   interp.InterpConfig(ratio=True, harm=True), {"harm_en": True}),
}


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("engine", ("model", "rtl"))
def test_interp_output_does_not_depend_on_the_chunk(tmp_path: Path, engine: str,
                                                     variant: str) -> None:
    src = tmp_path / "cap.csv"
    a, b, index = capture_csv(src)
    extra, cfg, kw = VARIANTS[variant]
    if "HARM" in extra:
        table = (np.round(12 * np.sin(2 * np.pi * np.arange(64) / 32))).astype(np.int64)
        harm = tmp_path / "harm.hex"
        harm.write_text("".join(f"{v & 0xFF:02x}\n" for v in table))
        extra = tuple(str(harm) if e == "HARM" else e for e in extra)
        kw = kw | {"harm_table": table}
    whole = interp.run(a, b, index, cfg, **kw)
    # the capture crosses the boundaries with state: index edges, faults, calibration updates
    assert np.unique(whole.index_count[[999, 1999, 2999]]).size == 3
    assert whole.faults[999] == 0 and whole.faults[1999] != 0 and whole.faults[-1] & 4
    if cfg.cal:
        upd = whole.extra["cal_updates"]
        assert 0 < upd[999] < upd[1999] < upd[-1], upd[[999, 1999, 2999]]
        assert not np.array_equal(whole.extra["cal_state"][:, 1000], enccal.IDENTITY)
    outs = {}
    for rows in CHUNKS:
        out = tmp_path / f"res_{rows}.csv"
        r = run("interp", "--engine", engine, "--in", str(src), "--out", str(out),
                "--chunk-rows", rows, *extra)
        assert r.returncode == 0, r.stdout + r.stderr
        outs[rows] = out.read_bytes()
    assert all(o == outs["100000"] for o in outs.values()), [k for k, o in outs.items()
                                                             if o != outs["100000"]]
    got = np.loadtxt(tmp_path / "res_997.csv", delimiter=",", skiprows=1, dtype=np.int64)
    assert got.shape == (N, 8)
    assert np.array_equal(got[:, 0], whole.pos) and np.array_equal(got[:, 2], whole.faults)
    assert np.array_equal(got[:, 3], whole.pos_homed) and np.array_equal(got[:, 5],
                                                                          whole.index_count)


def test_interp_compare_streams_both_engines(tmp_path: Path) -> None:
    src = tmp_path / "cap.csv"
    capture_csv(src)
    out = tmp_path / "res.csv"
    r = run("interp", "--compare", "--calib", "--in", str(src), "--out", str(out),
            "--chunk-rows", "997")
    assert r.returncode == 0 and "agree on every sample" in r.stdout, r.stdout + r.stderr
    assert len(out.read_text().splitlines()) == N + 1


def test_model_chunks_with_events_and_controls() -> None:
    """run_chunk from the state the previous chunk left equals one run, with clear and arm
    pulses, calibration enable runs (resets), freeze and a changing mu cut at random places."""
    n = 12_000
    x = enccal.mixed_motion(n, seed=4)
    a, b = encsig.adc_codes(x, encsig.PAPER_LIKE)
    index = np.mod(x, 256.0) < 0.2
    en = np.ones(n, dtype=bool)
    en[3000:3050] = False
    en[7000] = False
    freeze = np.zeros(n, dtype=bool)
    freeze[5000:5600] = True
    mu = np.where(np.arange(n) < 6000, 6, 4)
    clear, arm = np.array([2500, 2501, 9000]), np.array([100, 4000, 4001, 11_000])
    cfg = interp.InterpConfig(cal=True, invert=True)
    whole = interp.run(a, b, index, cfg, clear_at=clear, arm_at=arm, cal_en=en,
                       cal_freeze=freeze, cal_mu=mu)
    assert whole.homed.any() and whole.extra["cal_updates"][-1] >= 10
    cuts = np.unique(np.concatenate(([0, n], np.random.default_rng(5).integers(1, n, 40),
                                     [1, 2, 3001, 3002])))
    st = interp.InterpState()
    parts = []
    for i, j in zip(cuts[:-1], cuts[1:]):
        o, st = interp.run_chunk(a[i:j], b[i:j], index[i:j], cfg, st,
                                 clear_at=clear[(clear >= i) & (clear < j)] - i,
                                 arm_at=arm[(arm >= i) & (arm < j)] - i, cal_en=en[i:j],
                                 cal_freeze=freeze[i:j], cal_mu=mu[i:j])
        parts.append(np.vstack([o.as_matrix().T, o.extra["cal_state_after"],
                                o.extra["cal_gear"], o.extra["cal_updates"]]))
    want = np.vstack([whole.as_matrix().T, whole.extra["cal_state_after"],
                      whole.extra["cal_gear"], whole.extra["cal_updates"]])
    assert np.array_equal(np.hstack(parts), want)


def test_commutation_rtl_output_does_not_depend_on_the_chunk(tmp_path: Path) -> None:
    src = tmp_path / "frames.csv"
    frames_csv(src, 2345)
    model = tmp_path / "model.csv"
    r = run("commutation", "--engine", "model", "--in", str(src), "--out", str(model))
    assert r.returncode == 0, r.stderr
    for rows in CHUNKS:
        out = tmp_path / f"dac_{rows}.csv"
        r = run("commutation", "--engine", "rtl", "--in", str(src), "--out", str(out),
                "--chunk-rows", rows)
        assert r.returncode == 0, r.stdout + r.stderr
        assert out.read_bytes() == model.read_bytes(), rows
