"""`hapgate harm fit`: learn the harmonic correction table of the ratio angle stage (enc_interp
ANGLE = 1, HARM = 1) off-chip from a capture, and write the table file that `hapgate replay
interp --angle ratio --harm FILE` reads and the firmware loads (dsp-fw/include/hg_harm.h, or the
HARM_ADDR / HARM_DATA sequence of rtl/interp/README.md).

The capture (CAPTURE.csv, the replay's format: a, b, optional index and truth_counts) runs
through the bit-exact model with the correction off, so the positions fitted are the ones the
FPGA reports; `hapgate.golden.angle.harmonic_fit` needs no truth: the residual of a straight line
through (sample, position), averaged per bin of the line. The capture must be at a steady speed
over many lines (each of the 2^HARM_LOG2 bins visited; a few thousand samples suffice)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..base.atomic import OutputError, write_bytes
from ..base.capture import CaptureError, check_output, read_table
from ..base.report import table
from ..golden import angle, interp
from .replay_interp import CAPTURE, TRUTH_COUNTS_PER_LINE


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="harm_cmd", required=True)
    f = sub.add_parser("fit", help="learn a table from CAPTURE.csv (steady speed) -> TABLE.hex")
    f.add_argument("--in", dest="inp", required=True, type=Path,
                   help="CAPTURE.csv (hapgate replay interp's input format)")
    f.add_argument("--out", required=True, type=Path,
                   help="TABLE.hex: 2^HARM_LOG2 lines of two hex digits (signed 1/4 count)")
    f.add_argument("--c-out", type=Path, default=None,
                   help="also write the entries as a C array (for hg_harm_load)")
    f.add_argument("--calib", action="store_true",
                   help="the FPGA runs the online calibration (CAL = 1, enabled from the first "
                        "sample): fit its positions (use --skip for its convergence)")
    f.add_argument("--skip", type=int, default=0,
                   help="samples at the start left out of the fit (default 0)")
    f.add_argument("--harm-log2", type=int, default=angle.HARM_LOG2, choices=range(4, 9),
                   metavar="{4..8}", help="table entries per line, log2 (HARM_LOG2, default 6)")


def learn(a: np.ndarray, b: np.ndarray, cfg: interp.InterpConfig, skip: int = 0
          ) -> tuple[np.ndarray, np.ndarray]:
    """(table, positions with the correction off) for the samples a, b under cfg (ratio)."""
    off = interp.run(a, b, None, cfg, cal_en=cfg.cal)
    if skip >= a.size - 16:
        raise ValueError(f"--skip {skip} leaves {max(a.size - skip, 0)} samples to fit")
    return angle.harmonic_fit(off.pos[skip:].astype(np.int64), cfg.lut_bits, cfg.harm_log2), \
        off.pos


def _rms_deg(pos: np.ndarray, truth: np.ndarray, cfg: interp.InterpConfig) -> float:
    e = interp.truth_counts_error(pos, truth)
    return float(np.sqrt(np.mean((e - e.mean()) ** 2)) * 360 / cfg.counts_per_line)


def main(args: argparse.Namespace) -> int:
    cfg = interp.InterpConfig(ratio=True, harm=True, harm_log2=args.harm_log2, cal=args.calib)
    try:
        if args.skip < 0:
            raise CaptureError(f"--skip {args.skip}: must be >= 0")
        check_output(args.out, [args.inp])
        if args.c_out is not None:
            check_output(args.c_out, [args.inp])
        tab = read_table(args.inp, CAPTURE)
    except CaptureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if tab.ignored:
        print(f"note: {args.inp}: ignored column(s) {', '.join(tab.ignored)}", file=sys.stderr)
    a = tab.columns["a"].astype(np.int8)
    b = tab.columns["b"].astype(np.int8)
    t0 = time.perf_counter()
    try:
        harm, pos_off = learn(a, b, cfg, args.skip)
    except ValueError as exc:   # too short, or a bin never visited: not a steady run
        print(f"error: {args.inp}: {exc} (the fit needs a steady speed over many lines)",
              file=sys.stderr)
        return 2
    secs = time.perf_counter() - t0
    note = (f"hapgate harm fit --in {args.inp.name}: {a.size - args.skip} samples, "
            f"HARM_LOG2 {cfg.harm_log2}, {'calibrated, ' if cfg.cal else ''}"
            f"signed 1/4 count per entry")
    try:
        write_bytes(args.out, angle.harm_table_text(harm, note))
        if args.c_out is not None:
            body = ", ".join(str(int(v)) for v in harm)
            write_bytes(args.c_out, f"/* {note} */\nstatic const int8_t hg_harm_table"
                                    f"[{harm.size}] = {{ {body} }};\n")
    except OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rows = [["entries", harm.size], ["range [1/4 count]", f"{harm.min()} .. {harm.max()}"],
            ["fit seconds", f"{secs:.3f}"]]
    if "truth_counts" in tab.columns:
        truth = tab.columns["truth_counts"] * (cfg.counts_per_line / TRUTH_COUNTS_PER_LINE)
        on = interp.run(a, b, None, cfg, cal_en=cfg.cal, harm_table=harm, harm_en=True)
        sl = slice(args.skip, None)
        rows += [["rms off [el deg]", f"{_rms_deg(pos_off[sl], truth[sl], cfg):.4f}"],
                 ["rms on, same capture [el deg]", f"{_rms_deg(on.pos[sl], truth[sl], cfg):.4f}"]]
    print(table(["harmonic table", "value"], rows))
    print(f"wrote {args.out}" + (f" and {args.c_out}" if args.c_out else ""))
    return 0
