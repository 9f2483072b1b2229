"""`hapgate device serve`: the virtual device (Verilated gateware, unchanged firmware, plant)
with the firmware's PC link on a pseudo-terminal, for PC programs written against
`hapgate.host` (README "Drive the device from a PC").

The pty is opened here (raw mode) and its master end handed to the native harness, whose UART
model (tb/native/device/uart_link.cpp) moves the bytes at the configured baud in simulated
time. `Server` is the same thing as a context manager, for tests and benchmarks.

SIGINT (Ctrl-C) or SIGTERM ends the command within a second, whatever it is doing:

- serving (after the "port:" line): the harness is stopped, its link summary ("link: bytes in
  ...") is written on stderr, exit 0;
- before that (building the harness, starting it): "device serve: stopped while building" (or
  "... while starting") on stderr, the harness's summary if it had started, and exit 128 + the
  signal's number (130 for SIGINT, 143 for SIGTERM), as a shell reports a command the signal
  ended. An interrupted build's compilers are ended with it (hapgate.base.cbuild) and it leaves
  no cached harness behind: the next start builds it again.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tty
from pathlib import Path
from typing import Any

from ..base.paths import BUILD, ensure
from ..device import runner, soc
from ..device import scene as scene_mod
from ..device.telemetry import Feed
from . import view

SERVE_S = 1e6                 # simulated seconds a server runs for (it stops on a signal)
STOP_WAIT_S = 2.0             # after SIGTERM, how long the harness may take before SIGKILL
PACES = ("realtime", "free")
FIDELITIES = ("rtl", "soc")   # served: the gateware with the native firmware, or the whole SoC
DEFAULT_BAUD = 1_000_000      # the paper's parallel-port rate


class ServeError(RuntimeError):
    """The server could not start (bad scene, build failure, harness refused its config)."""


class Interrupted(BaseException):
    """SIGINT or SIGTERM before the device serves (`signum`). A BaseException, like
    KeyboardInterrupt, so that no `except Exception` on the way (a build's) holds it up."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


class _Signals:
    """SIGINT and SIGTERM for `main`: the first one raises Interrupted until `serving` is set
    (the build and the start end at once), and sets `stop` in any case (the serve loop ends).
    A second signal only sets `stop`, so that it cannot break the clean-up of the first."""

    def __init__(self) -> None:
        self.stop = threading.Event()
        self.serving = False

    def __call__(self, signum: int, _frame: Any) -> None:
        first = not self.stop.is_set()
        self.stop.set()
        if first and not self.serving:
            raise Interrupted(signum)


def default_scene() -> Any:
    """No environment, the hand resting on the handle (a soft spring to the start pose)."""
    return scene_mod.from_dict({"env": {"kind": "none"},
                                "hand": {"kind": "spring", "k": 300.0, "b": 2.0}},
                               source="<default serve scene>")


def load_scene(path: str | None, fidelity: str | None = None) -> Any:
    """The validated scene (SceneError names the file and key), or the default one; with
    `fidelity` (--fidelity) its run.fidelity replaced, validated again."""
    sc = default_scene() if path is None else scene_mod.load(path)
    if fidelity is not None and fidelity != sc.run.fidelity:
        sc = sc.override({"run.fidelity": fidelity})
    if sc.run.fidelity not in FIDELITIES:
        raise ServeError(f"{path}: run.fidelity {sc.run.fidelity!r}: serving needs one of "
                         f"{', '.join(FIDELITIES)}")
    return sc


def _for_serving(scene: Any, axes: tuple[int, ...] | None) -> Any:
    """The scene with the run made endless, unrecorded and untraced (and the axes chosen)."""
    run_kw: dict[str, Any] = {"duration_s": SERVE_S, "record": (), "trace": False}
    if axes is not None:
        run_kw["axes"] = tuple(sorted(axes))
    return dataclasses.replace(scene, run=dataclasses.replace(scene.run, **run_kw))


class Server:
    """The virtual device serving its PC link on a fresh pty: `with Server(...) as s:` then
    open `s.port`. `stop()` ends it (SIGTERM) and returns the harness's link summary."""

    def __init__(self, scene: Any = None, baud: int = DEFAULT_BAUD, pace: str = "free",
                 axes: tuple[int, ...] | None = None, view: Any = None) -> None:
        if pace not in PACES:
            raise ServeError(f"--pace {pace}: expected one of {', '.join(PACES)}")
        if not 1200 <= int(baud) <= 12_000_000:
            raise ServeError(f"--baud {baud}: expected 1200..12000000")
        self.scene = _for_serving(default_scene() if scene is None else scene, axes)
        self.baud, self.pace = int(baud), pace
        self.view = view          # a hapgate.device.telemetry.Feed for the live view
        self.port = ""
        self.proc: subprocess.Popen[str] | None = None
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        self._err: list[str] = []
        self._reader: threading.Thread | None = None
        self.building = False     # in start(), building the harness (or finding it built)

    def start(self) -> str:
        sc = self.scene
        self.building = True
        at_soc = sc.run.fidelity == "soc"
        if at_soc and self.view is not None:
            raise ServeError("--view needs run.fidelity 'rtl'")
        if at_soc and tuple(sc.run.axes) != (0, 1, 2):
            raise ServeError("--axes: the soc fidelity builds the whole FPGA (axes 0 1 2)")
        exe = (soc.build(self.baud) if at_soc else
               runner.build(runner.choose_clock(sc), runner.axis_mask(sc), False))
        self.building = False
        q0 = runner.start_pose(sc)
        self._tmp = tempfile.TemporaryDirectory(prefix="serve-",
                                                dir=ensure(BUILD / "native" / "runs"))
        tmp = Path(self._tmp.name)
        master, slave = os.openpty()
        tty.setraw(slave)
        self.port = os.ttyname(slave)
        os.close(slave)          # the PC opens it; while nobody has, the device's bytes drop
        (tmp / "plant.cfg").write_text(runner.plant_config(sc, q0))
        view_cfg, fds = self.view.open() if self.view is not None else ("", ())
        soc_cfg = soc.prepare(sc, q0, tmp, linked=True) if at_soc else ""
        (tmp / "run.cfg").write_text(runner.run_config(sc, q0) + view_cfg + soc_cfg)
        (tmp / "link.cfg").write_text(f"fd = {master}\nbaud = {self.baud}\npace = {self.pace}\n")
        self.proc = subprocess.Popen(
            [str(exe), *(str(tmp / f) for f in ("plant.cfg", "run.cfg")), str(tmp),
             str(tmp / "link.cfg")],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            pass_fds=(master, *fds), cwd=tmp if at_soc else None)
        os.close(master)
        if self.view is not None:
            self.view.started(tmp)
        self._reader = threading.Thread(target=self._read_stderr, daemon=True)
        self._reader.start()
        time.sleep(0.05)
        if self.proc.poll() is not None:
            self._reader.join(timeout=1)
            raise ServeError(f"device harness exited ({self.proc.returncode}): "
                             f"{''.join(self._err).strip()}")
        return self.port

    def _read_stderr(self) -> None:
        assert self.proc is not None and self.proc.stderr is not None
        for line in self.proc.stderr:
            if line.startswith("progress "):
                continue
            if line.startswith("pace:"):          # realtime pacing fell behind: say so now
                sys.stderr.write(line)
                sys.stderr.flush()
                continue
            self._err.append(line)

    def stop(self) -> str:
        """SIGTERM, wait (STOP_WAIT_S, then SIGKILL), and return what the harness reported on
        stderr (the link summary line)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=STOP_WAIT_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self._reader is not None:
            self._reader.join(timeout=5)
        if self.view is not None:
            self.view.finished()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None
        return "".join(self._err)

    def __enter__(self) -> Server:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", metavar="FILE", help="scene TOML (default: hand resting on the "
                   "handle, no environment)")
    p.add_argument("--baud", type=int, default=DEFAULT_BAUD,
                   help=f"link rate, 10 bit-times per byte (default {DEFAULT_BAUD})")
    p.add_argument("--pace", choices=PACES, default="realtime",
                   help="realtime: simulated time follows the wall clock when the device is "
                   "fast enough (and says when it is not); free: as fast as it runs")
    p.add_argument("--fidelity", choices=FIDELITIES,
                   help="rtl: the gateware with the firmware compiled natively; soc: the whole "
                   "SoC, the firmware image on its soft CPU, the link on its UART pins (default: "
                   "the scene's run.fidelity)")
    p.add_argument("--axes", type=int, nargs="+", choices=(0, 1, 2),
                   help="simulate only these axes (the others held; faster)")
    view.add_view_options(p)


def main(args: argparse.Namespace) -> int:
    """Serve until SIGINT or SIGTERM (the module's docstring says what a signal does when)."""
    sigs = _Signals()
    old = {s: signal.signal(s, sigs) for s in (signal.SIGINT, signal.SIGTERM)}
    server: Server | None = None
    try:
        feed = None
        try:
            scene = load_scene(args.scene, getattr(args, "fidelity", None))
            feed = Feed(scene, can_pause=False) if args.view else None
            server = Server(scene, args.baud, args.pace,
                            tuple(args.axes) if args.axes else None, view=feed)
        except (ServeError, ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        try:
            port = server.start()
        except (ServeError, ValueError, RuntimeError) as exc:   # DeviceError is a RuntimeError
            server.stop()
            print(f"error: {exc}", file=sys.stderr)
            return 2
        sigs.serving = True           # from here a signal only ends the serve loop
        print(f"port: {port}", flush=True)
        return _serve(server, feed, args, sigs.stop)
    except Interrupted as exc:
        return _stopped_early(exc.signum, server)
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _serve(server: Server, feed: Feed | None, args: argparse.Namespace,
           stop: threading.Event) -> int:
    """The started server until `stop` is set: its summary on stderr, 0 (1 if the harness
    ended by itself, 2 if the page could not open)."""
    page = None
    if feed is not None:
        page = view.open_page(feed, args, f"device serve on {server.port}",
                              *runner.parts(server.scene))
        if page is None:
            server.stop()
            return 2
    print(f"serving the virtual device ({server.scene.run.fidelity} fidelity) at {server.baud} "
          f"baud, pace {server.pace}, axes "
          f"{list(server.scene.run.axes)}; Ctrl-C stops", file=sys.stderr, flush=True)
    while not stop.is_set():
        if server.proc is not None and server.proc.poll() is not None:
            code, said = server.proc.returncode, server.stop()     # (all it wrote, read)
            if page is not None:
                page.close()
            print(f"error: the device harness ended ({code}): {said.strip()}", file=sys.stderr)
            return 1
        stop.wait(0.2)
    summary = server.stop()
    if page is not None:
        page.close()
    sys.stderr.write(summary)
    sys.stderr.flush()
    return 0


def _stopped_early(signum: int, server: Server | None) -> int:
    """A signal before the device served: say where it stopped, stop what had started (the
    harness's summary, if it ran) and exit 128 + signum."""
    where = "building" if server is not None and server.building else "starting"
    summary = server.stop() if server is not None else ""
    print(f"device serve: stopped while {where}", file=sys.stderr)
    sys.stderr.write(summary)
    sys.stderr.flush()
    return 128 + signum
