"""`hapgate scene run FILE [--out DIR]` and `hapgate scene check FILE...`.

run: load and validate the scene (exit 2, nothing written, on a malformed or unreadable file or
an unusable --out), run it in closed loop (`hapgate.device.runner.run`), print what was built and
skipped and the summary table, write summary.json, run.npz and the plots into DIR (default
build/scenes/<name>/), and exit 0 when every [expect] holds, 1 when one fails, 3 when the run
itself could not be done (the runner raised).
check: validate scene files only (exit 0 when all load, 2 otherwise).
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from ..base.atomic import OutputError
from ..base.paths import BUILD
from ..base.progress import Progress
from ..device import result as res
from ..device import runner
from ..device.scene import SceneError, load
from ..device.telemetry import Feed
from ..golden import kinematics
from . import view

EXIT_PASS, EXIT_FAIL, EXIT_BAD_INPUT, EXIT_NO_RUN = 0, 1, 2, 3
OUTPUT_NAMES = ("summary.json", "run.npz", "position.png", "force_depth.png", "dac.png",
                "torque.png")


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="scene_cmd", required=True)
    rp = sub.add_parser("run", help="run a scene in closed loop, print its table, write outputs")
    rp.add_argument("file", type=Path, help="scene file (TOML; format: scenes/README.md)")
    rp.add_argument("--out", type=Path, default=None,
                    help="output folder (default: build/scenes/<name>/)")
    view.add_view_options(rp)
    rp.set_defaults(fn=cmd_run)
    cp = sub.add_parser("check", help="validate scene files without running them")
    cp.add_argument("files", type=Path, nargs="+")
    cp.set_defaults(fn=cmd_check)


def _err(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)


def _outdir(out: Path) -> Path | None:
    """Create the output folder; None (after saying why) when it cannot be used."""
    if out.exists() and not out.is_dir():
        _err(f"--out {out}: exists and is not a folder")
        return None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        _err(f"--out {out}: cannot create: {exc.strerror or exc}")
        return None
    if not os.access(out, os.W_OK | os.X_OK):
        _err(f"--out {out}: not writable")
        return None
    return out


def cmd_run(args: argparse.Namespace) -> int:
    return run_file(args.file, args.out, args if args.view else None)


def _live_view(scene: Any, args: argparse.Namespace) -> tuple[Any, Any] | None:
    """The feed and the page of a scene run with --view; None after an error message."""
    if scene.run.fidelity != "rtl":
        _err(f"{scene.source}: --view needs run.fidelity = 'rtl' (the scene has "
             f"{scene.run.fidelity!r})")
        return None
    path = scene.hand.path
    target0 = (np.asarray(path[0][1:4], float) if path
               else kinematics.fk(runner.start_pose(scene)))
    feed = Feed(scene, target0=target0 if scene.hand.kind == "spring" else None)
    built, skipped = runner.parts(scene)
    page = view.open_page(feed, args, f"scene {scene.name} ({scene.source})", built, skipped)
    return None if page is None else (feed, page)


def run_file(file: Path, out_dir: Path | None = None,
             view_args: argparse.Namespace | None = None) -> int:
    """Load, run, print and write one scene (what `hapgate scene run` does; `make demo` can
    call it on scenes/short.toml). Returns the exit status. view_args: serve the live view
    (--view-port, --view-host) during the run and after it, until Ctrl-C."""
    try:
        scene = load(file)
    except SceneError as exc:
        _err(str(exc))
        return EXIT_BAD_INPUT
    out = _outdir(out_dir if out_dir is not None else BUILD / "scenes" / scene.name)
    if out is None:
        return EXIT_BAD_INPUT
    live = None
    if view_args is not None:
        live = _live_view(scene, view_args)
        if live is None:
            return EXIT_BAD_INPUT
    try:
        with Progress(total=scene.run.duration_s, label=scene.name, unit="s") as bar:
            live_kw = {"view": live[0]} if live else {}     # the runner's signature otherwise
            r = runner.run(scene, progress=bar, out_dir=out, **live_kw)
    except KeyboardInterrupt:          # Ctrl-C during the run: the harness is stopped with it
        _err(f"{scene.source}: interrupted")
        if live is not None:
            live[1].close()
        return 130
    except SceneError as exc:          # the runner refuses a combination it cannot build
        _err(str(exc))
        return EXIT_BAD_INPUT
    except Exception as exc:  # noqa: BLE001 - reported, distinct exit code
        known = getattr(runner, "DeviceError", ())   # the runner's own, clear message
        if not (isinstance(known, type) and isinstance(exc, known)):
            traceback.print_exc()
        _err(f"{scene.source}: the run failed: {exc}")
        return EXIT_NO_RUN
    outcomes = res.evaluate(scene.expect, r.metrics)
    print(res.summary_text(r, outcomes))
    for name in OUTPUT_NAMES:          # no stale plot of an earlier run beside this one
        (out / name).unlink(missing_ok=True)
    try:
        written = res.write(r, out, outcomes)
    except OutputError as exc:         # a path in DIR that is not a regular file, a full disk
        _err(str(exc))
        return EXIT_BAD_INPUT
    print(f"wrote {out}/: " + ", ".join(p.name for p in written), flush=True)
    if live is not None:
        view.wait_for_signal("the run is over; the view stays up until Ctrl-C")
        live[1].close()
    return EXIT_PASS if res.verdict(outcomes) == "PASS" else EXIT_FAIL


def cmd_check(args: argparse.Namespace) -> int:
    bad = 0
    for f in args.files:
        try:
            s = load(f)
        except SceneError as exc:
            _err(str(exc))
            bad += 1
            continue
        r = s.run
        print(f"{f}: ok: {s.name}, {r.duration_s:g} s, {r.fidelity}, axes "
              f"{','.join(map(str, r.axes))}, {r.servo_hz} Hz, env {s.env.kind}, hand "
              f"{s.hand.kind}, {len(s.faults)} fault(s), {len(s.expect.items())} expect(s)")
    return EXIT_BAD_INPUT if bad else EXIT_PASS


def main(args: argparse.Namespace) -> int:
    return int(args.fn(args))
