"""`hapgate replay commutation --in FRAMES.csv --out DAC.csv [--engine rtl|model]`.

FRAMES.csv: a header, then one row per frame. Columns (any order): pos0, pos1, pos2 (position
counts, any integer: only the per-revolution part is used), torque0..2 (signed 16-bit); optional
offset0..2 (1/1024 electrical cycle; default 0), mode0..2 (0..3 or sine/six_step/align/off;
default sine), enable (0/1; default 1), fault0..2 (0/1; default 0), limit (0..65535; default
65535 = none).

DAC.csv: one row per input frame: frame, dac0..dac5 (signed codes, order m0a, m0b, m1a, m1b, m2a,
m2b) and t0_ns..t5_ns (each load's time after the frame start, i.e. after the inputs are latched).

Engines: `model` (numpy, bit-exact) or `rtl` (the commutator on a native Verilator harness,
tb/native/commutation, clocked at --clk-hz: ~10^5 frames/s at 12 MHz, ~2.5 10^4 at 48 MHz; the
RTL's codes are compared with the model and the DAC timing is checked clock by clock). The RTL
engine takes any clock the RTL accepts (a multiple of 1 kHz giving whole clocks of skew and
frame, >= 2 MHz with the default 2 us skew); the model engine takes any clock.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

from ..base.report import table
from ..golden import commutation as cm

REQUIRED = [f"pos{i}" for i in range(3)] + [f"torque{i}" for i in range(3)]
OPTIONAL = {**{f"offset{i}": (0, 0, 1023) for i in range(3)},
            **{f"mode{i}": (cm.SINE, 0, 3) for i in range(3)},
            **{f"fault{i}": (0, 0, 1) for i in range(3)},
            "enable": (1, 0, 1), "limit": (65535, 0, 65535)}
RANGES = {**{f"torque{i}": (-32768, 32767) for i in range(3)},
          **{f"pos{i}": (-(1 << 63), (1 << 63) - 1) for i in range(3)}}


class InputError(ValueError):
    pass


def _column(name: str, cells: list[str], first_line: int, lo: int, hi: int) -> np.ndarray:
    text = np.char.strip(np.array(cells, dtype=str))
    if name.startswith("mode"):
        lower = np.char.lower(text)
        for word, val in cm.MODES.items():
            text = np.where(lower == word, str(val), text)
    try:
        vals = text.astype(np.int64)
    except (ValueError, OverflowError):
        bad = next(i for i, t in enumerate(text.tolist()) if not _is_int(t))
        raise InputError(f"line {first_line + bad}: column {name}: {cells[bad]!r} is not an "
                         "integer") from None
    out = np.flatnonzero((vals < lo) | (vals > hi))
    if out.size:
        i = int(out[0])
        raise InputError(f"line {first_line + i}: column {name}: {vals[i]} is outside {lo}..{hi}")
    return vals


def _is_int(t: str) -> bool:
    try:
        int(t)
        return True
    except ValueError:
        return False


def read_frames(path: Path, cfg: cm.CommutationConfig) -> cm.Frames:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise InputError(f"{path}: empty file (a header line is required)")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise InputError(f"line 1: header lacks column(s) {', '.join(missing)}")
    unknown = [h for h in header if h not in REQUIRED and h not in OPTIONAL]
    if unknown:
        raise InputError(f"line 1: unknown column(s) {', '.join(unknown)}")
    body = rows[1:]
    lens = np.array([len(r) for r in body], dtype=np.int64)
    bad = np.flatnonzero(lens != len(header))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"line {i + 2}: {lens[i]} fields, the header has {len(header)}")
    if not body:
        raise InputError(f"{path}: no frames after the header")
    cols = {h: [r[j] for r in body] for j, h in enumerate(header)}
    n = len(body)
    maxoff = cfg.codes - 1

    def get(name: str) -> np.ndarray:
        if name in cols:
            lo, hi = RANGES.get(name, OPTIONAL.get(name, (0, 0, 0))[1:])
            if name.startswith("offset"):
                hi = maxoff
            return _column(name, cols[name], 2, lo, hi)
        return np.full(n, OPTIONAL[name][0], dtype=np.int64)

    per = {k: np.stack([get(f"{k}{i}") for i in range(3)], axis=1)
           for k in ("pos", "torque", "offset", "mode", "fault")}
    return cm.Frames(per["pos"], per["torque"], per["offset"], per["mode"], get("enable"),
                     per["fault"], get("limit"))


def run_rtl(frames: cm.Frames, cfg: cm.CommutationConfig, simulator: str = "verilator"
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """The commutator RTL over `frames` on the native Verilator harness (tb/native/commutation),
    clocked at cfg.clk_hz: (codes (n, 6), load times ns (n, 6), seconds with the build). The DAC
    port is checked clock by clock and every load against the documented schedule; a violation
    raises RuntimeError, a clock the RTL refuses raises ValueError (before any build)."""
    from ..runners import native_comm

    if simulator != "verilator":
        raise ValueError(f"the replay engine runs on Verilator only, not {simulator}")
    t0 = time.perf_counter()
    run = native_comm.run_commutation(frames, cfg)
    secs = time.perf_counter() - t0
    errors = native_comm.schedule_errors(run, cfg)
    if errors:
        raise RuntimeError(f"DAC timing: {errors} frames or port checks off the schedule")
    return run.codes, run.load_ns(cfg), secs


def write_dac(path: Path, codes: np.ndarray, load_ns: np.ndarray) -> None:
    n = codes.shape[0]
    header = ",".join(["frame"] + [f"dac{k}" for k in range(6)] + [f"t{k}_ns" for k in range(6)])
    table_ = np.column_stack([np.arange(n), codes, load_ns]).astype(np.float64)
    np.savetxt(path, table_, delimiter=",", header=header, comments="",
               fmt=["%d"] * 7 + ["%.3f"] * 6)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--in", dest="inp", required=True, type=Path, help="FRAMES.csv")
    parser.add_argument("--out", required=True, type=Path, help="DAC.csv to write")
    parser.add_argument("--engine", choices=("rtl", "model"), default="rtl",
                        help="rtl: cocotb + Verilator, checked against the model (default)")
    parser.add_argument("--clk-hz", type=int, default=50_000_000,
                        help="FPGA clock (default 50 MHz)")
    parser.add_argument("--offset-binary", action="store_true", help="DAC coding (codes out are "
                        "signed either way)")


def main(args: argparse.Namespace) -> int:
    cfg = cm.CommutationConfig(clk_hz=args.clk_hz, offset_binary=args.offset_binary)
    try:
        frames = read_frames(args.inp, cfg)
    except (InputError, OSError) as exc:
        print(f"error: {args.inp}: {exc}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    model = cm.commutate(frames, cfg)
    t_model = time.perf_counter() - t0
    rows = [["model", len(frames), f"{t_model:.4f}", "-"]]
    if args.engine == "model":
        codes = model
        load_ns = np.broadcast_to(cm.load_times_ns(cfg), codes.shape)
    else:
        try:
            codes, load_ns, secs = run_rtl(frames, cfg)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        rows.append(["rtl (native Verilator, incl. build)", len(frames), f"{secs:.2f}",
                     str(int(np.count_nonzero(codes != model)))])
    write_dac(args.out, codes, load_ns)
    print(table(["engine", "frames", "seconds", "codes differing from model"], rows))
    print(f"wrote {args.out}")
    return 0 if args.engine == "model" or np.array_equal(codes, model) else 1
