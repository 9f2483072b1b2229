"""The profile-guided build of a Verilated harness (hapgate.runners.native.verilate_harness with
`train`): when the training run fails, the build still yields a working executable, compiled
without a profile, and its log says why. (That a trained build computes the same results as the
plain one: tb/device/test_closed_loop.py::test_pgo_build_changes_nothing.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hapgate.golden import interp
from hapgate.golden.interp import InterpConfig
from hapgate.runners import native


def test_a_failed_training_run_costs_only_the_profile(monkeypatch):
    trained: list[Path] = []

    def refuse(exe: Path) -> None:
        trained.append(exe)
        raise RuntimeError("training refused on purpose")

    def build_with_failing_training(cfg: InterpConfig = InterpConfig(),
                                    clk_hz: int = interp.MIN_CLK_HZ, axes: int = 3,
                                    sample_hz: int = 1_000_000) -> Path:
        params = interp.interp3_params(cfg, clk_hz=clk_hz, sample_hz=sample_hz, axes=axes)
        return native.verilate_harness("interp_harness", "enc_interp3", native.SOURCES, params,
                                       [native.HARNESS], cflags=f"-DAXES={axes}", train=refuse)

    x = np.linspace(0.0, 6.0, 3000)                     # six lines forward, one axis
    a = np.round(100 * np.sin(2 * np.pi * x)).astype(np.int8)
    b = np.round(100 * np.cos(2 * np.pi * x)).astype(np.int8)
    plain = native.run_interp(a, b)
    monkeypatch.setattr(native, "build_interp", build_with_failing_training)
    got = native.run_interp(a, b)

    assert len(trained) == 1 and trained[0].name == "interp_harness"
    log = (trained[0].parent / "build.log").read_text()
    assert "== pgo: training failed (training refused on purpose)" in log
    assert "== pgo: use ==" in log and "== pgo: trained ==" not in log
    pos = got.axis(0)["pos"]
    assert abs(int(pos[-1]) - int(pos[0])) > 5 * 2 ** 10   # six lines fed, 2^10 counts each
    for col in native.COLUMNS:
        assert np.array_equal(plain.axis(0)[col], got.axis(0)[col]), col
