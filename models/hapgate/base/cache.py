"""The one content-hash cache of the tree: whatever is built from inputs (a Verilated harness, a
compiled library, a netlist, a compiled register map, a sweep job's record) is found again by a
key made of the inputs themselves -- the bytes of the files, the flags, tool versions and
parameters -- and published atomically, so a reader never sees a half-built entry.

    key = digest(files=[*sources, harness], data={"params": params, "cflags": cflags})
    exe = cached_dir(BUILD / "native", f"harness-{key}", build=make_it) / "harness"

`cached_dir` builds into a temporary folder beside the entry (under a lock, so parallel workers
build once) and renames it into place when the build returned; a failed build leaves nothing.
`cached_file` does the same for one file.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from . import cbuild
from .atomic import write_bytes
from .paths import ensure, locked


def digest(files: Iterable[Path] = (), data: Any = None, length: int = 12,
           algorithm: str = "sha1") -> str:
    """The hex key of the inputs: `data` as canonical JSON (sorted keys; paths and other objects
    as their text), then the bytes of every file in order. `length` hex digits (None: all)."""
    h = hashlib.new(algorithm)
    if data is not None:
        h.update(json.dumps(data, sort_keys=True, default=str).encode())
    for f in files:
        h.update(Path(f).read_bytes())
    return h.hexdigest()[:length] if length else h.hexdigest()


def cached_dir(root: Path, name: str, build: Callable[[Path], None],
               done: str | None = None, log: str = "build.log") -> Path:
    """root/name, built by `build(tmp)` into a temporary folder and renamed into place unless it
    is already there (with the file `done` in it, if given). Parallel callers wait on a lock and
    reuse the first one's result. A failed build leaves only its log, `log` in the folder,
    copied to root/name.log (a BuildError then names that copy)."""
    final = ensure(root) / name
    with locked(final):
        if final.is_dir() and (done is None or (final / done).exists()):
            return final
        if final.exists():                      # an entry left incomplete by an older layout
            shutil.rmtree(final)
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=root))
        try:
            build(tmp)
            os.rename(tmp, final)
        except BaseException as exc:
            kept = root / f"{name}.log"
            if (tmp / log).exists():
                shutil.copyfile(tmp / log, kept)
            shutil.rmtree(tmp, ignore_errors=True)
            if isinstance(exc, cbuild.BuildError) and (tmp / log) == exc.log:
                raise cbuild.BuildError(str(exc).replace(str(exc.log), str(kept)), kept,
                                        exc.text) from None
            raise
    return final


def cached_file(path: Path, make: Callable[[], str | bytes]) -> Path:
    """`path`, written atomically from `make()` unless it already exists."""
    with locked(path):
        if not path.exists():
            write_bytes(ensure(path.parent) / path.name, make())
    return path
