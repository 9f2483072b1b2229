"""Writing lookup tables as $readmemh files: one writer for every ROM in the design.

Files go to build/gen/ and are written atomically, so parallel test workers that generate the
same table never see a half-written file. The RTL receives the path as a parameter.

Reading a configuration's parameters (`rtl_params()`) writes nothing: a table parameter is a
`TableFile`, a path that knows its contents. Generating the files is an explicit call,
`write_tables(params)`, which every build step (simulation, native harness, lint, synthesis)
makes before it hands the parameters to a tool.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path, PosixPath

import numpy as np

from .atomic import write_bytes
from .paths import GEN, ensure


def hex_text(values: np.ndarray, width: int) -> str:
    """One unsigned hex word per line (two's complement for negatives), `width` bits each."""
    v = np.asarray(values, dtype=np.int64)
    if v.ndim != 1 or v.size == 0:
        raise ValueError("a table is a non-empty 1-D array")
    lo, hi = -(1 << (width - 1)), (1 << width) - 1
    if v.min() < lo or v.max() > hi:
        raise ValueError(f"table values {v.min()}..{v.max()} do not fit {width} bits")
    digits = (width + 3) // 4
    words = v & ((1 << width) - 1)
    return "\n".join(f"{w:0{digits}x}" for w in words.tolist()) + "\n"


def write_hex(name: str, values: np.ndarray, width: int, directory: Path | None = None) -> Path:
    """Write `values` to <directory>/<name>.hex (default build/gen) atomically; return the path."""
    out_dir = ensure(directory or GEN)
    path = out_dir / f"{name}.hex"
    text = hex_text(values, width)
    if path.exists() and path.read_text() == text:
        return path
    return write_bytes(path, text)


def read_hex(path: Path, width: int, signed: bool = False) -> np.ndarray:
    """Read a $readmemh file back (used by tests to prove the RTL reads what the model uses)."""
    words = np.array([int(t, 16) for t in Path(path).read_text().split()], dtype=np.int64)
    if signed:
        words = np.where(words >= 1 << (width - 1), words - (1 << width), words)
    return words


class TableFile(PosixPath):
    """The path of a generated table, <directory>/<name>.hex, with what to write there:
    `values()` (a 1-D array) in `width`-bit words. Equal to (and usable as) the plain path;
    nothing is written until `write()` (or `write_tables`) is called."""

    values: Callable[[], np.ndarray]
    width: int

    @classmethod
    def of(cls, name: str, values: Callable[[], np.ndarray], width: int,
           directory: Path | None = None) -> TableFile:
        t = cls(Path(directory or GEN) / f"{name}.hex")
        t.values, t.width = values, int(width)
        return t

    def write(self) -> Path:
        return write_hex(self.stem, self.values(), self.width, self.parent)

    def __reduce__(self):  # noqa: ANN204 - pickled with its generator (sweep workers)
        return (_table_file, (str(self), self.values, self.width))


def _table_file(path: str, values: Callable[[], np.ndarray], width: int) -> TableFile:
    p = Path(path)
    return TableFile.of(p.stem, values, width, p.parent)


def write_tables(params: Mapping[str, object]) -> list[Path]:
    """Write every table a parameter set names (`TableFile` values); return their paths.
    Idempotent and safe in parallel (write_hex)."""
    return [v.write() for v in params.values() if isinstance(v, TableFile)]
