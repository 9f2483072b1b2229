"""A progress bar for long runs (standard library only; writes to stderr, never to stdout).

    with Progress(total=scene.run.duration_s, label="wall", unit="s") as bar:
        runner.run(scene, progress=bar)   # the runner calls bar(done[, total]) as it likes

Nothing is shown for the first `delay_s` (2 s): short runs stay quiet. On a terminal the bar
redraws in place at most `rate_hz` times a second; into a file or pipe it writes one line per
quarter of the run, so logs stay short.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO


class Progress:
    def __init__(self, total: float, label: str = "", unit: str = "", delay_s: float = 2.0,
                 rate_hz: float = 10.0, stream: TextIO | None = None,
                 clock: Callable[[], float] | None = None) -> None:
        if not total > 0:
            raise ValueError(f"progress total must be > 0, got {total}")
        self.total, self.label, self.unit = float(total), label, unit
        self.delay_s, self.period = delay_s, 1.0 / rate_hz
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock or time.perf_counter
        self.t0 = self.clock()
        self.last_draw = -1.0
        self.last_quarter = 0
        self.shown = False
        self.done = 0.0
        self.first: tuple[float, float] | None = None

    @property
    def tty(self) -> bool:
        return bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, done: float, total: float | None = None) -> None:
        """`done` of `total` (the total given at construction unless passed here)."""
        if total is not None and total > 0:
            self.total = float(total)
        self.done = min(max(float(done), 0.0), self.total)
        now = self.clock()
        if self.first is None:             # the rate is measured from the first report on
            self.first = (now, self.done)  # (a build before the run does not count)
        elapsed = now - self.t0
        if elapsed < self.delay_s:
            return
        if self.tty:
            if now - self.last_draw >= self.period:
                self.last_draw = now
                self._draw(elapsed, end="\r")
        else:
            quarter = int(4 * self.done / self.total)
            if quarter > self.last_quarter:
                self.last_quarter = quarter
                self._draw(elapsed, end="\n")

    def _draw(self, elapsed: float, end: str) -> None:
        frac = self.done / self.total
        width = 30
        fill = int(round(width * frac))
        t1, d1 = self.first if self.first is not None else (self.t0, 0.0)
        rate = (self.done - d1) / (self.clock() - t1) if self.clock() > t1 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("nan")
        self.stream.write(f"{self.label} [{'#' * fill}{'.' * (width - fill)}] {100 * frac:5.1f} % "
                          f"{self.done:.4g}/{self.total:.4g} {self.unit} "
                          f"{elapsed:6.1f} s elapsed, {eta:6.1f} s left{end}")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """End the bar's line (only if it was drawn)."""
        if self.shown and self.tty:
            self._draw(self.clock() - self.t0, end="\n")

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
