"""hapgate.base.paths.locked: the lock the cached builds (Verilator harnesses, cocotb builds,
Yosys netlists) take so that parallel test workers never build the same artefact at once."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from hapgate.base import paths


def test_locked_excludes_other_holders(tmp_path: Path) -> None:
    events: list[tuple[str, int]] = []

    def hold(n: int) -> None:
        with paths.locked(tmp_path / "artefact"):
            events.append(("in", n))
            time.sleep(0.05)
            events.append(("out", n))

    threads = [threading.Thread(target=hold, args=(n,)) for n in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(events) == 6
    for k in range(0, 6, 2):   # never two holders inside at once
        assert events[k][0] == "in" and events[k + 1] == ("out", events[k][1]), events
    assert (tmp_path / "artefact.lock").exists()
