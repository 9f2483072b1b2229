"""The one way C and C++ are built (the native Verilator harnesses and their profile-guided
builds, the firmware library, the plant and the model harness): run the compiler or make with
the caller's flags -- unchanged, so the binaries are what they were -- in the build folder,
append everything it printed to a log file, and on a failure raise BuildError with the log's
tail.

A build command runs in a process group of its own (a new session), so that an interrupted
build can be ended whole: when the wait for it is interrupted (Ctrl-C's KeyboardInterrupt, or
the exception a signal handler raises, as `hapgate device serve` does while it builds), the
group -- make and every compiler it started -- is sent SIGTERM (make deletes the target it was
writing, the compilers their output files), SIGKILL after `STOP_GRACE_S` for whatever is left,
and the exception goes on. What an interrupted build wrote is never taken for a finished one:
the cached builds build into a temporary folder that is renamed into place only when the build
returned (hapgate.base.cache.cached_dir)."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path

TAIL_LINES = 30
STOP_GRACE_S = 0.3      # after SIGTERM, how long an interrupted build's processes may take


class BuildError(RuntimeError):
    """A compile or link failed; the message names the log and ends with its tail (`log`, and
    the whole of it in `text`)."""

    def __init__(self, message: str, log: Path, text: str) -> None:
        super().__init__(message)
        self.log, self.text = log, text


def run(cmd: Sequence[str], log: Path, what: str, cwd: Path | None = None,
        check: bool = True) -> int:
    """Run one build command; its output goes to (the end of) `log`. Returns the exit code
    (raises BuildError on a non-zero one when `check`). Interrupted (any exception while it
    runs), the command's whole process group is ended first (`stop_group`) and the log says
    so."""
    argv = [str(c) for c in cmd]
    proc: subprocess.Popen[str] | None = None
    try:
        proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, start_new_session=True)
        stdout, stderr = proc.communicate()
    except BaseException:
        if proc is not None:
            stop_group(proc)
            try:
                with open(log, "a") as fh:
                    fh.write(f"$ {' '.join(argv)}\n(interrupted: its processes were ended)\n")
            except OSError:
                pass
        raise
    with open(log, "a") as fh:
        fh.write(f"$ {' '.join(argv)}\n{stdout}{stderr}")
    if check and proc.returncode != 0:
        raise failure(what, log)
    return proc.returncode


def _group_alive(pgid: int) -> bool:
    """Whether the process group still has a member (a zombie not yet reaped counts)."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:       # a member we may not signal: it exists
        return True
    return True


def stop_group(proc: subprocess.Popen[str], grace_s: float = STOP_GRACE_S) -> None:
    """End `proc` and everything in its process group (it leads one: start_new_session):
    SIGTERM, then SIGKILL after `grace_s` for whatever is left; `proc` is reaped and its pipes
    closed."""
    pgid = proc.pid
    try:
        os.killpg(pgid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    deadline = time.monotonic() + grace_s
    while True:
        proc.poll()                       # reap the leader: its zombie keeps the group alive
        if not _group_alive(pgid) or time.monotonic() >= deadline:
            break
        time.sleep(0.01)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()
    for f in (proc.stdout, proc.stderr):
        if f is not None:
            f.close()


def failure(what: str, log: Path) -> BuildError:
    """The error for `what`: the log's path and its last lines."""
    text = log.read_text(errors="replace") if log.exists() else ""
    tail = "\n".join(text.splitlines()[-TAIL_LINES:])
    return BuildError(f"{what} failed to build; see {log}\n{tail}", log, text)
