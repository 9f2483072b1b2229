"""The firmware's documented limits at their boundaries (issue 29, "Boundaries"): the torque
clamp tau_max in both directions (and the TQ_LIMIT it writes to the FPGA), the link-silence
timeout HG_LINK_TIMEOUT_MS and the PC force TTL, each at the spec's number and one step either
side. The checks are C unit tests (dsp-fw/tests/test_axis.c, test_link.c: `bounds_*`, with the
spec's numbers written in them), run here one by one under ASan and UBSan so a failure names its
boundary."""

from __future__ import annotations

import fcntl
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "build" / "dsp-fw"
EXE = BUILD / "hg_tests_san"


def build() -> None:
    """make the sanitized unit tests; serialised with tb/fw/test_dsp_fw.py's builds."""
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        r = subprocess.run(["make", "-s", "-C", str(ROOT / "dsp-fw"), f"BUILD={BUILD}", str(EXE)],
                           check=False, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize("name", ["bounds_tau_max", "bounds_link_timeout", "bounds_force_ttl"])
def test_fw_boundary(name: str) -> None:
    build()
    r = subprocess.run([EXE, name], check=False, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip().splitlines()[-1] == "1 passed, 0 failed", \
        r.stdout + r.stderr
