"""`hapgate replay interp`: run a lab capture (or any CSV of ADC samples) through the gateware
(native Verilator harness) or the bit-exact model, write the per-sample results, compare the two,
and measure the error against a truth column when the capture has one."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base.capture import (
    CaptureError,
    CaptureTable,
    Column,
    CsvWriter,
    check_output,
    given_path,
    iter_table,
    line_progress,
    rechunk,
)
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
CHUNK_ROWS = 1 << 18


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--in", dest="inp", required=True,
                   help="CAPTURE.csv: header; a,b (signed ADC codes); optional index (0/1), "
                        "truth_counts (float, 1024 counts per line at any --lut-bits); other "
                        "columns ignored (and named)")
    p.add_argument("--out", required=True,
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
    p.add_argument("--chunk-rows", type=int, default=CHUNK_ROWS,
                   help=f"samples per chunk (memory is bounded by a chunk; the output does not "
                        f"depend on it; default {CHUNK_ROWS})")
    p.add_argument("--no-align", action="store_true",
                   help="do not remove the mean offset between position and truth_counts")


def clock_error(clk_hz: int) -> str | None:
    """Why the interpolator RTL would refuse this clock (rtl/interp/sample_strobe.v), or None."""
    if clk_hz < interp.MIN_CLK_HZ or clk_hz % interp.MIN_CLK_HZ or clk_hz > MAX_CLK_HZ:
        return (f"--clk-hz {clk_hz}: the FPGA clock must be a multiple of the 1 MHz sample rate "
                f"(1000000, 2000000, ... 48000000, ...) up to {MAX_CLK_HZ}")
    return None


class _Errors:
    """Running error statistics against the truth (mean, then the spread about it), merged chunk
    by chunk (Chan et al.'s pairwise update): the whole file's figures without keeping it."""

    def __init__(self) -> None:
        self.n, self.mean, self.m2, self.lo, self.hi = 0, 0.0, 0.0, np.inf, -np.inf

    def add(self, err: np.ndarray) -> None:
        if err.size == 0:
            return
        m = float(err.mean())
        m2 = float(((err - m) ** 2).sum())
        n = self.n + err.size
        d = m - self.mean
        self.m2 += m2 + d * d * self.n * err.size / n
        self.mean += d * err.size / n
        self.n = n
        self.lo, self.hi = min(self.lo, float(err.min())), max(self.hi, float(err.max()))

    def figures(self, align: bool) -> tuple[float, float, float]:
        """(offset, rms, max |err - offset|)."""
        off = self.mean if align else 0.0
        rms = float(np.sqrt(self.m2 / self.n + (self.mean - off) ** 2))
        return off, rms, max(self.hi - off, off - self.lo)


def _chunks(args: argparse.Namespace) -> Iterator[tuple[dict[str, np.ndarray], CaptureTable]]:
    for tab in rechunk(iter_table(args.inp, CAPTURE), args.chunk_rows):
        raw = tab.columns
        cap = {"a": raw["a"].astype(np.int8), "b": raw["b"].astype(np.int8)}
        if "index" in raw:
            cap["index"] = raw["index"].astype(bool)
        if "truth_counts" in raw:
            cap["truth_counts"] = raw["truth_counts"]
        yield cap, tab


def _learn(args: argparse.Namespace, cfg: interp.InterpConfig) -> np.ndarray:
    """--harm learn: the model with the correction off over the capture, chunk by chunk; the
    fit needs every position at once (4 bytes a sample: the one part not bounded by a chunk)."""
    st = interp.InterpState()
    pos = []
    for cap, _ in _chunks(args):
        o, st = interp.run_chunk(cap["a"], cap["b"], None, cfg, st, cal_en=cfg.cal)
        pos.append(o.pos)
    return angle.harmonic_fit(np.concatenate(pos).astype(np.int64), cfg.lut_bits, cfg.harm_log2)


def _take(pending: list[dict[str, np.ndarray]], k: int) -> dict[str, np.ndarray]:
    """The first k rows of a list of column chunks (removed from it)."""
    whole = {c: np.concatenate([p[c] for p in pending]) for c in pending[0]}
    pending.clear()
    if whole[next(iter(whole))].size > k:
        pending.append({c: v[k:] for c, v in whole.items()})
    return {c: v[:k] for c, v in whole.items()}


def _rows(pending: list[dict[str, np.ndarray]]) -> int:
    return sum(p["pos"].size for p in pending)


@dataclass
class Replayed:
    n: int = 0                                        # samples
    faults: int = 0                                   # samples with a fault (--engine's)
    secs: dict[str, float] = field(default_factory=dict)       # per engine
    errs: dict[str, _Errors] = field(default_factory=dict)     # per engine
    mismatch: tuple[int, str, int, int, int] | None = None     # sample, column, rtl, model, line
    ignored: list[str] = field(default_factory=list)


def replay(args: argparse.Namespace, cfg: interp.InterpConfig, harm: np.ndarray | None
           ) -> Replayed:
    """The capture through the engine(s) chunk by chunk into RESULT.csv. The model carries its
    state between chunks (interp.run_chunk), the RTL runs as one harness process fed through a
    pipe; the two are lined up row by row, so memory is bounded by the chunks whatever the
    file's size."""
    on = harm is not None
    engines = ("rtl", "model") if args.compare else (args.engine,)
    res = Replayed(secs=dict.fromkeys(engines, 0.0), errs={e: _Errors() for e in engines})
    pend: dict[str, list[dict[str, np.ndarray]]] = {e: [] for e in ("truth", "line", *engines)}
    scale = cfg.counts_per_line / TRUTH_COUNTS_PER_LINE
    rtl = native.InterpStream(cfg, args.clk_hz, cal_en=cfg.cal, harm_table=harm,
                              harm_en=on) if "rtl" in engines else None
    st = interp.InterpState()
    progress = line_progress(args.inp, "replay interp")

    def flush(w: CsvWriter) -> None:
        k = min(_rows(pend[e]) for e in engines)
        if k == 0:
            return
        got = {e: _take(pend[e], k) for e in engines}
        line = _take(pend["line"], k)["pos"]
        truth = _take(pend["truth"], k)["pos"] if pend["truth"] else None
        if args.compare and res.mismatch is None:
            bad = native.first_mismatch(got["rtl"], got["model"])
            if bad is not None:
                res.mismatch = (bad[0] + res.n, bad[1], bad[2], bad[3], int(line[bad[0]]))
        if truth is not None:
            for e in engines:
                res.errs[e].add(interp.truth_counts_error(got[e]["pos"], truth * scale))
        o = got[args.engine]
        w.add({"pos": o["pos"], "vel": o["vel"], "fault": o["faults"],
               "pos_homed": o["pos_homed"], "index_pos": o["index_pos"],
               "index_count": o["index_count"], "homed": o["homed"],
               "overspeed_count": o["overspeed_count"]})
        res.n += k
        res.faults += int(np.count_nonzero(o["faults"]))
        progress(int(line[-1]))

    try:
        with CsvWriter(args.out, OUT_COLUMNS) as w:
            for cap, tab in _chunks(args):
                res.ignored = tab.ignored
                pend["line"].append({"pos": tab.lines})
                if "truth_counts" in cap:
                    pend["truth"].append({"pos": cap["truth_counts"]})
                if rtl is not None:
                    rtl.feed(cap["a"], cap["b"], cap.get("index"))
                if "model" in engines:
                    t0 = time.perf_counter()
                    o, st = interp.run_chunk(cap["a"], cap["b"], cap.get("index"), cfg, st,
                                             cal_en=cfg.cal, harm_table=harm, harm_en=on)
                    res.secs["model"] += time.perf_counter() - t0
                    pend["model"].append(native.model_matrix(o))
                if rtl is not None:
                    pend["rtl"].append(rtl.take())
                flush(w)
            if rtl is not None:
                pend["rtl"].append(rtl.finish())
                bad = int(rtl.stats.get("harm_readback_bad", "0"))
                if bad:
                    raise RuntimeError(f"the RTL read back {bad} harmonic table entries wrong")
                res.secs["rtl"] = float(rtl.stats["seconds"])
            flush(w)
            if any(_rows(pend[e]) for e in engines):
                raise RuntimeError("the engines returned different numbers of rows")
    finally:
        if rtl is not None:
            rtl.close()
        progress.close()
    return res


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
        args.inp, args.out = given_path("--in", args.inp), given_path("--out", args.out)
        if args.harm is not None:
            given_path("--harm", args.harm)
        if why:
            raise CaptureError(why)
        if args.chunk_rows < 1:
            raise CaptureError(f"--chunk-rows {args.chunk_rows}: must be >= 1")
        check_output(args.out, [args.inp] + ([Path(args.harm)] if args.harm not in (None, "learn")
                                             else []))
        if args.harm not in (None, "learn"):
            harm = angle.read_harm_table(Path(args.harm), args.harm_log2)
        if args.harm == "learn":
            try:
                harm = _learn(args, cfg)
            except ValueError as exc:
                if isinstance(exc, CaptureError):
                    raise
                print(f"error: {args.inp}: {exc} (--harm learn needs a steady speed over many "
                      "lines)", file=sys.stderr)
                return 2
            print(f"harmonic table learned from {args.inp}: {harm.size} entries, "
                  f"{harm.min()} .. {harm.max()} quarter counts")
        res = replay(args, cfg, harm)
    except CaptureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if res.ignored:
        print(f"note: {args.inp}: ignored column(s) {', '.join(res.ignored)}", file=sys.stderr)

    n, errs = res.n, res.errs
    truth = errs[args.engine].n > 0
    rows = []
    for e, t in res.secs.items():
        row: list[object] = [e, n, f"{t:.3f}", f"{n / max(t, 1e-9):.3e}"]
        if truth:
            offset, rms, mx = errs[e].figures(not args.no_align)
            row += [f"{offset:.3f}", f"{rms:.4f}", f"{mx:.4f}",
                    f"{rms * 360 / cfg.counts_per_line:.4f}",
                    f"{mx * 360 / cfg.counts_per_line:.4f}",
                    f"{rms * 360 / cfg.counts_per_rev:.3e}", f"{mx * 360 / cfg.counts_per_rev:.3e}"]
        rows.append(row)
    headers = ["engine", "samples", "seconds", "samples/s"]
    if truth:
        headers += [f"offset [1/{cfg.counts_per_line} line]", f"rms [1/{cfg.counts_per_line} line]",
                    f"max [1/{cfg.counts_per_line} line]", "rms [el deg]",
                    "max [el deg]", "rms [mech deg]", "max [mech deg]"]
    print(table(headers, rows))
    print(f"wrote {args.out} ({n} rows, lut_bits={cfg.lut_bits}); samples with a fault: "
          f"{res.faults}")
    if args.compare:
        if res.mismatch is not None:
            k, col, r, m, line = res.mismatch
            print(f"MISMATCH: first at sample {k} (line {line}), column {col}: "
                  f"rtl {r}, model {m}")
            return 1
        print("rtl and model agree on every sample and column")
    return 0
