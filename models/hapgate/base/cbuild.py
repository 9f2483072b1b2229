"""The one way C and C++ are built (the native Verilator harnesses and their profile-guided
builds, the firmware library, the plant and the model harness): run the compiler or make with
the caller's flags -- unchanged, so the binaries are what they were -- in the build folder,
append everything it printed to a log file, and on a failure raise BuildError with the log's
tail."""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

TAIL_LINES = 30


class BuildError(RuntimeError):
    """A compile or link failed; the message names the log and ends with its tail (`log`, and
    the whole of it in `text`)."""

    def __init__(self, message: str, log: Path, text: str) -> None:
        super().__init__(message)
        self.log, self.text = log, text


def run(cmd: Sequence[str], log: Path, what: str, cwd: Path | None = None,
        check: bool = True) -> int:
    """Run one build command; its output goes to (the end of) `log`. Returns the exit code
    (raises BuildError on a non-zero one when `check`)."""
    out = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True)
    with open(log, "a") as fh:
        fh.write(f"$ {' '.join(map(str, cmd))}\n{out.stdout}{out.stderr}")
    if check and out.returncode != 0:
        raise failure(what, log)
    return out.returncode


def failure(what: str, log: Path) -> BuildError:
    """The error for `what`: the log's path and its last lines."""
    text = log.read_text(errors="replace") if log.exists() else ""
    tail = "\n".join(text.splitlines()[-TAIL_LINES:])
    return BuildError(f"{what} failed to build; see {log}\n{tail}", log, text)
