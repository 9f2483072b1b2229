"""CSV captures in and results out, for the replay commands: strict, vectorised, with errors that
name the file and line. Nothing is written when the input is bad."""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np


class CaptureError(ValueError):
    """A malformed input file (the message names the file and the line)."""


def read_csv_columns(path: Path, required: Sequence[str], optional: Sequence[str] = ()
                     ) -> dict[str, np.ndarray]:
    """Read the named numeric columns of a CSV with a header row (other columns are ignored).

    Returns float64 arrays keyed by column name (optional columns only when present)."""
    path = Path(path)
    try:
        with open(path, newline="") as f:
            header = f.readline()
    except OSError as exc:
        raise CaptureError(f"{path}: cannot read: {exc.strerror}") from None
    names = [h.strip().lower() for h in header.strip().split(",")]
    if not header.strip():
        raise CaptureError(f"{path}:1: empty file (a header row is required)")
    dup = sorted({n for n in names if names.count(n) > 1 and n})
    if dup:
        raise CaptureError(f"{path}:1: duplicate columns in the header: {', '.join(dup)}")
    missing = [c for c in required if c not in names]
    if missing:
        raise CaptureError(f"{path}:1: header lacks column(s) {', '.join(missing)} "
                           f"(found: {', '.join(names)})")
    wanted = [c for c in (*required, *optional) if c in names]
    cols = [names.index(c) for c in wanted]
    try:
        data = _load(path, cols)
    except (ValueError, IndexError) as exc:
        why = re.sub(r" at row \d+.*$", "", str(exc)).rstrip(".")
        raise CaptureError(f"{path}:{_locate(path, cols)}: malformed row: {why}") from None
    if data.shape[0] == 0:
        raise CaptureError(f"{path}:2: no data rows after the header")
    bad = np.flatnonzero(~np.isfinite(data).all(axis=1))
    if bad.size:
        raise CaptureError(f"{path}:{bad[0] + 2}: non-finite value")
    return {c: data[:, i] for i, c in enumerate(wanted)}


def _load(path: Path, cols: list[int], max_rows: int | None = None) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # "input contained no data": ours to say
        return np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, dtype=np.float64,
                          ndmin=2, comments=None, max_rows=max_rows)


def _locate(path: Path, cols: list[int]) -> str:
    """The file line (1-based) of the first malformed row, by bisection over loadtxt's
    max_rows (each probe is one vectorised load). Only runs on the error path."""
    n = sum(1 for _ in open(path, "rb")) - 1
    lo, hi = 0, n            # the first lo rows load; the first hi rows do not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            _load(path, cols, mid)
            lo = mid
        except (ValueError, IndexError):
            hi = mid
    return str(hi + 1)


def as_int(path: Path, name: str, values: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Check that a column holds integers in lo..hi; error names the first bad line."""
    bad = np.flatnonzero((values != np.round(values)) | (values < lo) | (values > hi))
    if bad.size:
        k = int(bad[0])
        raise CaptureError(f"{path}:{k + 2}: column {name!r} = {values[k]!r} is not an integer "
                           f"in {lo}..{hi}")
    return values.astype(np.int64)


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Integer columns to CSV with a header row (vectorised)."""
    names = list(columns)
    mat = np.stack([np.asarray(columns[c], dtype=np.int64) for c in names], 1)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, mat, fmt="%d", delimiter=",", header=",".join(names), comments="")
