"""`hapgate replay interp`: run a lab capture (or any CSV of ADC samples) through the gateware
(native Verilator harness) or the bit-exact model, write the per-sample results, compare the two,
and measure the error against a truth column when the capture has one."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..base.capture import CaptureError, Column, check_output, read_table, write_csv
from ..base.report import table
from ..golden import angle, interp
from ..runners import native

OUT_COLUMNS = ("pos", "vel", "fault", "pos_homed", "index_pos", "index_count", "homed",
               "overspeed_count")
# CAPTURE.csv columns (hapgate.base.capture's rules). truth_counts is in the capture's own unit,
# 1024 counts per line (2**20 per revolution of a 1024-line encoder) whatever --lut-bits: the
# replay rescales it to the run's resolution (8 * 2**lut_bits counts per line).
TRUTH_COUNTS_PER_LINE = 1024
CAPTURE = (Column("a", lo=-128, hi=127), Column("b", lo=-128, hi=127),
           Column("index", lo=0, hi=1, required=False),
           Column("truth_counts", kind="float", required=False))
MAX_CLK_HZ = 2_147_000_000   # a 32-bit Verilog integer parameter


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--in", dest="inp", required=True, type=Path,
                   help="CAPTURE.csv: header; a,b (signed ADC codes); optional index (0/1), "
                        "truth_counts (float, 1024 counts per line at any --lut-bits); other "
                        "columns ignored (and named)")
    p.add_argument("--out", required=True, type=Path,
                   help="RESULT.csv (row k = sample k); its folder must exist")
    p.add_argument("--engine", choices=("rtl", "model"), default="rtl",
                   help="rtl: the native Verilator harness; model: the golden model")
    p.add_argument("--compare", action="store_true",
                   help="run both engines and report the first mismatch (exit 1 if any)")
    p.add_argument("--lut-bits", type=int, default=7, choices=range(5, 10), metavar="{5..9}",
                   help="arcsine LUT codes per 45 deg = 2**N (default 7)")
    p.add_argument("--clk-hz", type=int, default=interp.MIN_CLK_HZ,
                   help="FPGA clock for --engine rtl: a multiple of the 1 MHz sample rate "
                        "(default: one clock per sample; results are identical at any clock)")
    p.add_argument("--calib", action="store_true",
                   help="online encoder calibration on (enc_interp CAL = 1, enabled from the "
                        "first sample; output format unchanged; the error includes its "
                        "convergence, ~200 lines)")
    p.add_argument("--angle", choices=("asin", "ratio"), default="asin",
                   help="angle stage: the paper's arcsine (default) or the ratio table "
                        "atan(smaller / larger) (enc_interp ANGLE = 1; rtl/interp/README.md)")
    p.add_argument("--harm", metavar="FILE|learn", default=None,
                   help="with --angle ratio: the harmonic correction table (HARM = 1) on from "
                        "the first sample, loaded from FILE (hapgate harm fit's output) or "
                        "learned from this capture first ('learn': fitted with the correction "
                        "off, then applied to the same samples)")
    p.add_argument("--harm-log2", type=int, default=6, choices=range(4, 9), metavar="{4..8}",
                   help="with --harm: table entries per line, log2 (HARM_LOG2, default 6)")
    p.add_argument("--no-align", action="store_true",
                   help="do not remove the mean offset between position and truth_counts")


def _engine(name: str, cap: dict[str, np.ndarray], cfg: interp.InterpConfig, clk_hz: int,
            harm: np.ndarray | None = None) -> tuple[dict[str, np.ndarray], float]:
    a, b, idx = cap["a"], cap["b"], cap.get("index")
    on = harm is not None
    t0 = time.perf_counter()
    if name == "model":
        out = native.model_matrix(interp.run(a, b, idx, cfg, cal_en=cfg.cal, harm_table=harm,
                                             harm_en=on))
    else:
        run = native.run_interp(a, b, idx, cfg, clk_hz=clk_hz, cal_en=cfg.cal, harm_table=harm,
                                harm_en=on)
        bad = int(run.stats.get("harm_readback_bad", "0"))
        if bad:
            raise RuntimeError(f"the RTL read back {bad} harmonic table entries wrong")
        out = run.axis(0)
    return out, time.perf_counter() - t0


def clock_error(clk_hz: int) -> str | None:
    """Why the interpolator RTL would refuse this clock (rtl/interp/sample_strobe.v), or None."""
    if clk_hz < interp.MIN_CLK_HZ or clk_hz % interp.MIN_CLK_HZ or clk_hz > MAX_CLK_HZ:
        return (f"--clk-hz {clk_hz}: the FPGA clock must be a multiple of the 1 MHz sample rate "
                f"(1000000, 2000000, ... 48000000, ...) up to {MAX_CLK_HZ}")
    return None


def main(args: argparse.Namespace) -> int:
    ratio = args.angle == "ratio"
    if args.calib and args.lut_bits > 8 and not ratio:
        print("error: --calib with the arcsine needs --lut-bits <= 8 (or --angle ratio)",
              file=sys.stderr)
        return 2
    if args.harm is not None and not ratio:
        print("error: --harm needs --angle ratio (the harmonic table corrects the ratio stage)",
              file=sys.stderr)
        return 2
    cfg = interp.InterpConfig(lut_bits=args.lut_bits, cal=args.calib, ratio=ratio,
                              harm=args.harm is not None, harm_log2=args.harm_log2)
    why = clock_error(args.clk_hz)
    harm: np.ndarray | None = None
    try:
        if why:
            raise CaptureError(why)
        check_output(args.out, [args.inp] + ([Path(args.harm)] if args.harm not in (None, "learn")
                                             else []))
        if args.harm not in (None, "learn"):
            harm = angle.read_harm_table(Path(args.harm), args.harm_log2)
        tab = read_table(args.inp, CAPTURE)
    except CaptureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if tab.ignored:
        print(f"note: {args.inp}: ignored column(s) {', '.join(tab.ignored)}", file=sys.stderr)
    raw = tab.columns
    cap = {"a": raw["a"].astype(np.int8), "b": raw["b"].astype(np.int8)}
    if "index" in raw:
        cap["index"] = raw["index"].astype(bool)
    n = cap["a"].size
    if args.harm == "learn":
        try:
            harm = angle.harmonic_fit(interp.run(cap["a"], cap["b"], None, cfg, cal_en=cfg.cal)
                                      .pos.astype(np.int64), cfg.lut_bits, cfg.harm_log2)
        except ValueError as exc:
            print(f"error: {args.inp}: {exc} (--harm learn needs a steady speed over many "
                  "lines)", file=sys.stderr)
            return 2
        print(f"harmonic table learned from {args.inp}: {harm.size} entries, "
              f"{harm.min()} .. {harm.max()} quarter counts")
    engines = ("rtl", "model") if args.compare else (args.engine,)
    results = {e: _engine(e, cap, cfg, args.clk_hz, harm) for e in engines}
    out, _ = results[args.engine]
    cols = {"pos": out["pos"], "vel": out["vel"], "fault": out["faults"],
            "pos_homed": out["pos_homed"], "index_pos": out["index_pos"],
            "index_count": out["index_count"], "homed": out["homed"],
            "overspeed_count": out["overspeed_count"]}
    try:
        write_csv(args.out, cols)
    except CaptureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2

    rows = []
    for e, (o, secs) in results.items():
        row: list[object] = [e, n, f"{secs:.3f}", f"{n / secs:.3e}"]
        if "truth_counts" in raw:
            truth = raw["truth_counts"] * (cfg.counts_per_line / TRUTH_COUNTS_PER_LINE)
            err = interp.truth_counts_error(o["pos"], truth)
            offset = 0.0 if args.no_align else float(err.mean())
            err = err - offset
            rms, mx = float(np.sqrt(np.mean(err**2))), float(np.abs(err).max())
            row += [f"{offset:.3f}", f"{rms:.4f}", f"{mx:.4f}",
                    f"{rms * 360 / cfg.counts_per_line:.4f}",
                    f"{mx * 360 / cfg.counts_per_line:.4f}",
                    f"{rms * 360 / cfg.counts_per_rev:.3e}", f"{mx * 360 / cfg.counts_per_rev:.3e}"]
        rows.append(row)
    headers = ["engine", "samples", "seconds", "samples/s"]
    if "truth_counts" in raw:
        headers += [f"offset [1/{cfg.counts_per_line} line]", f"rms [1/{cfg.counts_per_line} line]",
                    f"max [1/{cfg.counts_per_line} line]", "rms [el deg]",
                    "max [el deg]", "rms [mech deg]", "max [mech deg]"]
    print(table(headers, rows))
    faults = int(np.count_nonzero(out["faults"]))
    print(f"wrote {args.out} ({n} rows, lut_bits={cfg.lut_bits}); samples with a fault: {faults}")
    if args.compare:
        bad = native.first_mismatch(results["rtl"][0], results["model"][0])
        if bad is not None:
            k, col, r, m = bad
            print(f"MISMATCH: first at sample {k} (line {int(tab.lines[k])}), column {col}: "
                  f"rtl {r}, model {m}")
            return 1
        print("rtl and model agree on every sample and column")
    return 0
