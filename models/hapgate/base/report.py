"""Plain-text tables and report files (build/reports/): every figure printed with its run time."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .atomic import write_bytes
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


def csv_text(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    f = io.StringIO(newline="")
    w = csv.writer(f)
    w.writerow(headers)
    w.writerows(rows)
    return f.getvalue()


def write_csv(name: str, headers: Sequence[str], rows: Sequence[Sequence[object]]) -> Path:
    """build/reports/<name>, written atomically (base.atomic)."""
    return write_bytes(ensure(REPORTS) / name, csv_text(headers, rows))


def save_figure(fig: object, path: Path, dpi: int = 100) -> Path:
    """A matplotlib figure as PNG at `path`, written atomically (base.atomic)."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")  # type: ignore[attr-defined]
    return write_bytes(path, buf.getvalue())


def npz_bytes(arrays: dict[str, object]) -> bytes:
    """np.savez of `arrays` as bytes (for write_bytes)."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def figure_path(name: str) -> Path:
    return ensure(REPORTS) / name


def pyplot():
    """matplotlib with a file-only backend (never a window)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
