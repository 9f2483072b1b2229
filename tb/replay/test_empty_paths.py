"""An empty path given to a replay command (`--in ''`, `--out ''`, `--harm ''`) is named as
empty, exit 2 and nothing written -- not taken for ".", the current folder (issue 35, item 6)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

HEADERS = {"interp": "a,b\n1,2\n", "commutation": "pos0,pos1,pos2,torque0,torque1,torque2\n"
                                                  "0,0,0,1,2,3\n"}


def replay(cmd: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", cmd,
                           "--engine", "model", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("cmd", sorted(HEADERS))
@pytest.mark.parametrize("empty", ["--in", "--out"])
def test_empty_path_is_named_as_empty(tmp_path: Path, cmd: str, empty: str) -> None:
    src = tmp_path / "in.csv"
    src.write_text(HEADERS[cmd])
    paths = {"--in": str(src), "--out": str(tmp_path / "out.csv")} | {empty: ""}
    r = replay(cmd, *(x for kv in paths.items() for x in kv), cwd=tmp_path)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr == f"error: {empty}: the path is empty\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]      # nothing written


def test_empty_harm_table_path_is_named_as_empty(tmp_path: Path) -> None:
    src = tmp_path / "in.csv"
    src.write_text(HEADERS["interp"])
    r = replay("interp", "--angle", "ratio", "--harm", "", "--in", str(src), "--out",
               str(tmp_path / "out.csv"), cwd=tmp_path)
    assert r.returncode == 2 and r.stderr == "error: --harm: the path is empty\n", r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]
