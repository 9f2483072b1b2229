"""`hapgate sweep SPEC [--scheduler tcp://HOST:PORT] [--workers N] [--out DIR] [--no-cache]`.

Expands the sweep spec (scenes/sweeps/README.md) into jobs, runs them on Dask (a LocalCluster of
N worker processes, or the scheduler named), prints the kind's table, writes results.csv,
results.npz, summary.json and plots into DIR (default build/sweeps/<name>/). Exit 0 when every
job ran (and, for the soak, every check held), 1 when a check failed, 2 for a malformed spec or
unusable --out (nothing written), 3 when the sweep itself could not run.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

from ..base.atomic import OutputError, write_bytes
from ..base.paths import BUILD
from ..base.report import csv_text, table
from ..device import sweep, zwidth
from . import sweep_report

EXIT_OK, EXIT_FAIL, EXIT_BAD_INPUT, EXIT_NO_RUN = 0, 1, 2, 3


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("spec", type=Path, help="sweep spec (TOML; scenes/sweeps/README.md)")
    p.add_argument("--scheduler", default=None,
                   help="tcp://HOST:PORT of a running `dask scheduler` (default: a local cluster)")
    p.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    p.add_argument("--out", type=Path, default=None, help="output folder "
                   "(default build/sweeps/<name>/)")
    p.add_argument("--no-cache", action="store_true", help="rerun every job (cache unused)")
    p.add_argument("--limit", type=int, default=0, help="run only the first N jobs (a trial)")
    p.add_argument("--compare", type=Path, nargs="*", default=[],
                   help="Z-width: output folders of other Z-width sweeps (their results.csv) "
                        "to put on the same plot and table")
    p.set_defaults(fn=main)


def read_rows(path: Path) -> list[dict[str, object]]:
    """A results.csv back as records (numbers as float, True/False as bool)."""
    def conv(v: str) -> object:
        if v in ("True", "False"):
            return v == "True"
        try:
            return float(v)
        except ValueError:
            return v
    with open(path, newline="") as fh:
        return [{k: conv(v) for k, v in r.items()} for r in csv.DictReader(fh)]


def _err(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)


def main(args: argparse.Namespace) -> int:
    try:
        spec = sweep.load(args.spec)
    except sweep.SweepError as exc:
        _err(str(exc))
        return EXIT_BAD_INPUT
    for d in args.compare:
        if not (d / "results.csv").is_file():
            _err(f"--compare {d}: no results.csv there")
            return EXIT_BAD_INPUT
    if args.workers < 1:
        _err("--workers: at least 1")
        return EXIT_BAD_INPUT
    out = args.out if args.out is not None else BUILD / "sweeps" / spec.name
    if out.exists() and not out.is_dir():
        _err(f"--out {out}: exists and is not a folder")
        return EXIT_BAD_INPUT
    jobs = spec.jobs()
    if args.limit > 0:
        jobs = jobs[:args.limit]
    print(f"sweep {spec.name}: {len(jobs)} {spec.kind} jobs on "
          f"{args.scheduler or f'a local cluster of {args.workers} workers'}")
    try:
        res = sweep.run(spec, workers=args.workers, scheduler=args.scheduler,
                        cache=None if args.no_cache else sweep.CACHE, jobs=jobs)
    except Exception as exc:                         # noqa: BLE001 - reported, exit 3
        _err(f"the sweep could not run: {type(exc).__name__}: {exc}")
        return EXIT_NO_RUN
    try:
        return _report(args, spec, res, out)
    except OutputError as exc:                      # an unusable output: nothing half-written
        _err(str(exc))
        return EXIT_BAD_INPUT


def _latency_k(t: dict[str, float]) -> float:
    """A K_max row's latency bound (b - |B|)/(T/2 + tau), with its own loop latency."""
    return zwidth.latency_bound(t["b_phys"], t["b_wall"], 1 / t["servo_hz"], t["tau_s"])


def _report(args: argparse.Namespace, spec: sweep.Spec, res: sweep.SweepResult, out: Path
            ) -> int:
    """Write the results (base.atomic) and print the kind's tables; the exit status."""
    files = sweep.write(res, out)
    status = EXIT_OK
    rows = res.rows()
    if spec.kind == "zwidth":
        for d in args.compare:
            rows = rows + read_rows(d / "results.csv")
        hits = [r for r in rows if "rate_hardness" in r]     # test = "impact"
        rows = [r for r in rows if "rate_hardness" not in r]
        if hits:
            print(table(["servo Hz", "K N/m", "B N s/m", "v contact m/s", "rate-hardness N/m",
                         "/ K", "static F/x N/m", "/ K"], sweep_report.impact_table(hits)))
        if not rows:
            print(f"{len(res.records)} jobs in {res.wall_s:.1f} s on {res.workers} workers")
            print("wrote " + ", ".join(str(f) for f in files))
            return status
        tab = sweep_report.kmax_table(rows)
        print(table(["position", "servo Hz", "B N s/m", "K_max N/m", "first unstable K",
                     "2(b-|B|)/T", "(b-|B|)/(T/2+tau)", "35 N/cm stable"],
                    [[t["position"], str(t["servo_hz"]), f"{t['b_wall']:g}",
                      f"{t['k_max']:.0f}", f"{t['k_first_unstable']:.0f}",
                      f"{max(2 * (t['b_phys'] - t['b_wall']) * t['servo_hz'], 0):.0f}",
                      f"{_latency_k(t):.0f}",
                      "yes" if t["k_max"] >= 3500 else "no"] for t in tab]))
        write_bytes(out / "kmax.json", json.dumps(tab, indent=2, default=str))
        sweep_report.zwidth_plot(rows, out / "zwidth.png")
        files += [out / "kmax.json", out / "zwidth.png"]
    elif spec.kind == "soak":
        print(table(["soak", "value"], sweep_report.soak_table(rows, res.wall_s, res.workers)))
        bad = sum(int(r[k]) for r in rows for k in ("slips", "false_overspeed",
                                                      "missed_overspeed"))
        status = EXIT_FAIL if bad else EXIT_OK
    elif spec.kind == "calib_mc":
        tabs = sweep_report.calib_tables(rows)
        for head, body in tabs.values():
            print(table(head, body))
        write_bytes(out / "percentiles.csv",
                    "".join(csv_text(head, body) for head, body in tabs.values()))
        sweep_report.calib_plot(rows, out / "histogram.png")
        files += [out / "percentiles.csv", out / "histogram.png"]
    elif spec.kind == "seu":
        files += _seu_report(spec, rows, res, out, list(args.compare))
    print(f"{len(res.records)} jobs ({sum(res.cached)} from the cache, {res.retried} rerun after a "
          f"lost worker or a retry) in {res.wall_s:.1f} s on {res.workers} workers "
          f"({res.scheduler}); "
          f"{len(res.records) / res.wall_s if 0 < res.wall_s < math.inf else 0:.2f} jobs/s")
    print("wrote " + ", ".join(str(f) for f in files))
    return status



def _seu_report(spec: sweep.Spec, rows: list[dict[str, object]], res: sweep.SweepResult,
                out: Path, compare: list[Path] = ()) -> list[Path]:  # type: ignore[assignment]
    """The injection campaign's tables (per block, per register, the worst sites) and CSVs."""
    from ..device import seu
    _sc, design, _clk = seu.setup(spec.base or seu.SCENE)
    tabs = sweep_report.seu_tables(rows, design.bits_per_block())
    for key, title in (("blocks", "per block"), ("registers", "per register (most dangerous)"),
                       ("worst", "worst sites (replay with the command)")):
        print(f"\n{title}:")
        print(table(*tabs[key]))
    cpu = sum(float(r.get("harness_cpu_s") or 0.0) for r in rows if not r.get("cached"))
    ran = sum(1 for c in res.cached if not c)
    print(f"\nbudgets: torque within {seu.BUDGET_DEV_NM} N m of the reference (two frames or "
          f"more outside: a violation), steps within {seu.BUDGET_STEP_NM} N m per frame; "
          f"zero torque within {seu.REACT_S * 1e6:.0f} us of the latch")
    if ran:
        print(f"harness CPU {cpu / ran:.3f} s per run ({ran} runs)")
    files = []
    for key in ("blocks", "registers_all", "worst"):
        f = out / f"seu_{key}.csv"
        write_bytes(f, csv_text(*tabs[key]))
        files.append(f)
    campaigns = {spec.name: rows}
    for d in compare:   # other campaigns beside this one (e.g. the unhardened paper's)
        other = read_rows(d / "results.csv")
        campaigns[json.loads((d / "summary.json").read_text()).get("name", d.name)
                  if (d / "summary.json").is_file() else d.name] = other
        print(f"\n{d.name}: per block")
        print(table(*sweep_report.seu_tables(other, design.bits_per_block())["blocks"]))
    sweep_report.seu_plot(campaigns, out / "seu.png")
    return [*files, out / "seu.png"]
