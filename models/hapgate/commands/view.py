"""`hapgate view RUN_DIR`, and the `--view` of `hapgate scene run` and `hapgate device serve`:
the live view's page (docs/view.md), served by the process that runs the device.

Each prints `view: http://HOST:PORT/` on its own stdout line. Bad inputs (a RUN_DIR without
run.npz, a corrupt npz, a port in use) exit 2 with a message naming the path or the port.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from typing import Any

EXIT_BAD_INPUT = 2


def add_view_options(p: argparse.ArgumentParser, flag: bool = True) -> None:
    """--view (when flag), --view-port, --view-host."""
    if flag:
        p.add_argument("--view", action="store_true",
                       help="serve the live view in the browser (prints 'view: URL')")
    p.add_argument("--view-port", type=int, default=0, metavar="N",
                   help="the page's port (default: a free one)")
    p.add_argument("--view-host", default="127.0.0.1", metavar="HOST",
                   help="the address the page binds to (default 127.0.0.1: this machine only)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="a `hapgate scene run` output folder (run.npz)")
    add_view_options(p, flag=False)


def open_page(source: Any, args: argparse.Namespace, title: str,
              built: list[str] | None = None, skipped: list[str] | None = None) -> Any:
    """The page over source, its URL printed on stdout; None after an error message (the
    caller exits 2)."""
    from ..device.view import Page, ViewError

    if not 0 <= args.view_port <= 65535:
        print(f"error: --view-port {args.view_port}: expected 0..65535", file=sys.stderr)
        return None
    try:
        page = Page(source, args.view_host, args.view_port or None, title, built, skipped)
    except (ViewError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None
    print(f"view: {page.url}", flush=True)
    return page


def wait_for_signal(note: str) -> None:
    """Serve until SIGINT or SIGTERM."""
    stop = threading.Event()
    old = {s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    print(note, file=sys.stderr, flush=True)
    try:
        while not stop.wait(0.2):
            pass
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def main(args: argparse.Namespace) -> int:
    from ..device.telemetry import Replay, ViewInputError

    try:
        replay = Replay(args.run_dir)
    except ViewInputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    page = open_page(replay, args, f"replay of {args.run_dir}")
    if page is None:
        return EXIT_BAD_INPUT
    wait_for_signal(f"replaying {args.run_dir}/run.npz ({replay.t.size} samples, "
                    f"{replay.t[-1]:.3f} s); Ctrl-C stops")
    page.close()
    return 0
