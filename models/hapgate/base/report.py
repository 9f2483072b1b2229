"""Plain-text tables and report files (build/reports/): every figure printed with its run time."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from .paths import REPORTS, ensure


def table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    cells = [[str(h) for h in headers]] + [[_fmt(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _fmt(c: object) -> str:
    if isinstance(c, float):
        if c == 0:
            return "0"
        a = abs(c)
        return f"{c:.3e}" if a >= 1e6 or a < 1e-3 else f"{c:.4g}"
    return str(c)


def write_csv(name: str, headers: Sequence[str], rows: Sequence[Sequence[object]]) -> Path:
    path = ensure(REPORTS) / name
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(headers)
        w.writerows(rows)
    return path


def figure_path(name: str) -> Path:
    return ensure(REPORTS) / name


def pyplot():
    """matplotlib with a file-only backend (never a window)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
