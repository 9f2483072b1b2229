"""`hapgate cosim run SCENE [--rate HZ] [--seed N] [--out DIR]` and `hapgate cosim check FILE...`.

run: load the co-simulation scene (a name in scenes/cosim/ or a path; exit 2 on a malformed or
unreadable one, naming the file and the key), run it (`hapgate.runners.cosim.run`: the harness
on the Verilated top and the firmware), print its summary lines and failed checks, keep
ticks.bin, isr.csv, frames.csv and loads.bin in DIR (default build/cosim/<name>/), and exit 0
when the harness's checks hold, 1 when one fails.
check: validate scene files only (exit 0 when all load, 2 otherwise).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..base.paths import BUILD
from ..runners import cosim

EXIT_BAD_INPUT = 2


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="cosim_cmd", required=True)
    rp = sub.add_parser("run", help="run a co-simulation scene, print its summary")
    rp.add_argument("scene", help="a name in scenes/cosim/ (" + ", ".join(cosim.SCENARIOS)
                    + ") or a TOML file (format: tb/native/cosim/README.md)")
    rp.add_argument("--rate", type=int, default=None, help="servo tick, Hz (the scene's)")
    rp.add_argument("--seed", type=int, default=None, help="power-up positions (the scene's)")
    rp.add_argument("--out", type=Path, default=None,
                    help="output folder (default: build/cosim/<name>/)")
    rp.set_defaults(fn=cmd_run)
    cp = sub.add_parser("check", help="validate co-simulation scene files without running them")
    cp.add_argument("files", type=Path, nargs="+")
    cp.set_defaults(fn=cmd_check)


def cmd_run(args: argparse.Namespace) -> int:
    try:
        name = cosim.load(args.scene).name
    except cosim.CosimSceneError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    out = args.out if args.out is not None else BUILD / "cosim" / name
    r = cosim.run(args.scene, args.rate, seed=args.seed, keep=out)
    print(" ".join(f"{k}={v}" for k, v in r.summary.items()))
    for f in r.fails:
        print(f"fail: {f}")
    print(f"outputs: {out}")
    return 0 if r.ok else 1


def cmd_check(args: argparse.Namespace) -> int:
    bad = 0
    for f in args.files:
        try:
            cosim.load(f)
        except cosim.CosimSceneError as exc:
            print(f"error: {exc}", file=sys.stderr)
            bad += 1
    return EXIT_BAD_INPUT if bad else 0
