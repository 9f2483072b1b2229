"""Writing output files so that no data are ever lost: ONE helper for every command that writes
(replay results, scene outputs, sweep results, reports, generated tables).

The rules:

- An output path is a regular file (replaced) or a new name in a folder that exists. Anything
  else (a folder, a device such as /dev/full or /dev/null, a FIFO, a socket, a missing folder)
  is refused with an `OutputError` naming the path; the path is left as it was.
- The data go to a temporary file beside the target; every write is checked (a short write is
  retried, an error raised), the file is flushed to the disk (fsync) and only then renamed over
  the target (the rename and the folder are checked and synced too). On any error (a full disk:
  ENOSPC) the temporary file is removed and the target keeps its old content.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class OutputError(ValueError):
    """An output path that cannot be used, or a write that failed (the message names the path)."""


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def check_output_path(path: Path) -> None:
    """Refuse (OutputError) anything but a regular file or a new name in an existing folder."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    try:
        st = os.stat(path)                   # (follows a symbolic link: its target counts)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise OutputError(f"{path}: cannot use as an output: {_why(exc)}") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OutputError(f"{path}: is a folder; give a file name")
        if not stat.S_ISREG(st.st_mode):
            kind = ("a FIFO" if stat.S_ISFIFO(st.st_mode) else
                    "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                    "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
            raise OutputError(f"{path}: is {kind}, not a regular file; outputs must be regular "
                              f"files or new names in an existing folder")
    elif os.path.islink(path):
        raise OutputError(f"{path}: is a dangling symbolic link")
    if not parent.is_dir():
        raise OutputError(f"{path}: the folder {parent} does not exist (it is not created)")


def _umask() -> int:
    old = os.umask(0o022)
    os.umask(old)
    return old


class AtomicFile:
    """The temporary file of one output; `write()` checks every byte reaches the file."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        check_output_path(self.path)
        parent = self.path.parent if str(self.path.parent) else Path(".")
        try:
            self.fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{self.path.name}.",
                                            suffix=".tmp")
        except OSError as exc:
            raise OutputError(f"{self.path}: cannot write in {parent}: {_why(exc)}") from None
        self.tmp = Path(tmp)
        self.parent = parent

    def write(self, data: bytes | str) -> None:
        view = memoryview(data.encode() if isinstance(data, str) else data)
        try:
            while view.nbytes:
                n = os.write(self.fd, view)
                if n <= 0:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                view = view[n:]
        except OSError as exc:
            raise OutputError(f"{self.path}: write failed: {_why(exc)}") from None

    def commit(self) -> None:
        try:
            os.fsync(self.fd)
            os.fchmod(self.fd, 0o666 & ~_umask())     # mkstemp makes 0600: an ordinary file
            os.close(self.fd)
            self.fd = -1
            check_output_path(self.path)              # (it may have changed since the start)
            os.replace(self.tmp, self.path)
        except OSError as exc:
            raise OutputError(f"{self.path}: write failed: {_why(exc)}") from None
        try:
            dfd = os.open(self.parent, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError as exc:
            raise OutputError(f"{self.path}: written, but its folder could not be synced: "
                              f"{_why(exc)}") from None

    def abort(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        self.tmp.unlink(missing_ok=True)


@contextmanager
def atomic_output(path: Path) -> Iterator[AtomicFile]:
    """`with atomic_output(p) as f: f.write(...)`: p gets all of it, or keeps what it had."""
    f = AtomicFile(path)
    try:
        yield f
        f.commit()
    except BaseException:
        f.abort()
        raise


def write_bytes(path: Path, data: bytes | str) -> Path:
    """Write `data` to `path` atomically (the module's rules); return the path."""
    with atomic_output(path) as f:
        f.write(data)
    return Path(path)
