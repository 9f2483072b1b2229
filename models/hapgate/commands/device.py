"""`hapgate device serve`: the virtual device (Verilated gateware, unchanged firmware, plant)
with the firmware's PC link on a pseudo-terminal, for PC programs written against
`hapgate.host` (README "Drive the device from a PC").

The pty is opened here (raw mode) and its master end handed to the native harness, whose UART
model (tb/native/device/uart_link.cpp) moves the bytes at the configured baud in simulated
time. `Server` is the same thing as a context manager, for tests and benchmarks.
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
from ..device import runner
from ..device import scene as scene_mod
from ..device.telemetry import Feed
from . import view

SERVE_S = 1e6                 # simulated seconds a server runs for (it stops on a signal)
PACES = ("realtime", "free")
DEFAULT_BAUD = 1_000_000      # the paper's parallel-port rate


class ServeError(RuntimeError):
    """The server could not start (bad scene, build failure, harness refused its config)."""


def default_scene() -> Any:
    """No environment, the hand resting on the handle (a soft spring to the start pose)."""
    return scene_mod.from_dict({"env": {"kind": "none"},
                                "hand": {"kind": "spring", "k": 300.0, "b": 2.0}},
                               source="<default serve scene>")


def load_scene(path: str | None) -> Any:
    """The validated scene (SceneError names the file and key), or the default one."""
    sc = default_scene() if path is None else scene_mod.load(path)
    if sc.run.fidelity != "rtl":
        raise ServeError(f"{path}: run.fidelity {sc.run.fidelity!r}: serving needs 'rtl'")
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

    def start(self) -> str:
        sc = self.scene
        exe = runner.build(runner.choose_clock(sc), runner.axis_mask(sc), False)
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
        (tmp / "run.cfg").write_text(runner.run_config(sc, q0) + view_cfg)
        (tmp / "link.cfg").write_text(f"fd = {master}\nbaud = {self.baud}\npace = {self.pace}\n")
        self.proc = subprocess.Popen(
            [str(exe), *(str(tmp / f) for f in ("plant.cfg", "run.cfg")), str(tmp),
             str(tmp / "link.cfg")],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            pass_fds=(master, *fds))
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
        """SIGTERM, wait, and return what the harness reported (the link summary line)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
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
    p.add_argument("--axes", type=int, nargs="+", choices=(0, 1, 2),
                   help="simulate only these axes (the others held; faster)")
    view.add_view_options(p)


def main(args: argparse.Namespace) -> int:
    feed = None
    try:
        scene = load_scene(args.scene)
        feed = Feed(scene, can_pause=False) if args.view else None
        server = Server(scene, args.baud, args.pace, tuple(args.axes) if args.axes else None,
                        view=feed)
    except (ServeError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    stop = threading.Event()

    def on_signal(_sig: int, _frm: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        port = server.start()
    except (ServeError, ValueError, RuntimeError) as exc:     # DeviceError is a RuntimeError
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"port: {port}", flush=True)
    page = None
    if feed is not None:
        page = view.open_page(feed, args, f"device serve on {port}",
                              *runner.parts(server.scene))
        if page is None:
            server.stop()
            return 2
    print(f"serving the virtual device at {server.baud} baud, pace {server.pace}, axes "
          f"{list(server.scene.run.axes)}; Ctrl-C stops", file=sys.stderr, flush=True)
    while not stop.is_set():
        if server.proc is not None and server.proc.poll() is not None:
            print(f"error: the device harness ended ({server.proc.returncode}): "
                  f"{''.join(server._err).strip()}", file=sys.stderr)
            return 1
        stop.wait(0.2)
    summary = server.stop()
    if page is not None:
        page.close()
    sys.stderr.write(summary)
    return 0
