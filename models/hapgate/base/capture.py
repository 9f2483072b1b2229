"""CSV captures in and results out, for the replay commands (`replay interp`, `replay
commutation`): ONE reader with ONE rule set, streamed in chunks (memory bounded by the chunk and
the numeric columns kept), errors that name the file, the line and the column, and results
written atomically (nothing is written when anything is wrong).

The rules (the same for every command; each command only declares its columns):

- UTF-8 text (a leading byte-order mark is allowed); line ends LF or CRLF; at most
  MAX_LINE_BYTES bytes per line. Anything else: `FILE:LINE:COL: ...` (COL counts characters,
  1-based; for undecodable bytes, bytes).
- Blank lines (empty or spaces only) are skipped anywhere; line numbers are always the file's own.
- The first non-blank line is the header: comma-separated names, case-insensitive, spaces around
  them ignored. An empty name or a duplicate name is an error; a missing required column is an
  error; columns the command does not know are ignored and reported (`CaptureTable.ignored`).
- Every data line has as many fields as the header. Spaces around a cell are ignored; an empty
  cell is an error.
- Integer columns: an optional sign and decimal digits only (`1.0`, `1e1`, `0x10` are not
  integers), inside the column's range; a column may also accept words (e.g. `sine`).
  Float columns: a finite decimal number (no `nan`, no `inf`).
- At least one data line.
"""

from __future__ import annotations

import io
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import AtomicFile, OutputError, check_output_path
from .progress import Progress

MAX_LINE_BYTES = 4096          # longer lines are rejected (a capture line is ~20-80 bytes)
CHUNK_BYTES = 1 << 20          # read this much at a time
INT64_MIN, INT64_MAX = -(1 << 63), (1 << 63) - 1


class CaptureError(ValueError):
    """A malformed input file or an unusable output path (the message names file and line)."""


@dataclass(frozen=True)
class Column:
    """One column a command reads. kind "int" (range lo..hi, optional words) or "float"."""
    name: str
    kind: str = "int"
    lo: int = INT64_MIN
    hi: int = INT64_MAX
    required: bool = True
    default: float | None = None          # value of an absent optional column
    words: Mapping[str, int] = field(default_factory=dict)


@dataclass
class CaptureTable:
    columns: dict[str, np.ndarray]        # int64 or float64, one entry per data line
    lines: np.ndarray                     # the file line (1-based) of each data row
    ignored: list[str]                    # header columns the command does not use

    def __len__(self) -> int:
        return int(self.lines.size)


def _where(path: Path, line: int, col: int | None = None) -> str:
    return f"{path}:{line}" + (f":{col}" if col is not None else "")


def _chunks(path: Path, max_line: int, chunk: int):
    """Yield (first line number, text) of whole lines, chunk by chunk; reject non-UTF-8 bytes
    and over-long lines without ever holding more than chunk + max_line bytes."""
    try:
        f = open(path, "rb")
    except OSError as exc:
        raise CaptureError(f"{path}: cannot read: {exc.strerror}") from None
    with f:
        lineno, carry, first = 1, b"", True
        while True:
            try:
                block = f.read(chunk)
            except OSError as exc:
                raise CaptureError(f"{path}: cannot read: {exc.strerror}") from None
            data = carry + block
            if first and data.startswith(b"\xef\xbb\xbf"):
                data = data[3:]
            first = False
            if not block:
                body, carry = data, b""
            else:
                cut = data.rfind(b"\n")
                body, carry = (data[:cut], data[cut + 1:]) if cut >= 0 else (b"", data)
                if len(carry) > max_line + 1:            # + a possible CR
                    n = body.count(b"\n") + (1 if cut >= 0 else 0)
                    raise CaptureError(f"{_where(path, lineno + n)}: line longer than "
                                       f"{max_line} bytes")
                if cut < 0:
                    continue
            if not body and not block:
                return
            arr = np.frombuffer(body, dtype=np.uint8)
            nl = np.flatnonzero(arr == 10)
            ends = np.concatenate((nl, [arr.size]))
            starts = np.concatenate(([0], nl + 1))
            cr = np.zeros(ends.size, dtype=np.int64)
            if arr.size:
                cr = ((arr[np.maximum(ends - 1, 0)] == 13) & (ends > starts)).astype(np.int64)
            long = np.flatnonzero(ends - starts - cr > max_line)
            if long.size:
                raise CaptureError(f"{_where(path, lineno + int(long[0]))}: line longer than "
                                   f"{max_line} bytes")
            try:
                text = body.decode("utf-8")
            except UnicodeDecodeError as exc:
                k = int(np.searchsorted(nl, exc.start))        # lines before the bad byte
                col = exc.start - (int(nl[k - 1]) + 1 if k else 0) + 1
                raise CaptureError(f"{_where(path, lineno + k, col)}: not UTF-8 text (byte "
                                   f"0x{body[exc.start]:02x})") from None
            yield lineno, text
            lineno += nl.size + 1
            if not block:
                return


def _col_of(line: str, j: int) -> int:
    """1-based character column where field j of a raw line starts (error path only)."""
    parts = line.split(",")
    return 1 + sum(len(p) + 1 for p in parts[:j])


def _parse(path: Path, col: Column, j: int, text: np.ndarray, raw: list[str],
           lines: np.ndarray) -> np.ndarray:
    """Vectorised parse of one column's cells (stripped strings) with the rule set."""
    def fail(k: int, why: str) -> CaptureError:
        return CaptureError(f"{_where(path, int(lines[k]), _col_of(raw[k], j))}: column "
                            f"{col.name!r}: {why}")

    empty = np.flatnonzero(np.char.str_len(text) == 0)
    if empty.size:
        raise fail(int(empty[0]), "empty cell")
    if col.kind == "float":
        try:
            vals = text.astype(np.float64)
        except ValueError:
            for k, t in enumerate(text.tolist()):       # error path: find the first bad cell
                try:
                    float(t)
                except ValueError:
                    raise fail(k, f"{t!r} is not a number") from None
            raise
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            raise fail(int(bad[0]), f"{str(text[bad[0]])!r} is not a finite number")
        return vals
    if col.words:
        lower = np.char.lower(text)
        for word, val in col.words.items():
            text = np.where(lower == word.lower(), str(val), text)
    digits = np.char.lstrip(text, "+-")
    nsign = np.char.str_len(text) - np.char.str_len(digits)
    signed = np.char.startswith(text, "-") | np.char.startswith(text, "+")
    ok = np.char.isdecimal(digits) & ((nsign == 0) | ((nsign == 1) & signed))
    bad = np.flatnonzero(~ok)
    if bad.size:
        k = int(bad[0])
        names = f" or one of {', '.join(col.words)}" if col.words else ""
        raise fail(k, f"{raw_cell(raw[k], j)!r} is not an integer{names}")
    big = np.char.str_len(digits) >= 19              # may not fit int64: checked one by one
    vals = np.where(big, "0", text).astype(np.int64)
    outside = (vals < col.lo) | (vals > col.hi)
    for k in np.flatnonzero(big).tolist():
        v = int(text[k])
        outside[k] = not col.lo <= v <= col.hi
        if not outside[k]:
            vals[k] = v
    bad = np.flatnonzero(outside)
    if bad.size:
        k = int(bad[0])
        raise fail(k, f"{raw_cell(raw[k], j)!r} is outside {col.lo}..{col.hi}")
    return vals


def raw_cell(line: str, j: int) -> str:
    parts = line.split(",")
    return parts[j].strip() if j < len(parts) else ""


def iter_table(path: Path, columns: Sequence[Column], max_line_bytes: int = MAX_LINE_BYTES,
               chunk_bytes: int = CHUNK_BYTES) -> Iterator[CaptureTable]:
    """The declared columns of a capture CSV with the module's rule set, one table per block of
    the file read (memory bounded by chunk_bytes, whatever the file's size). An error in the
    file is raised when its block is reached: a consumer that writes as it goes writes through
    CsvWriter, so an error still leaves nothing behind."""
    path = Path(path)
    if path.is_dir():
        raise CaptureError(f"{path}: is a folder, not a CSV file")
    header: list[str] | None = None
    idx: dict[str, int] = {}
    any_rows = False
    last_line = 0
    for first, text in _chunks(path, max_line_bytes, chunk_bytes):
        raw = text.replace("\r\n", "\n").split("\n")
        lines = first + np.arange(len(raw), dtype=np.int64)
        last_line = int(lines[-1])
        arr = np.array(raw, dtype=str) if raw else np.zeros(0, dtype=str)
        keep = np.flatnonzero(np.char.str_len(np.char.strip(arr)) > 0) if arr.size else arr
        if keep.size == 0:
            continue
        if header is None:
            h = int(keep[0])
            header = [n.strip().lower() for n in raw[h].split(",")]
            empty = [k for k, n in enumerate(header) if not n]
            if empty:
                raise CaptureError(f"{_where(path, int(lines[h]), _col_of(raw[h], empty[0]))}: "
                                   f"empty column name in the header")
            dup = sorted({n for n in header if header.count(n) > 1})
            if dup:
                raise CaptureError(f"{_where(path, int(lines[h]))}: duplicate column(s) in the "
                                   f"header: {', '.join(dup)}")
            missing = [c.name for c in columns if c.required and c.name not in header]
            if missing:
                raise CaptureError(f"{_where(path, int(lines[h]))}: header lacks column(s) "
                                   f"{', '.join(missing)} (found: {', '.join(header)})")
            idx = {c.name: header.index(c.name) for c in columns if c.name in header}
            keep = keep[1:]
            if keep.size == 0:
                continue
        rows = [raw[k] for k in keep.tolist()]
        rlines = lines[keep]
        cells = np.char.split(np.array(rows, dtype=str), ",")
        nf = np.fromiter(map(len, cells), dtype=np.int64, count=len(rows))
        bad = np.flatnonzero(nf != len(header))
        if bad.size:
            k = int(bad[0])
            raise CaptureError(f"{_where(path, int(rlines[k]))}: {nf[k]} fields, the header "
                               f"has {len(header)}")
        grid = np.char.strip(np.array(cells.tolist(), dtype=str).reshape(len(rows),
                                                                          len(header)))
        out: dict[str, np.ndarray] = {}
        for c in columns:
            if c.name in idx:
                out[c.name] = _parse(path, c, idx[c.name], grid[:, idx[c.name]], rows, rlines)
            elif c.default is not None:
                out[c.name] = np.full(len(rows), c.default, dtype=np.float64 if c.kind == "float"
                                      else np.int64)
        known = {c.name for c in columns}
        any_rows = True
        yield CaptureTable(out, rlines, [h for h in header if h not in known])
    if header is None:
        raise CaptureError(f"{_where(path, 1)}: empty file (a header line is required)")
    if not any_rows:
        raise CaptureError(f"{_where(path, last_line + 1 if last_line else 2)}: no data lines "
                           f"after the header")


def concat(tables: Sequence[CaptureTable]) -> CaptureTable:
    """One table of several (in order)."""
    return CaptureTable({k: np.concatenate([t.columns[k] for t in tables])
                         for k in tables[0].columns},
                        np.concatenate([t.lines for t in tables]), tables[0].ignored)


def rechunk(tables: Iterable[CaptureTable], rows: int) -> Iterator[CaptureTable]:
    """The same rows in tables of exactly `rows` rows (the last may be shorter)."""
    if rows < 1:
        raise ValueError(f"chunk rows must be >= 1, got {rows}")
    held: list[CaptureTable] = []
    n = 0
    for t in tables:
        held.append(t)
        n += len(t)
        while n >= rows:
            whole = concat(held) if len(held) > 1 else held[0]
            yield CaptureTable({k: v[:rows] for k, v in whole.columns.items()},
                               whole.lines[:rows], whole.ignored)
            rest = CaptureTable({k: v[rows:] for k, v in whole.columns.items()},
                                whole.lines[rows:], whole.ignored)
            held, n = ([rest] if len(rest) else []), len(rest)
    if held:
        yield concat(held) if len(held) > 1 else held[0]


def line_progress(path: Path, label: str) -> Progress:
    """A progress bar over the lines of a CSV file, its total estimated from the file's size and
    its first 64 KiB (called with the line number reached)."""
    try:
        size = Path(path).stat().st_size
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError:             # (reading it will say what is wrong)
        size, head = 1, b""
    lines = size * max(head.count(b"\n"), 1) / max(len(head), 1)
    return Progress(total=max(lines, 1.0), label=label, unit="lines")


def read_table(path: Path, columns: Sequence[Column], max_line_bytes: int = MAX_LINE_BYTES,
               chunk_bytes: int = CHUNK_BYTES) -> CaptureTable:
    """Read the declared columns of a whole capture CSV with the module's rule set."""
    return concat(list(iter_table(path, columns, max_line_bytes, chunk_bytes)))


# ---------------------------------------------------------------------------- output

def given_path(option: str, text: str | Path) -> Path:
    """The path an option names (argparse gives the text as typed): an empty one is an error
    naming the option (Path("") is ".", and the error would name a folder nobody gave)."""
    if not str(text):
        raise CaptureError(f"{option}: the path is empty")
    return Path(text)


def check_output(out: Path, inputs: Sequence[Path] = ()) -> None:
    """Before any work: the output is a regular file or a new name in an existing folder
    (base.atomic's rules: no folder, device, FIFO or missing folder), the folder is writable,
    the file is not read-only, and it is not one of the inputs (a capture is never
    overwritten)."""
    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    try:
        check_output_path(out)
    except OutputError as exc:
        raise CaptureError(str(exc)) from None
    try:                                   # a real probe (access() says yes to root)
        fd, probe = tempfile.mkstemp(dir=parent, prefix=f".{out.name}.", suffix=".probe")
        os.close(fd)
        os.unlink(probe)
    except OSError:
        raise CaptureError(f"{out}: the folder {parent} is not writable") from None
    if out.exists() and not os.access(out, os.W_OK):
        raise CaptureError(f"{out}: the file exists and is not writable")
    for i in inputs:
        i = Path(i)
        same = out.resolve() == i.resolve()
        if not same and out.exists() and i.exists():
            same = os.path.samefile(out, i)
        if same:
            raise CaptureError(f"{out}: --out is the input file {i}; it would be overwritten")


def _csv_text(columns: Mapping[str, np.ndarray], fmts: list[str], floaty: bool) -> bytes:
    mat = np.stack([np.asarray(columns[c], dtype=np.float64 if floaty else np.int64)
                    for c in columns], 1)
    buf = io.BytesIO()
    np.savetxt(buf, mat, fmt=fmts, delimiter=",")
    return buf.getvalue()


class CsvWriter:
    """A result CSV written chunk by chunk (memory bounded by a chunk), atomically: the header
    and every chunk go to a temporary file, renamed over the target by `close()` only when
    complete (base.atomic: checked writes, fsync; on an error nothing is left behind).
    Integer columns unless `fmt` says."""

    def __init__(self, path: Path, names: Sequence[str],
                 fmt: Mapping[str, str] | None = None) -> None:
        self.names = list(names)
        fmt = dict(fmt or {})
        self.fmts = [fmt.get(c, "%d") for c in self.names]
        self.floaty = any(f != "%d" for f in self.fmts)
        try:
            self.file = AtomicFile(path)
        except OutputError as exc:
            raise CaptureError(str(exc)) from None
        self._write((",".join(self.names) + "\n").encode())

    def _write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OutputError as exc:
            self.file.abort()
            raise CaptureError(str(exc)) from None

    def add(self, columns: Mapping[str, np.ndarray]) -> None:
        self._write(_csv_text({c: columns[c] for c in self.names}, self.fmts, self.floaty))

    def close(self) -> None:
        try:
            self.file.commit()
        except OutputError as exc:
            self.file.abort()
            raise CaptureError(str(exc)) from None

    def abort(self) -> None:
        self.file.abort()

    def __enter__(self) -> CsvWriter:
        return self

    def __exit__(self, kind: object, *_: object) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def write_csv(path: Path, columns: Mapping[str, np.ndarray],
              fmt: Mapping[str, str] | None = None) -> None:
    """Columns to CSV with a header row (vectorised), atomically (CsvWriter, one chunk)."""
    with CsvWriter(path, list(columns), fmt) as w:
        w.add(columns)
