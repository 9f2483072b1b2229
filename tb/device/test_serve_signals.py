"""`hapgate device serve` on SIGINT and SIGTERM (issue 35, item 5): it ends within a second
whether it serves or builds. Serving, it stops the harness and writes its link summary, exit 0;
building, the build's compilers end with it (hapgate.base.cbuild: the build commands run in a
process group of their own, ended whole), it says "device serve: stopped while building", exits
128 + the signal's number and leaves no cached harness a later start would take as built.

The served tests reuse the shared device build of scenes/short.toml (one axis, the host tests'
build); the build test makes a fresh one in a temporary folder and interrupts it mid-compile.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from hapgate.base import cache, cbuild
from hapgate.base.paths import ROOT

HG = [sys.executable, "-m", "hapgate.commands.cli"]
SERVE = ["device", "serve", "--scene", "scenes/short.toml", "--pace", "free"]
BUILD_S = 900          # hang guard: the first start may build the device (minutes)
END_S = 1.0            # the bound: a signal ends the command within a second
COMPILERS = {"cc1plus", "clang", "clang++"}     # a C++ compiler at work (its process name)
# `device serve` with the device builds (hapgate.runners.native.BUILD) in the folder argv[1]:
# a fresh build, whatever build/ holds
IN_FOLDER = ("import sys\nfrom pathlib import Path\nfrom hapgate.runners import native\n"
             "native.BUILD = Path(sys.argv[1])\nfrom hapgate.commands import cli\n"
             "sys.exit(cli.main(sys.argv[2:]))\n")


class Proc:
    """A command whose stdout and stderr lines are read in threads."""

    def __init__(self, argv: list[str]) -> None:
        self.p = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True, env=os.environ | {"PYTHONUNBUFFERED": "1"})
        self.out: list[str] = []
        self.err: list[str] = []
        self._threads = [threading.Thread(target=self._read, args=(f, into), daemon=True)
                         for f, into in ((self.p.stdout, self.out), (self.p.stderr, self.err))]
        for t in self._threads:
            t.start()

    @staticmethod
    def _read(f, into: list[str]) -> None:
        for line in f:
            into.append(line.rstrip("\n"))

    def wait_for(self, ready: Callable[[], bool], what: str, timeout: float = BUILD_S) -> None:
        t0 = time.monotonic()
        while not ready():
            if self.p.poll() is not None:
                raise AssertionError(f"exited {self.p.returncode} before {what}: "
                                     + "\n".join(self.out + self.err))
            if time.monotonic() - t0 > timeout:
                raise AssertionError(f"no {what} in {timeout} s: " + "\n".join(self.err))
            time.sleep(0.02)

    def signal_and_time(self, sig: int) -> float:
        """Send `sig`; the seconds until the process ended (killed after a hang guard)."""
        t0 = time.monotonic()
        self.p.send_signal(sig)
        try:
            self.p.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
        dt = time.monotonic() - t0
        for t in self._threads:
            t.join(timeout=5)
        return dt

    def kill(self) -> None:
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait()


def processes() -> dict[int, tuple[str, str, int, int]]:
    """Every process: pid -> (command name, state, parent pid, session id), from /proc."""
    out = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        comm = stat[stat.index("(") + 1:stat.rindex(")")]
        f = stat[stat.rindex(")") + 2:].split()
        out[int(d.name)] = (comm, f[0], int(f[1]), int(f[3]))
    return out


def descendants(pid: int, procs: dict[int, tuple[str, str, int, int]]) -> list[int]:
    kids = {p for p, v in procs.items() if v[2] == pid}
    for k in list(kids):
        kids |= set(descendants(k, procs))
    return sorted(kids)


def live_of(seen: dict[int, str]) -> list[str]:
    """The processes of `seen` (pid -> command name) still running (zombies aside)."""
    return [f"{p} {v[0]}" for p, v in processes().items()
            if seen.get(p) == v[0] and v[1] != "Z"]


def wait_gone(left_of: Callable[[], list[str]], timeout: float = END_S) -> list[str]:
    t0 = time.monotonic()
    while (left := left_of()) and time.monotonic() - t0 < timeout:
        time.sleep(0.01)
    return left


# ------------------------------------------------------------------------------ serving
@pytest.mark.parametrize("scene", ["scenes/short.toml", "scenes/bringup/index.toml"],
                         ids=["homed", "unhomed"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_while_serving_ends_within_a_second_with_the_link_summary(sig: int,
                                                                          scene: str) -> None:
    """short.toml restarts from its stored calibration; bringup/index.toml has none, so nothing
    homes it while it serves: either ends at once with its summary."""
    proc = Proc(HG + ["device", "serve", "--scene", scene, "--pace", "free"])
    try:
        proc.wait_for(lambda: any(x.startswith("port: /dev/pts/") for x in proc.out),
                      "'port:' line")
        proc.wait_for(lambda: any(x.startswith("serving the virtual device") for x in proc.err),
                      "'serving' note", timeout=60)
        dt = proc.signal_and_time(sig)
    finally:
        proc.kill()
    err = "\n".join(proc.err)
    assert proc.p.returncode == 0, err
    assert dt < END_S, f"{sig.name}: ended after {dt:.2f} s"
    assert any(x.startswith("link: bytes in ") for x in proc.err), err
    assert "Traceback" not in err, err


# ------------------------------------------------------------------------------ building
def test_sigterm_while_building_ends_the_build_at_once(tmp_path: Path) -> None:
    """A fresh device build in tmp_path, interrupted while the compiler runs: the command ends
    within a second (143, "stopped while building"), none of the build's processes (make,
    the compiler driver, the compiler) is left, and no cached harness: only the failed build's
    log and the lock beside it."""
    proc = Proc([sys.executable, "-c", IN_FOLDER, str(tmp_path), *SERVE])
    kids: dict[int, str] = {}

    def compiling() -> bool:
        procs = processes()
        kids.clear()
        kids.update((k, procs[k][0]) for k in descendants(proc.p.pid, procs))
        return bool(COMPILERS & set(kids.values()))

    try:
        proc.wait_for(compiling, "C++ compiler in the build", timeout=300)
        dt = proc.signal_and_time(signal.SIGTERM)
    finally:
        proc.kill()
    err = "\n".join(proc.err)
    assert proc.p.returncode == 128 + signal.SIGTERM, err
    assert dt < END_S, f"ended after {dt:.2f} s"
    assert "device serve: stopped while building" in proc.err, err
    assert not any(x.startswith("port:") for x in proc.out)
    assert "Traceback" not in err, err
    left = wait_gone(lambda: live_of(kids), max(0.05, END_S - dt))   # within the second
    assert left == [], f"build processes outlived the command: {left} (of {kids})"
    native = tmp_path / "native"
    entries = sorted(p.name for p in native.iterdir())
    assert [e for e in entries if not e.endswith((".log", ".lock"))] == [], entries
    (log,) = native.glob("device_harness-*.log")
    assert "(interrupted: its processes were ended)" in log.read_text()


# ------------------------------------------------------------------------------ cbuild.run
class Alarm(BaseException):
    """What the test's SIGALRM handler raises (as device serve's handler raises Interrupted)."""


def test_interrupted_build_command_ends_its_whole_process_group(tmp_path: Path) -> None:
    """cbuild.run of a command with a child of its own (sh and two sleeps), interrupted by an
    exception from a signal handler: the exception comes through at once, every process of the
    group is gone within a second, and the cached entry it was building is not published (a
    'finished' file written before the interruption does not make it one)."""
    root = tmp_path / "cache"
    pidfile = tmp_path / "pid"
    calls = []

    def build(bdir: Path) -> None:
        calls.append(bdir)
        (bdir / "exe").write_text("half")                 # the file `done` names, half-written
        cbuild.run(["sh", "-c", f"echo $$ > {pidfile}; sleep 30 & sleep 30"], bdir / "build.log",
                   "dummy")

    def on_alarm(_sig: int, _frame: object) -> None:
        raise Alarm

    old = signal.signal(signal.SIGALRM, on_alarm)
    seen: dict[int, str] = {}          # sh and its two sleeps: pid -> command name
    try:
        def ring_when_started() -> None:
            t0 = time.monotonic()
            while time.monotonic() - t0 < 30:
                text = pidfile.read_text().strip() if pidfile.exists() else ""
                procs = processes()
                if text and int(text) in procs:
                    sh = int(text)
                    kids = {k: procs[k][0] for k in descendants(sh, procs)}
                    if list(kids.values()).count("sleep") == 2:
                        seen.update(kids)
                        seen[sh] = procs[sh][0]
                        break
                time.sleep(0.01)
            signal.pthread_kill(threading.main_thread().ident, signal.SIGALRM)

        threading.Thread(target=ring_when_started, daemon=True).start()
        t0 = time.monotonic()
        with pytest.raises(Alarm):
            cache.cached_dir(root, "dummy", build, done="exe")
        dt = time.monotonic() - t0
    finally:
        signal.signal(signal.SIGALRM, old)
    assert seen, "the command never started its children"
    t1 = time.monotonic()
    left = wait_gone(lambda: live_of(seen))
    assert left == [], f"still running {time.monotonic() - t1:.2f} s after: {left}"
    assert dt < 30
    assert sorted(p.name for p in root.iterdir()) == ["dummy.lock", "dummy.log"]
    assert "(interrupted: its processes were ended)" in (root / "dummy.log").read_text()

    def quick(bdir: Path) -> None:                        # a later build builds again
        calls.append(bdir)
        (bdir / "exe").write_text("whole")

    assert (cache.cached_dir(root, "dummy", quick, done="exe") / "exe").read_text() == "whole"
    assert len(calls) == 2
