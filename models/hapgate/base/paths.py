"""Where things are: the repository root, its sources and the build tree (generated files only)."""

from __future__ import annotations

import fcntl
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
RTL = ROOT / "rtl"
RTL_INCLUDE = RTL / "include"  # hg_sim.vh: the simulation-only macros (`include "hg_sim.vh")
TB = ROOT / "tb"
BUILD = ROOT / "build"
GEN = BUILD / "gen"          # generated tables (.hex) consumed by RTL and models
REPORTS = BUILD / "reports"  # CSV / PNG written by demo and bench
SIM = BUILD / "sim"          # one build directory per (block, simulator, parameter set)


def ensure(path: Path) -> Path:
    """Create `path` (a directory) if needed and return it."""
    path.mkdir(parents=True, exist_ok=True)
    return path


@contextmanager
def locked(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on `path` + ".lock" (parallel test workers building the same
    cached artefact: the first builds it, the others wait and reuse it)."""
    ensure(path.parent)
    with open(str(path) + ".lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)
