"""`make bench`: run time beside error for every engine, as tables on stdout and CSV/PNG in
build/reports/. Speed is printed here, never asserted in a test."""

from __future__ import annotations

import argparse

from . import toolenv
from .report import table, write_csv


def main(args: argparse.Namespace) -> int:
    from . import demo

    toolenv.apply()
    headers = ["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"]
    rows, ok = demo.sine_section()
    print("== sine ROM (1024 codes; error in DAC LSB) ==")
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_sine_rom.csv', headers, rows)}")
    return 0 if ok else 1
