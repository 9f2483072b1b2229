"""The native host code (host/: the C library, the CHAI3D shims, the C example and the test
programs), built by its own Makefile into build/host/ through the one C/C++ build runner
(hapgate.base.cbuild: logged to build/host/build.log, a failure raises BuildError with the log's
tail). One build at a time: parallel test workers wait for the first and reuse what it built
(make rebuilds only what changed)."""

from __future__ import annotations

from pathlib import Path

from ..base import cbuild as runner
from ..base.paths import BUILD, ROOT, ensure, locked

HOST_BUILD = BUILD / "host"
LIB = HOST_BUILD / "lib"
BIN = HOST_BUILD / "bin"


def build(target: str = "all") -> Path:
    """`make -C host TARGET` (all: the libraries, the shims and hg-wall; check: also the
    sanitizer-built test programs). Returns build/host; BuildError names the failure."""
    log = ensure(HOST_BUILD) / "build.log"
    with locked(HOST_BUILD):
        log.write_text("")          # this build's log only
        runner.run(["make", "-s", "-C", str(ROOT / "host"), f"BUILD={HOST_BUILD}", target], log,
                   f"host code (make {target})")
    return HOST_BUILD
