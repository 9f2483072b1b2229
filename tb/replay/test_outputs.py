"""Outputs never lose data (hapgate.base.atomic): an output path is a regular file or a new name
in an existing folder, anything else is refused with exit 2 naming the path; a failed write (a
full disk) is exit 2 with the old file intact and no temporary file left. And `replay
commutation --engine model` streams: its output does not depend on the chunk size."""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapgate.base import atomic
from hapgate.commands import cli
from test_capture_rules import COMMANDS, replay


def capture(tmp_path: Path, cmd: str) -> Path:
    header, row = COMMANDS[cmd]
    src = tmp_path / "cap.csv"
    src.write_text(f"{header}\n{row}\n{row}\n")
    return src


@pytest.mark.parametrize("cmd", COMMANDS)
def test_special_files_and_folders_are_refused(tmp_path: Path, cmd: str) -> None:
    src = capture(tmp_path, cmd)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    folder = tmp_path / "d"
    folder.mkdir()
    link = tmp_path / "to_full"
    link.symlink_to("/dev/full")
    for out, words in (("/dev/full", "is a device"), ("/dev/null", "is a device"),
                       (str(fifo), "is a FIFO"), (str(folder), "is a folder"),
                       (str(link), "is a device"),
                       (str(tmp_path / "missing" / "o.csv"), "does not exist")):
        r = replay(cmd, "--in", str(src), "--out", out)
        assert r.returncode == 2, (out, r.returncode, r.stdout, r.stderr)
        assert out in r.stderr and words in r.stderr, (out, r.stderr)
        assert "Traceback" not in r.stderr
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)        # still the device
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and link.is_symlink()
    assert not any(folder.iterdir()) and not (tmp_path / "missing").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap.csv", "d", "fifo", "to_full"]


@pytest.mark.parametrize("cmd", COMMANDS)
@pytest.mark.parametrize("fail", ["write", "fsync", "short_write"])
def test_full_disk_leaves_nothing_behind(tmp_path: Path, cmd: str, fail: str,
                                         monkeypatch: pytest.MonkeyPatch,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    src = capture(tmp_path, cmd)
    out = tmp_path / "out.csv"
    out.write_text("old content\n")
    real_write = os.write

    def enospc(*_: object) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    if fail == "write":
        monkeypatch.setattr(atomic.os, "write", enospc)
    elif fail == "fsync":
        monkeypatch.setattr(atomic.os, "fsync", enospc)
    else:                                 # the disk takes a few bytes, then nothing
        monkeypatch.setattr(atomic.os, "write",
                            lambda fd, data: real_write(fd, bytes(data)[:3]) and 0)
    rc = cli.main(["replay", cmd, "--engine", "model", "--in", str(src), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert str(out) in err and "No space left on device" in err, err
    assert out.read_text() == "old content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap.csv", "out.csv"]


def test_atomic_write_replaces_a_regular_file_only(tmp_path: Path) -> None:
    p = tmp_path / "f.txt"
    atomic.write_bytes(p, "one\n")
    atomic.write_bytes(p, b"two\n")
    assert p.read_text() == "two\n" and stat.S_IMODE(p.stat().st_mode) & 0o044  # not 0600
    with pytest.raises(atomic.OutputError, match="is a folder"):
        atomic.write_bytes(tmp_path, "x")
    with pytest.raises(atomic.OutputError, match="/dev/full: is a device"):
        atomic.write_bytes(Path("/dev/full"), "x")
    with pytest.raises(atomic.OutputError, match="does not exist"):
        atomic.write_bytes(tmp_path / "no" / "f", "x")
    with pytest.raises(RuntimeError):
        with atomic.atomic_output(p) as f:
            f.write("three\n")
            raise RuntimeError("the producer failed")
    assert p.read_text() == "two\n" and sorted(x.name for x in tmp_path.iterdir()) == ["f.txt"]


def frames_csv(path: Path, n: int, seed: int = 5) -> None:
    """Frames that exercise every column: positions across the 32-bit wrap, every mode (words
    too), enable off, faults, limits and offsets, in a shuffled column order with an extra one."""
    rng = np.random.default_rng(seed)
    pos = rng.integers(-(1 << 33), 1 << 33, (n, 3))
    torque = rng.integers(-32768, 32768, (n, 3))
    offset = rng.integers(0, 1024, (n, 3))
    mode = rng.choice(np.array(["sine", "six_step", "align", "off", "0", "1"]), (n, 3))
    fault = (rng.random((n, 3)) < 0.05).astype(int)
    enable = (rng.random(n) < 0.9).astype(int)
    limit = np.where(rng.random(n) < 0.5, 65535, rng.integers(0, 65536, n))
    cols = {"note": np.full(n, "x")} | {f"torque{i}": torque[:, i] for i in range(3)} | \
        {f"pos{i}": pos[:, i] for i in range(3)} | {f"mode{i}": mode[:, i] for i in range(3)} | \
        {f"offset{i}": offset[:, i] for i in range(3)} | \
        {f"fault{i}": fault[:, i] for i in range(3)} | {"enable": enable, "limit": limit}
    rows = np.stack([np.asarray(v).astype(str) for v in cols.values()], 1)
    lines = [",".join(cols)] + [",".join(r) for r in rows.tolist()]
    lines.insert(700, "")                      # a blank line mid-stream
    path.write_text("\r\n".join(lines) + "\n")


def test_commutation_model_output_does_not_depend_on_the_chunk(tmp_path: Path) -> None:
    src = tmp_path / "frames.csv"
    frames_csv(src, 4567)
    outs = []
    for rows in ("1000", "997", "1", "1000000"):
        out = tmp_path / f"dac_{rows}.csv"
        r = subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", "commutation",
                            "--engine", "model", "--in", str(src), "--out", str(out),
                            "--chunk-rows", rows], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        outs.append(out.read_bytes())
    assert all(o == outs[-1] for o in outs)
    text = outs[-1].decode().splitlines()
    assert len(text) == 4568 and text[-1].startswith("4566,")
    # an error after the first chunks: exit 2, nothing written (the chunks already made vanish)
    bad = tmp_path / "bad.csv"
    bad.write_text(src.read_text() + "x,1,2,3,0,0,0,sine,sine,sine,0,0,0,0,0,0,1,huge\n")
    out = tmp_path / "never.csv"
    r = subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", "commutation",
                        "--engine", "model", "--in", str(bad), "--out", str(out),
                        "--chunk-rows", "100"], capture_output=True, text=True)
    assert r.returncode == 2 and "limit" in r.stderr, r.stderr
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
