"""The `hapgate` command: the project's entry point (installed into .venv/bin by `make`)."""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

from ..base import toolenv
from ..base.paths import ROOT
from ..base.report import table
from ..device import runner as device_runner
from ..flows import blocks, boards, flow, fusesoc, stage
from ..golden import configs
from ..runners.sim import MissingSimulator, simulators
from . import (
    bench,
    bringup,
    cosim,
    coverage,
    demo,
    device,
    flash,
    harm,
    mutants,
    replay_commutation,
    replay_interp,
    scene,
    seu,
    sweep,
)
from . import view as view_cmd

REPLAY = {"interp": replay_interp, "commutation": replay_commutation}


def cmd_versions(_: argparse.Namespace) -> int:
    print(table(["tool", "version", "path"], toolenv.versions()))
    return 0


def cmd_check_sims(_: argparse.Namespace) -> int:
    toolenv.apply()
    try:
        sims = simulators()
    except MissingSimulator as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"simulators: {', '.join(sims)}")
    return 0


def cmd_lint(args: argparse.Namespace) -> int:
    rows, failed = [], []
    t0 = time.perf_counter()
    jobs = []
    for name in args.block or list(blocks.BLOCKS):
        block = blocks.get(name)
        params = block.params()
        jobs += [(flow.lint_verilator, block, params), (flow.lint_icarus, block, params)]
        if name == "hapgate_top":   # the virtual device's builds: stage clocks, held axes
            for mask, gate in ((7, True), (5, True), (5, False)):
                sim = replace(block, sources=tuple(str(s) for s in device_runner.sim_sources(mask)))
                jobs.append((flow.lint_verilator, sim, params,
                             tuple(d[2:] for d in device_runner.sim_defines(mask, gate))))
        if not args.no_synth:
            targets = block.lint_synth + (block.synth_only if args.table else ())
            jobs += [(flow.synth, block, params, target) for target in targets]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:  # tools are processes
        findings = list(pool.map(lambda j: j[0](*j[1:]), jobs))
    for f in findings:
        rows.append([f.block, f.tool, "ok" if f.ok else "FAIL", f"{f.seconds:.2f}",
                     flow.resource_line(f) if f.resources else ""])
        if not f.ok:
            failed.append(f)
    print(table(["block", "check", "result", "seconds", "resources"], rows))
    for f in failed:
        print(f"\n--- {f.block}: {f.tool} ---\n{f.detail}", file=sys.stderr)
    print(f"lint: {len(rows) - len(failed)} ok, {len(failed)} failed "
          f"in {time.perf_counter() - t0:.1f} s")
    return 1 if failed else 0


def cmd_synth(args: argparse.Namespace) -> int:
    args.no_synth = False
    args.table = True      # every named configuration's synthesis too
    return cmd_lint(args)


def cmd_pnr(args: argparse.Namespace) -> int:
    if args.seeds < 1:
        print(f"error: --seeds must be >= 1, got {args.seeds}", file=sys.stderr)
        return 2
    if args.timeout <= 0:
        print(f"error: --timeout must be > 0, got {args.timeout:g}", file=sys.stderr)
        return 2
    for name in args.board:
        if name not in boards.BOARDS and name != stage.TARGET:
            print(f"error: unknown board {name!r}; known: {', '.join(boards.BOARDS)} "
                  f"(and {stage.TARGET}: the interpolator axis alone on a UP5K)",
                  file=sys.stderr)
            return 2
    rows, ok = [], True
    split: list[tuple[str, dict[str, int]]] = []
    if stage.TARGET in args.board:   # per-stage timing: a table, not a fit / timing verdict
        srows, path = stage.run_all(args.seeds)
        print(table(stage.HEADERS, srows))
        print(f"written {path}")
        ok = all(r[1] == args.seeds for r in srows)   # every seed placed and routed
        if args.board == [stage.TARGET]:
            return 0 if ok else 1
    for name in [b for b in args.board if b != stage.TARGET] or list(boards.BOARDS):
        try:
            b = boards.hardened(boards.BOARDS[name], args.harden)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        name = b.name
        f = boards.pnr(b, seeds=args.seeds, timeout_s=args.timeout)
        ok &= f.ok
        r = f.resources
        util = ", ".join(f"{k} {v}/{r[k + '/avail']} ({v / r[k + '/avail']:.0%})"
                         for k, v in r.items() if k + "/avail" in r and v)
        if b.soc and "cpu LUT4" in r:
            split.append((name, r))
        rows.append([name, b.doc, "ok" if f.ok else "FAIL",
                     f"{r.get('synth_s', 0)} + {r.get('pnr_s_per_seed', 0)}/seed",
                     f.detail.splitlines()[0] if f.detail else "", util])
        if not f.ok:
            print(f"--- {name} ---\n{f.detail}", file=sys.stderr)
    print(table(["board", "device", "result", "seconds (synth + pnr)", "fmax", "utilisation"],
                rows))
    if split:   # the SoC boards: Yosys's cells of each side, the hierarchy kept
        kinds = list(boards.SPLIT_CELLS.values())
        print(table(["board", "side", *kinds],
                    [[n, side, *(str(r.get(f"{side} {k}", 0)) for k in kinds)]
                     for n, r in split for side in ("cpu", "gateware")]))
    return 0 if ok else 1


def cmd_fusesoc(args: argparse.Namespace) -> int:
    return fusesoc.run(args.args)


def cmd_core(args: argparse.Namespace) -> int:
    return fusesoc.write_core(check=args.check)


CONFIGS_DOC = ROOT / "docs" / "configs.md"


def configs_doc_text() -> str:
    """docs/configs.md with its generated part (between the markers) made anew."""
    text = CONFIGS_DOC.read_text()
    a, b = text.index(configs.DOC_BEGIN), text.index(configs.DOC_END) + len(configs.DOC_END)
    return text[:a] + configs.markdown().rstrip("\n") + text[b:]


def cmd_configs(args: argparse.Namespace) -> int:
    try:
        reg = configs.load(Path(args.file)) if args.file else configs.registry()
    except configs.ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.write_docs or args.check_docs:
        text = configs_doc_text()
        if text == CONFIGS_DOC.read_text():
            print("docs/configs.md: current")
            return 0
        if args.check_docs:
            print("docs/configs.md: stale: run `hapgate configs --write-docs`", file=sys.stderr)
            return 1
        CONFIGS_DOC.write_text(text)
        print("written docs/configs.md")
        return 0
    base = configs.defaults()
    print(table(["configuration", "sets (the rest: defaults)", "what"],
                [[n, ", ".join(f"{k}={v}" for k, v in c.values().items() if v != base[k])
                  or "-", c.doc] for n, c in reg.items()]))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    return demo.main(args)


def cmd_bench(args: argparse.Namespace) -> int:
    return bench.main(args)


def cmd_replay(args: argparse.Namespace) -> int:
    return int(REPLAY[args.block].main(args))


def cmd_device(args: argparse.Namespace) -> int:
    return device.main(args)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="hapgate", description=__doc__)
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("versions", help="tool versions and paths").set_defaults(fn=cmd_versions)
    sub.add_parser("check-sims", help="which simulators the tests will use (CI: all or error)"
                   ).set_defaults(fn=cmd_check_sims)
    for name, fn, hlp in (("lint", cmd_lint, "verilator -Wall, Icarus elaboration, Yosys"),
                          ("synth", cmd_synth, "Yosys synthesis resource table")):
        sp = sub.add_parser(name, help=hlp)
        sp.add_argument("block", nargs="*", help="blocks (default: all)")
        sp.add_argument("--no-synth", action="store_true", help="skip the Yosys checks")
        sp.set_defaults(fn=fn, table=False)
    pp = sub.add_parser("pnr", help="synthesize and place-and-route the board tops (nextpnr); "
                        "up5k-interp: one interpolator axis alone on a UP5K, angle-stage variants")
    pp.add_argument("board", nargs="*", help="boards (default: all)")
    pp.add_argument("--seeds", type=int, default=1,
                    help="place and route with seeds 1..N, report the fmax spread")
    pp.add_argument("--harden", default="none", choices=("none", "all"),
                    help="with the integrity countermeasures (issue 38; the `hardened` "
                         "configuration's) on top of each board's configuration")
    pp.add_argument("--timeout", type=float, default=3600.0,
                    help="wall seconds per nextpnr run before the seed counts as failed "
                         "(router1 can livelock on a full HX8K)")
    pp.set_defaults(fn=cmd_pnr)
    fp = sub.add_parser("fusesoc", help="fusesoc with the pinned tools (hapgate.core)")
    fp.add_argument("args", nargs=argparse.REMAINDER, help="fusesoc arguments")
    fp.set_defaults(fn=cmd_fusesoc)
    cp = sub.add_parser("core", help="write hapgate.core from the named configurations, the "
                        "blocks and the boards (--check: exit 1 if the committed one differs)")
    cp.add_argument("--check", action="store_true", help="compare only")
    cp.set_defaults(fn=cmd_core)
    gp = sub.add_parser("configs", help="the named configurations (models/hapgate/configs.toml)"
                        ": check and list them; --write-docs: docs/configs.md's tables")
    gp.add_argument("--file", help="check this registry file instead")
    gp.add_argument("--write-docs", action="store_true", help="regenerate docs/configs.md")
    gp.add_argument("--check-docs", action="store_true",
                    help="exit 1 if docs/configs.md is not the generated one")
    gp.set_defaults(fn=cmd_configs)
    sub.add_parser("demo", help="the main job: run the design on RTL and models, compare"
                   ).set_defaults(fn=cmd_demo)
    rp = sub.add_parser("replay", help="run a capture CSV through the RTL or the model")
    rsub = rp.add_subparsers(dest="block", required=True)
    replay_interp.add_arguments(rsub.add_parser(
        "interp", help="encoder samples -> positions (CAPTURE.csv -> RESULT.csv)"))
    replay_commutation.add_arguments(rsub.add_parser(
        "commutation", help="positions and torques -> DAC codes and load times "
                            "(FRAMES.csv -> DAC.csv)"))
    rp.set_defaults(fn=cmd_replay)
    hp = sub.add_parser("harm", help="harmonic table of the ratio angle stage: fit --in "
                        "CAPTURE.csv --out TABLE.hex (learn it off-chip)")
    harm.add_arguments(hp)
    hp.set_defaults(fn=harm.main)
    mp = sub.add_parser("mutants", help="mutation testing: every mutant in tb/mutants/mutants.toml "
                        "must be killed by its tests (long; not in make test)")
    mutants.add_arguments(mp)
    mp.set_defaults(fn=mutants.main)

    cp = sub.add_parser("coverage", help="code coverage of the RTL from the block tests on "
                        "Verilator (build/reports/coverage/; long)")
    coverage.add_arguments(cp)
    cp.set_defaults(fn=coverage.main)

    scene.add_arguments(sub.add_parser(
        "scene", help="virtual-device scenes: run FILE [--out DIR] | check FILE..."))
    cosim.add_arguments(sub.add_parser(
        "cosim", help="firmware co-simulation scenes: run SCENE [--rate HZ] [--seed N] "
        "[--out DIR] | check FILE..."))
    up = sub.add_parser("bringup", help="bring-up over the PC link: PORT [--steps ...] [--out DIR] "
                        "[--apply] (docs/bringup.md)")
    bringup.add_arguments(up)
    up.set_defaults(fn=bringup.main)
    fl = sub.add_parser("flash", help="write a board's bitstream with openFPGALoader (BOARD "
                        "[--bitstream PATH] [--flash])")
    flash.add_arguments(fl)
    fl.set_defaults(fn=flash.main)
    dp = sub.add_parser("device", help="the virtual device")
    dsub = dp.add_subparsers(dest="device_cmd", required=True)
    device.add_arguments(dsub.add_parser(
        "serve", help="serve the virtual device's PC link on a pty (prints 'port: /dev/pts/N')"))
    dp.set_defaults(fn=cmd_device)

    vp = sub.add_parser("view", help="replay a finished scene run (RUN_DIR/run.npz) in the "
                        "browser with a time slider (prints 'view: URL')")
    view_cmd.add_arguments(vp)
    vp.set_defaults(fn=view_cmd.main)

    sweep.add_arguments(sub.add_parser(
        "sweep", help="run a sweep spec on Dask: SPEC [--scheduler tcp://H:P] [--workers N]"))
    seu.add_arguments(sub.add_parser(
        "seu", help="fault injection into the gateware's flip-flops: sites, one run"))
    bp = sub.add_parser("bench", help="benchmarks: run time beside error (build/reports/)")
    bench.add_arguments(bp)
    bp.set_defaults(fn=cmd_bench)
    args = p.parse_args(argv)
    return int(args.fn(args))


if __name__ == "__main__":
    sys.exit(main())
