"""`make bench`: run time beside error for every engine, as tables on stdout and CSV/PNG in
build/reports/. Speed is printed here, never asserted in a test."""

from __future__ import annotations

import argparse
import subprocess

from ..base import toolenv
from ..base.paths import ROOT
from ..base.report import table, write_csv
from ..runners import cosim
from . import bench_calib, bench_commutation, bench_host, bench_interp, bench_velobs


def main(args: argparse.Namespace) -> int:
    from . import demo

    toolenv.apply()
    ok = True
    headers = ["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"]
    rows, sine_ok = demo.sine_section()
    print("== sine ROM (1024 codes; error in DAC LSB) ==")
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_sine_rom.csv', headers, rows)}\n")
    ok &= sine_ok
    ok &= bench_interp.run(args.quick)
    print()
    ok &= bench_calib.run(args.quick)
    print()
    ok &= bench_velobs.run(args.quick)
    print()
    ok &= bench_commutation.run(args.quick)
    print()
    ok &= cosim.bench_section(args.quick)
    print()
    from . import bench_device
    ok &= bench_device.run(args.quick)
    print()
    ok &= bench_host.run(args.quick)
    print("\n== DSP firmware: servo step cost (make -C dsp-fw bench) ==", flush=True)
    ok &= subprocess.run(["make", "-s", "-C", str(ROOT / "dsp-fw"), "bench"]).returncode == 0
    print("bench:", "all engines agree with the models" if ok else "MISMATCH or failure above")
    return 0 if ok else 1
