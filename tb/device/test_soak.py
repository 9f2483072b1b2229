"""The interpolator soak (hapgate.device.soak): the 10^7-sample version of `make soak`, and its
checks shown to catch what they look for.

The full 10^9 run is `make soak` (scenes/sweeps/soak.toml); this one is scenes/sweeps/
soak_quick.toml: 4 jobs x 833 334 samples x 3 axes through the native Verilated interpolator on a
local Dask cluster of 2 workers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hapgate.device import soak, sweep
from hapgate.golden import encsig, interp

SPECS = Path(__file__).resolve().parents[2] / "scenes" / "sweeps"


def test_soak_1e7_samples_no_slip_overspeed_exact() -> None:
    spec = sweep.load(SPECS / "soak_quick.toml")
    res = sweep.run(spec, workers=2, cache=None, progress=False)
    rows = res.records
    total = sum(r["samples"] for r in rows)
    assert total >= 10_000_000
    assert sum(r["slips"] for r in rows) == 0
    assert sum(r["index_latch_errors"] for r in rows) == 0
    assert sum(r["false_overspeed"] for r in rows) == 0
    assert sum(r["missed_overspeed"] for r in rows) == 0
    # the run covered what it claims: overspeed segments, index crossings, the speed limit
    assert sum(r["segments_over"] for r in rows) >= 3
    assert sum(r["index_latches"] for r in rows) >= 1000
    assert max(r["peak_clean_rev_s"] for r in rows) > 243.8
    assert max(r["pos_err_max_counts"] for r in rows) < 512
    secs = sum(r["harness_s"] for r in rows)
    print(f"\nsoak: {total} samples, {res.wall_s:.1f} s wall on {res.workers} workers, "
          f"RTL {total / secs:.3g} samples/s")


def _model_outputs(seed: int, n: int) -> tuple[np.ndarray, list, list[dict[str, np.ndarray]]]:
    """The stimulus and the bit-exact model's outputs for it (the RTL's, per the interpolator's
    own bit-exactness tests), per axis."""
    a, b, idx, x, motions = soak.stimulus(seed, n)
    outs = []
    for ax in range(soak.AXES):
        o = interp.run(a[:, ax], b[:, ax], idx[:, ax], clear_at=motions[ax]["start"][1:])
        outs.append({"pos": o.pos.astype(np.int64), "index_pos": o.index_pos.astype(np.int64),
                     "index_count": o.index_count, "faults": o.faults})
    return x, motions, outs


def test_soak_checks_catch_slip_latch_and_overspeed_errors() -> None:
    x, motions, outs = _model_outputs(4, 400_000)
    ok = soak.evaluate(x, motions, outs)
    assert ok["slips"] == 0 and ok["false_overspeed"] == 0 and ok["missed_overspeed"] == 0
    assert ok["segments_over"] >= 3 and ok["index_latches"] > 0

    slip = [dict(o) for o in outs]
    slip[0]["pos"] = slip[0]["pos"].copy()
    slip[0]["pos"][200_000:] += 1024                  # one line lost half-way
    assert soak.evaluate(x, motions, slip)["slips"] >= 1

    latch = [dict(o) for o in outs]
    ax = next(i for i, o in enumerate(outs) if np.any(np.diff(o["index_count"]) != 0))
    latch[ax]["index_pos"] = latch[ax]["index_pos"] + 4   # every latch 4 counts off
    assert soak.evaluate(x, motions, latch)["index_latch_errors"] >= 1

    flags = [dict(o) for o in outs]
    for i, mo in enumerate(motions):
        end = mo["start"] + mo["lens"] - 1
        f = flags[i]["faults"].copy()
        f[end] ^= interp.FAULT_OVERSPEED                  # flip every segment's verdict
        flags[i]["faults"] = f
    bad = soak.evaluate(x, motions, flags)
    assert bad["false_overspeed"] == ok["segments_below"]
    assert bad["missed_overspeed"] == ok["segments_over"]


def test_safe_speed_of_ideal_signals_is_the_quadrant_limit() -> None:
    v = soak.safe_speed(encsig.IDEAL)
    # only the 1/2-LSB rounding margin: 0.5/127 rad of a quadrant's 90 degrees
    assert v == np.float64(v) and 240.0 < v < soak.V_LIMIT
    paper = soak.safe_speed(encsig.PAPER_LIKE)
    assert paper < v - 5.0           # offsets and quadrature error narrow a quadrant
