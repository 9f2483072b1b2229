"""`hapgate replay commutation --in FRAMES.csv --out DAC.csv [--engine rtl|model]`.

FRAMES.csv: a header, then one row per frame. Columns (any order): pos0, pos1, pos2 (position
counts, any integer: only the per-revolution part is used), torque0..2 (signed 16-bit); optional
offset0..2 (1/1024 electrical cycle; default 0), mode0..2 (0..3 or sine/six_step/align/off;
default sine), enable (0/1; default 1), fault0..2 (0/1; default 0), limit (0..65535; default
65535 = none). The file rules (UTF-8, line length, blank lines, header, integers, errors naming
FILE:LINE:COL, nothing written on an error) are hapgate.base.capture's, shared with `replay
interp`; columns it does not know are ignored and named on stderr.

DAC.csv: one row per input frame: frame, dac0..dac5 (signed codes, order m0a, m0b, m1a, m1b, m2a,
m2b) and t0_ns..t5_ns (each load's time after the frame start, i.e. after the inputs are latched).

Engines: `model` (numpy, bit-exact) or `rtl` (the commutator on a native Verilator harness,
tb/native/commutation, clocked at --clk-hz, idle clocks skipped: ~3-4 10^5 frames/s of CPU
time at any clock; the RTL's codes are compared with the model and the DAC timing is checked
clock by clock). For both engines --clk-hz must be a clock the RTL accepts (a multiple of
1 kHz giving whole clocks of skew and frame, 2 MHz to 134.217 MHz with the default 2 us skew
and 16 us frame), checked before any work.
"""

from __future__ import annotations

import argparse
import sys
import time
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
from ..golden import commutation as cm
from ..runners import native_comm

CHUNK_ROWS = 1 << 18
MODE_WORDS = {word: val for word, val in cm.MODES.items()}
MAX_CLK_HZ = 2_147_000_000   # a 32-bit Verilog integer parameter


def frame_columns(cfg: cm.CommutationConfig) -> tuple[Column, ...]:
    """FRAMES.csv columns (hapgate.base.capture's rules, shared with `replay interp`)."""
    cols = [Column(f"pos{i}") for i in range(3)]                 # any int64: per-rev part used
    cols += [Column(f"torque{i}", lo=-32768, hi=32767) for i in range(3)]
    cols += [Column(f"offset{i}", lo=0, hi=cfg.codes - 1, required=False, default=0)
             for i in range(3)]
    cols += [Column(f"mode{i}", lo=0, hi=3, required=False, default=cm.SINE, words=MODE_WORDS)
             for i in range(3)]
    cols += [Column(f"fault{i}", lo=0, hi=1, required=False, default=0) for i in range(3)]
    cols += [Column("enable", lo=0, hi=1, required=False, default=1),
             Column("limit", lo=0, hi=65535, required=False, default=65535)]
    return tuple(cols)


def frames_of(tab: CaptureTable) -> cm.Frames:
    c = tab.columns

    def per(k: str) -> np.ndarray:
        return np.stack([c[f"{k}{i}"] for i in range(3)], axis=1)

    return cm.Frames(per("pos"), per("torque"), per("offset"), per("mode"), c["enable"],
                     per("fault"), c["limit"])


def clock_error(clk_hz: int, engine: str) -> str | None:
    """Why the commutator RTL (rtl/dac_sched/dac_sched.v's elaboration checks, at the default
    2 us skew / 16 us frame / 1-clock strobe) would refuse this clock, or None. Checked for both
    engines, before any work: the model's load times are those of the RTL at that clock."""
    c = cm.CommutationConfig()
    hint = "e.g. 12000000, 16000000, 48000000 or 50000000"
    if clk_hz < 1000 or clk_hz % 1000 or clk_hz > MAX_CLK_HZ:
        return (f"--clk-hz {clk_hz}: must be a positive multiple of 1 kHz up to {MAX_CLK_HZ} "
                f"({hint})")
    khz = clk_hz // 1000
    top_khz = 2147483647 // max(c.frame_ns, c.skew_ns)   # dac_sched's 32-bit clock arithmetic
    if khz > top_khz:
        return (f"--clk-hz {clk_hz}: too fast for the DAC scheduler (its 32-bit clock "
                f"arithmetic takes at most {top_khz * 1000} Hz; {hint})")
    if khz * c.skew_ns % 1_000_000 or khz * c.frame_ns % 1_000_000:
        return (f"--clk-hz {clk_hz}: the {c.skew_ns} ns skew and {c.frame_ns} ns frame must be "
                f"whole clocks ({hint})")
    skew = khz * c.skew_ns // 1_000_000
    frame = khz * c.frame_ns // 1_000_000
    if skew < c.wr_cycles + 3 or 5 * skew + cm.PIPE_CLOCKS + c.wr_cycles + 3 > frame:
        return (f"--clk-hz {clk_hz}: too slow for the DAC schedule (a {c.skew_ns} ns skew of "
                f"{skew} clocks must hold the {c.wr_cycles}-clock strobe + 3; {hint})")
    del engine      # the native RTL engine takes every clock the RTL accepts, like the model
    return None


def run_rtl(frames: cm.Frames, cfg: cm.CommutationConfig, simulator: str = "verilator"
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """The commutator RTL over `frames` on the native Verilator harness (tb/native/commutation),
    clocked at cfg.clk_hz: (codes (n, 6), load times ns (n, 6), seconds with the build). The DAC
    port is checked clock by clock and every load against the documented schedule; a violation
    raises RuntimeError, a clock the RTL refuses raises ValueError (before any build)."""
    if simulator != "verilator":
        raise ValueError(f"the replay engine runs on Verilator only, not {simulator}")
    t0 = time.perf_counter()
    run = native_comm.run_commutation(frames, cfg)
    secs = time.perf_counter() - t0
    errors = native_comm.schedule_errors(run, cfg)
    if errors:
        raise RuntimeError(f"DAC timing: {errors} frames or port checks off the schedule")
    return run.codes, run.load_ns(cfg), secs


DAC_COLUMNS = ("frame", *(f"dac{k}" for k in range(6)), *(f"t{k}_ns" for k in range(6)))
DAC_FMT = {f"t{k}_ns": "%.3f" for k in range(6)}


def dac_columns(codes: np.ndarray, load_ns: np.ndarray, first: int = 0
                ) -> dict[str, np.ndarray]:
    cols: dict[str, np.ndarray] = {"frame": first + np.arange(codes.shape[0])}
    cols |= {f"dac{k}": codes[:, k] for k in range(6)}
    cols |= {f"t{k}_ns": load_ns[:, k] for k in range(6)}
    return cols


def replay_model(inp: Path, out: Path, cfg: cm.CommutationConfig, chunk_rows: int
                 ) -> tuple[int, float, list[str]]:
    """The model over FRAMES.csv chunk by chunk (a frame's codes depend on that frame only):
    memory bounded by a chunk, DAC.csv identical to a whole-file run. (frames, seconds of
    model time, ignored columns)."""
    n, secs, ignored = 0, 0.0, []
    with CsvWriter(out, DAC_COLUMNS, DAC_FMT) as w, line_progress(inp, "replay commutation") \
            as progress:
        for tab in rechunk(iter_table(inp, frame_columns(cfg)), chunk_rows):
            ignored = tab.ignored
            t0 = time.perf_counter()
            codes = cm.commutate(frames_of(tab), cfg)
            secs += time.perf_counter() - t0
            w.add(dac_columns(codes, np.broadcast_to(cm.load_times_ns(cfg), codes.shape), n))
            n += codes.shape[0]
            progress(int(tab.lines[-1]))
    return n, secs, ignored


def replay_rtl(inp: Path, out: Path, cfg: cm.CommutationConfig, chunk_rows: int
               ) -> tuple[int, float, float, int, list[str]]:
    """The RTL over FRAMES.csv chunk by chunk, through one harness process fed by a pipe
    (native_comm.CommStream), each chunk's codes compared with the model's and its load times
    with the documented schedule: memory bounded by a chunk, DAC.csv identical to a whole-file
    run. (frames, seconds of model time, seconds of the RTL with its build, codes differing from
    the model, ignored columns.) A DAC timing error raises RuntimeError (nothing written)."""
    n, t_model, differ, late, ignored = 0, 0.0, 0, 0, []
    want = cm.load_clocks(cfg)
    model: list[np.ndarray] = []
    t0 = time.perf_counter()
    rtl = native_comm.CommStream(cfg)
    progress = line_progress(inp, "replay commutation")

    def flush(w: CsvWriter, codes: np.ndarray, clocks: np.ndarray) -> None:
        nonlocal n, differ, late
        k = codes.shape[0]
        if k == 0:
            return
        ref = np.concatenate(model)
        model[:] = [ref[k:]]
        differ += int(np.count_nonzero(codes != ref[:k]))
        late += int(np.count_nonzero(np.any(clocks != want[None, :], axis=1)))
        w.add(dac_columns(codes, clocks * (1e9 / cfg.clk_hz), n))
        n += k

    try:
        with CsvWriter(out, DAC_COLUMNS, DAC_FMT) as w:
            for tab in rechunk(iter_table(inp, frame_columns(cfg)), chunk_rows):
                ignored = tab.ignored
                frames = frames_of(tab)
                rtl.feed(frames)
                t1 = time.perf_counter()
                model.append(cm.commutate(frames, cfg))
                t_model += time.perf_counter() - t1
                flush(w, *rtl.take())
                progress(int(tab.lines[-1]))
            flush(w, *rtl.finish())
            zero = cm.encode(np.zeros(6, dtype=np.int64), cfg)
            errors = late + rtl.violations + int(not np.array_equal(rtl.reset_words, zero))
            if errors:
                raise RuntimeError(f"DAC timing: {errors} frames or port checks off the schedule")
    finally:
        rtl.close()
        progress.close()
    return n, t_model, time.perf_counter() - t0, differ, ignored


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--in", dest="inp", required=True, help="FRAMES.csv")
    parser.add_argument("--out", required=True,
                        help="DAC.csv to write (its folder must exist)")
    parser.add_argument("--engine", choices=("rtl", "model"), default="rtl",
                        help="rtl: native Verilator harness, checked against the model (default)")
    parser.add_argument("--clk-hz", type=int, default=50_000_000,
                        help="FPGA clock, checked against the RTL's rules before any work "
                             "(default 50 MHz)")
    parser.add_argument("--offset-binary", action="store_true", help="DAC coding (codes out are "
                        "signed either way)")
    parser.add_argument("--chunk-rows", type=int, default=CHUNK_ROWS,
                        help=f"frames per chunk (memory is bounded by a chunk; the output "
                             f"does not depend on it; default {CHUNK_ROWS})")


def main(args: argparse.Namespace) -> int:
    try:
        args.inp, args.out = given_path("--in", args.inp), given_path("--out", args.out)
        why = clock_error(args.clk_hz, args.engine)
        if why:
            raise CaptureError(why)
        if args.chunk_rows < 1:
            raise CaptureError(f"--chunk-rows {args.chunk_rows}: must be >= 1")
        check_output(args.out, [args.inp])
        cfg = cm.CommutationConfig(clk_hz=args.clk_hz, offset_binary=args.offset_binary)
        if args.engine == "model":
            n, t_model, ignored = replay_model(args.inp, args.out, cfg, args.chunk_rows)
            _ignored(args.inp, ignored)
            print(table(["engine", "frames", "seconds", "codes differing from model"],
                        [["model", n, f"{t_model:.4f}", "-"]]))
            print(f"wrote {args.out}")
            return 0
        n, t_model, secs, differ, ignored = replay_rtl(args.inp, args.out, cfg, args.chunk_rows)
    except (CaptureError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    _ignored(args.inp, ignored)
    print(table(["engine", "frames", "seconds", "codes differing from model"],
                [["model", n, f"{t_model:.4f}", "-"],
                 ["rtl (native Verilator, incl. build)", n, f"{secs:.2f}", str(differ)]]))
    print(f"wrote {args.out}")
    return 0 if differ == 0 else 1


def _ignored(inp: Path, ignored: list[str]) -> None:
    if ignored:
        print(f"note: {inp}: ignored column(s) {', '.join(ignored)}", file=sys.stderr)
