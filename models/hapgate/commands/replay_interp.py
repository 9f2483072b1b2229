"""`hapgate replay interp`: run a lab capture (or any CSV of ADC samples) through the gateware
(native Verilator harness) or the bit-exact model, write the per-sample results, compare the two,
and measure the error against a truth column when the capture has one."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from ..base.capture import CaptureError, as_int, read_csv_columns, write_csv
from ..base.report import table
from ..golden import interp
from ..runners import native

OUT_COLUMNS = ("pos", "vel", "fault", "pos_homed", "index_pos", "index_count", "homed",
               "overspeed_count")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--in", dest="inp", required=True, type=Path,
                   help="CAPTURE.csv: header; a,b (signed ADC codes); optional index (0/1), "
                        "truth_counts (float); other columns ignored")
    p.add_argument("--out", required=True, type=Path, help="RESULT.csv (row k = sample k)")
    p.add_argument("--engine", choices=("rtl", "model"), default="rtl",
                   help="rtl: the native Verilator harness; model: the golden model")
    p.add_argument("--compare", action="store_true",
                   help="run both engines and report the first mismatch (exit 1 if any)")
    p.add_argument("--lut-bits", type=int, default=7, choices=range(5, 10), metavar="{5..9}",
                   help="arcsine LUT codes per 45 deg = 2**N (default 7)")
    p.add_argument("--clk-hz", type=int, default=interp.MIN_CLK_HZ,
                   help="FPGA clock for --engine rtl (default: one clock per sample; results "
                        "are identical at any clock)")
    p.add_argument("--calib", action="store_true",
                   help="online encoder calibration on (enc_interp CAL = 1, enabled from the "
                        "first sample; output format unchanged; the error includes its "
                        "convergence, ~200 lines)")
    p.add_argument("--no-align", action="store_true",
                   help="do not remove the mean offset between position and truth_counts")


def _engine(name: str, cap: dict[str, np.ndarray], cfg: interp.InterpConfig, clk_hz: int
            ) -> tuple[dict[str, np.ndarray], float]:
    a, b, idx = cap["a"], cap["b"], cap.get("index")
    t0 = time.perf_counter()
    if name == "model":
        out = native.model_matrix(interp.run(a, b, idx, cfg, cal_en=cfg.cal))
    else:
        out = native.run_interp(a, b, idx, cfg, clk_hz=clk_hz, cal_en=cfg.cal).axis(0)
    return out, time.perf_counter() - t0


def main(args: argparse.Namespace) -> int:
    if args.calib and args.lut_bits > 8:
        print("error: --calib needs --lut-bits <= 8", file=sys.stderr)
        return 2
    cfg = interp.InterpConfig(lut_bits=args.lut_bits, cal=args.calib)
    try:
        raw = read_csv_columns(args.inp, ["a", "b"], ["index", "truth_counts"])
        cap = {"a": as_int(args.inp, "a", raw["a"], -128, 127).astype(np.int8),
               "b": as_int(args.inp, "b", raw["b"], -128, 127).astype(np.int8)}
        if "index" in raw:
            cap["index"] = as_int(args.inp, "index", raw["index"], 0, 1).astype(bool)
    except CaptureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    n = cap["a"].size
    engines = ("rtl", "model") if args.compare else (args.engine,)
    results = {e: _engine(e, cap, cfg, args.clk_hz) for e in engines}
    out, _ = results[args.engine]
    cols = {"pos": out["pos"], "vel": out["vel"], "fault": out["faults"],
            "pos_homed": out["pos_homed"], "index_pos": out["index_pos"],
            "index_count": out["index_count"], "homed": out["homed"],
            "overspeed_count": out["overspeed_count"]}
    write_csv(args.out, cols)

    rows = []
    for e, (o, secs) in results.items():
        row: list[object] = [e, n, f"{secs:.3f}", f"{n / secs:.3e}"]
        if "truth_counts" in raw:
            err = interp.truth_counts_error(o["pos"], raw["truth_counts"])
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
        headers += ["offset [counts]", "rms [counts]", "max [counts]", "rms [el deg]",
                    "max [el deg]", "rms [mech deg]", "max [mech deg]"]
    print(table(headers, rows))
    faults = int(np.count_nonzero(out["faults"]))
    print(f"wrote {args.out} ({n} rows, lut_bits={cfg.lut_bits}); samples with a fault: {faults}")
    if args.compare:
        bad = native.first_mismatch(results["rtl"][0], results["model"][0])
        if bad is not None:
            k, col, r, m = bad
            print(f"MISMATCH: first at sample {k} (line {k + 2}), column {col}: rtl {r}, "
                  f"model {m}")
            return 1
        print("rtl and model agree on every sample and column")
    return 0
