"""The profile-guided build of a Verilated harness (hapgate.runners.native.verilate_harness with
`train`): when the training run fails, the build still yields a working executable, compiled
without a profile, and its log says why. (That a trained build computes the same results as the
plain one: tb/device/test_closed_loop.py::test_pgo_build_changes_nothing.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hapgate.runners import native


def test_a_failed_training_run_costs_only_the_profile(monkeypatch):
    """The interpolator harness built through the same path with a training run that raises.
    (Cached like any build: on a second run the log of the first still says what happened.)"""
    built: list[Path] = []

    def refuse(exe: Path) -> None:
        raise RuntimeError("training refused on purpose")

    def verilate_with_failing_training(*args, **kwargs) -> Path:
        exe = verilate(*args, **kwargs, train=refuse)
        built.append(exe)
        return exe

    x = np.linspace(0.0, 6.0, 3000)                     # six lines forward, one axis
    a = np.round(100 * np.sin(2 * np.pi * x)).astype(np.int8)
    b = np.round(100 * np.cos(2 * np.pi * x)).astype(np.int8)
    plain = native.run_interp(a, b)
    verilate = native.verilate_harness
    monkeypatch.setattr(native, "verilate_harness", verilate_with_failing_training)
    got = native.run_interp(a, b)

    assert len(built) == 1 and built[0].name == "interp_harness"
    log = (built[0].parent / "build.log").read_text()
    assert "== pgo: training failed (training refused on purpose)" in log
    assert "== pgo: use ==" in log and "== pgo: trained ==" not in log
    pos = got.axis(0)["pos"]
    assert abs(int(pos[-1]) - int(pos[0])) > 5 * 2 ** 10   # six lines fed, 2^10 counts each
    for col in native.COLUMNS:
        assert np.array_equal(plain.axis(0)[col], got.axis(0)[col]), col
