"""The native host code (host/: the C library, the CHAI3D shims, the C example and the test
programs), built by its own Makefile into build/host/. One build at a time: parallel test
workers wait for the first and reuse what it built (make rebuilds only what changed)."""

from __future__ import annotations

import subprocess
from pathlib import Path

from ..base.paths import BUILD, ROOT, locked

HOST_BUILD = BUILD / "host"
LIB = HOST_BUILD / "lib"
BIN = HOST_BUILD / "bin"


def build(target: str = "all") -> Path:
    """`make -C host TARGET` (all: the libraries, the shims and hg-wall; check: also the
    sanitizer-built test programs). Returns build/host; CalledProcessError names the failure."""
    with locked(HOST_BUILD):
        subprocess.run(["make", "-s", "-C", str(ROOT / "host"), f"BUILD={HOST_BUILD}", target],
                       check=True, stdout=subprocess.DEVNULL)
    return HOST_BUILD
