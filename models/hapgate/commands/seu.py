"""`hapgate seu sites [SCENE] [--registers]` and `hapgate seu run SCENE --site S --mode M --at-s T
[--frames N] [--out DIR]`: the fault-injection campaign's inventory and one injection
(scenes/seu/README.md).

sites: the flip-flop sites of the gateware the scene builds (hapgate.flows.saboteur), per block
(bits, registers) and, with --registers, per register; and the memories (not injected).
run: one injection into the closed loop (the worst-site table's replay command), its class
against the clean run and what it rests on; with --out the run's records (run.npz: the run's
and the reference's torques, ticks and DAC loads). Exit 0 when it ran, 2 for a bad scene,
site or option (nothing written), 3 when the run could not be done.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from ..base.atomic import OutputError, write_bytes
from ..base.paths import ensure
from ..base.report import npz_bytes, table
from ..device import seu
from ..device.scene import SceneError

EXIT_OK, EXIT_BAD_INPUT, EXIT_NO_RUN = 0, 2, 3


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="seu_cmd", required=True)
    sp = sub.add_parser("sites", help="the flip-flop sites per block (and register)")
    sp.add_argument("scene", type=Path, nargs="?", default=seu.SCENE,
                    help="the campaign's scene (default scenes/seu/rest.toml)")
    sp.add_argument("--registers", action="store_true", help="one row per register too")
    sp.set_defaults(fn=cmd_sites)
    rp = sub.add_parser("run", help="one injection in the closed loop, classified")
    rp.add_argument("scene", type=Path, help="the campaign's scene (scenes/seu/rest.toml)")
    rp.add_argument("--site", required=True, help="register[bit] (hapgate seu sites), or index")
    rp.add_argument("--mode", required=True, choices=seu.MODES)
    rp.add_argument("--at-s", type=float, required=True, help="scene time of the injection, s")
    rp.add_argument("--frames", type=int, default=0, help="stuck-at: DAC frames held")
    rp.add_argument("--out", type=Path, default=None, help="write run.npz here")
    rp.set_defaults(fn=cmd_run)


def _err(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)


def cmd_sites(args: argparse.Namespace) -> int:
    try:
        _sc, d, clk = seu.setup(args.scene)
    except (SceneError, ValueError) as exc:
        _err(str(exc))
        return EXIT_BAD_INPUT
    regs: dict[str, list[seu.saboteur.Site]] = {}
    for s in d.sites:
        regs.setdefault(s.register, []).append(s)
    bits = d.bits_per_block()
    rows = [[b, n, sum(1 for r, ss in regs.items() if ss[0].block == b)]
            for b, n in sorted(bits.items())]
    rows.append(["all", len(d.sites), len(regs)])
    print(f"hapgate_top at {clk / 1e6:g} MHz: {len(d.sites)} flip-flop bits "
          f"(netlist {d.netlist})")
    print(table(["block", "flip-flop bits", "registers"], rows))
    if args.registers:
        print(table(["register", "block", "bits", "source"],
                    [[r, ss[0].block, len(ss), ss[0].src] for r, ss in sorted(regs.items())]))
    print(table(["flip-flops nothing reads (not sites)", "block", "bits"],
                [[r, b, n] for b, r, n in d.unread]))
    print(table(["memory (not injected)", "block", "words", "width", "bits", "kind"],
                [[m.name, m.block, m.words, m.width, m.words * m.width,
                  "ROM" if m.rom else "RAM"] for m in d.memories]))
    return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    try:
        sc, d, _clk = seu.setup(args.scene)
        inj = seu.injection(d, args.site, args.mode, args.at_s, args.frames)
        if not 0 < inj.at_s < float(sc.run.duration_s):
            raise ValueError(f"--at-s {inj.at_s}: inside the scene's {sc.run.duration_s} s")
    except (SceneError, ValueError, KeyError) as exc:
        _err(str(exc.args[0]) if isinstance(exc, KeyError) else str(exc))
        return EXIT_BAD_INPUT
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        _err(f"--out {args.out}: exists and is not a folder")
        return EXIT_BAD_INPUT
    try:
        rec, ref, tr = seu.run_one(args.scene, inj)
    except Exception as exc:                         # noqa: BLE001 - reported, exit 3
        _err(f"the run could not be done: {type(exc).__name__}: {exc}")
        return EXIT_NO_RUN
    print(f"{inj.site} ({inj.block}), {inj.mode} at {inj.at_s * 1e3:.4f} ms"
          + (f" for {inj.frames} frames" if inj.frames else ""))
    fmt = {k: (f"{v * 1e3:.4f} ms" if k.startswith("t_") and math.isfinite(v) else v)
           for k, v in rec.items()}
    print(table(["quantity", "value"], [[k, str(v)] for k, v in fmt.items()]))
    if args.out is not None:
        try:
            arrays = {f"ref_{k}": v for k, v in ref.arrays().items()}
            arrays |= {f"run_{k}": v for k, v in tr.arrays().items()}
            arrays["at_s"] = np.asarray(inj.at_s)
            write_bytes(ensure(args.out) / "run.npz", npz_bytes(arrays))
        except OutputError as exc:
            _err(str(exc))
            return EXIT_BAD_INPUT
        print(f"wrote {args.out / 'run.npz'}")
    return EXIT_OK
