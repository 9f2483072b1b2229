"""The native Verilator harness of the commutator and its DAC scheduler (tb/native/commutation/).

`build_commutation(cfg)` Verilates rtl/commutation/commutator.v (with rtl/dac_sched/dac_sched.v
and the sine ROM, HG_SIM_SKIP defined) and a C++ main that clocks it at the configuration's CLK_HZ,
one build per parameter set (cached under build/native/ by `native.verilate_harness`).
`run_commutation()` feeds it `Frames` and returns what the DAC received: the signed codes and
each load's time after its frame start, in clocks, plus the port-timing violations the harness
counted. By default the idle clocks between a channel's load and the next request pass in one
edge each (the HG_SIM_SKIP hook, tb/native/commutation/dac_sched_skip.v: same outputs, every
clock still counted by the checks).
Bad CLK_HZ (or any parameter the RTL refuses at elaboration) raises `ValueError` with the RTL's
message.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base.cbuild import BuildError
from ..base.paths import BUILD, RTL, TB, ensure
from ..golden import commutation as cm
from . import funcov, native

HARNESS = TB / "native" / "commutation" / "commutation_harness.cpp"
SOURCES = [RTL / "commutation" / "sine_lut.v", RTL / "dac_sched" / "dac_sched.v",
           RTL / "commutation" / "commutator.v",
           TB / "native" / "commutation" / "dac_sched_skip.v"]  # the HG_SIM_SKIP hook
REC_IN = np.dtype([("pos", "<u4", 3), ("torque", "<i2", 3), ("offset", "<u2", 3),
                   ("mode", "u1"), ("enable", "u1"), ("fault", "u1"), ("pad0", "u1"),
                   ("limit", "<u2"), ("pad1", "<u2")])
REC_OUT = np.dtype([("word", "<u2", 6), ("at", "<u4", 6)])
assert REC_IN.itemsize == 32 and REC_OUT.itemsize == 36


def check_config(cfg: cm.CommutationConfig) -> None:
    """The RTL's elaboration checks of dac_sched, as a ValueError before any build (the
    harness's Verilator build would fail on them with the message only in its log)."""
    khz, rest = divmod(cfg.clk_hz, 1000)
    problems = []
    if cfg.clk_hz <= 0 or rest:
        problems.append(f"CLK_HZ {cfg.clk_hz} must be a positive multiple of 1 kHz")
    elif khz * cfg.skew_ns % 1_000_000 or khz * cfg.frame_ns % 1_000_000:
        problems.append(f"CLK_HZ {cfg.clk_hz}: SKEW_NS {cfg.skew_ns} and FRAME_NS "
                        f"{cfg.frame_ns} must be whole clocks")
    elif khz > 2147483647 // max(cfg.frame_ns, cfg.skew_ns):
        problems.append(f"CLK_HZ {cfg.clk_hz} is too large for the 32-bit clock arithmetic")
    else:
        if cfg.skew_clocks < cfg.wr_cycles + 3:
            problems.append(f"CLK_HZ {cfg.clk_hz}: {cfg.skew_clocks} clocks of skew, the DAC "
                            f"strobe needs >= {cfg.wr_cycles + 3}")
        if 5 * cfg.skew_clocks + cm.PIPE_CLOCKS + cfg.wr_cycles + 3 > cfg.frame_clocks:
            problems.append(f"CLK_HZ {cfg.clk_hz}: the last DAC write does not end in the frame")
        if 6 * cfg.skew_clocks > cfg.frame_clocks:
            problems.append("6 x SKEW_NS exceeds FRAME_NS")
    if cfg.frame_ns < cfg.settle_ns:
        problems.append("FRAME_NS must be at least SETTLE_NS")
    if problems:
        raise ValueError("; ".join(problems))


def build_commutation(cfg: cm.CommutationConfig = cm.CommutationConfig(),
                      checks: cm.CommutationConfig | None = None) -> Path:
    """Verilate and compile the commutator harness for this configuration (cached), with the
    scheduler's HG_SIM_SKIP idle-skip hook. `checks` (tests only): build the harness's port checks
    for another configuration's strobe, frame and settling than the RTL's."""
    check_config(cfg)
    params = cfg.rtl_params()
    c = cfg if checks is None else checks
    settle_clocks = c.clk_hz // 1000 * c.settle_ns // 1_000_000
    flags = (f"-DCOUNT_BITS={c.count_bits} -DANGLE_BITS={c.angle_bits} "
             f"-DFRAME_CLOCKS={c.frame_clocks} -DWR_CYCLES={c.wr_cycles} "
             f"-DSETTLE_CLOCKS={settle_clocks} -O3 -I{native.TESTB.parent}")
    try:
        return native.verilate_harness("commutation_harness", "commutator", SOURCES, params,
                                       [HARNESS], cflags=flags,
                                       inputs=[Path(params["LUT_FILE"]), native.TESTB,
                                               TB / "native" / "vl_internals.h"],
                                       vflags=["-DHG_SIM_SKIP"])
    except BuildError as exc:
        stops = re.findall(r"\b(\w+_must_\w+|\w+_needs_\w+)\b", exc.text)
        if stops:
            raise ValueError(f"the RTL refuses this configuration: {stops[0]}") from None
        raise


@dataclass
class CommRun:
    codes: np.ndarray        # (n, 6) signed codes the DAC received for rows 0..n-1
    load_clocks: np.ndarray  # (n, 6) clock edges from each frame start to each load
    reset_words: np.ndarray  # (6,) the words of frame 0 (the reset frame)
    violations: int          # DAC port timing violations counted by the harness
    seconds: float           # harness wall time (simulation only)
    cpu_seconds: float       # harness CPU time (simulation only; what the benchmark divides by)
    clocks: int              # clocks simulated (skipped ones included)
    edges: int = 0           # rising edges evaluated (= clocks without the idle skip)
    skips: int = 0           # of which skip edges (each stands for 1 + its room clocks)

    def load_ns(self, cfg: cm.CommutationConfig) -> np.ndarray:
        return self.load_clocks * (1e9 / cfg.clk_hz)


def pack_frames(frames: cm.Frames, cfg: cm.CommutationConfig) -> np.ndarray:
    n = len(frames)
    rec = np.zeros(n, dtype=REC_IN)
    rec["pos"] = (np.asarray(frames.pos, dtype=np.int64) & ((1 << cfg.count_bits) - 1))
    rec["torque"] = np.asarray(frames.torque, dtype=np.int64)
    rec["offset"] = np.asarray(frames.offset, dtype=np.int64) & (cfg.codes - 1)
    mode = np.asarray(frames.mode, dtype=np.int64) & 3
    rec["mode"] = mode[:, 0] | mode[:, 1] << 2 | mode[:, 2] << 4
    rec["enable"] = np.asarray(frames.enable, dtype=np.int64) != 0
    f = (np.asarray(frames.fault, dtype=np.int64) != 0).astype(np.int64)
    rec["fault"] = f[:, 0] | f[:, 1] << 1 | f[:, 2] << 2
    rec["limit"] = np.asarray(frames.limit, dtype=np.int64) & 0xFFFF
    funcov.sample_commutation(frames.mode, frames.torque, rec["limit"])   # coverage runs only
    return rec


def run_commutation(frames: cm.Frames, cfg: cm.CommutationConfig = cm.CommutationConfig(),
                    skip: bool | str = True, exe: Path | None = None) -> CommRun:
    """Every row of `frames` through the Verilated commutator at cfg.clk_hz (row i latched at
    frame start i + 1 after reset), with the DAC port checked clock by clock. skip: idle clocks
    (after a channel's load until the next request or frame start) pass in one edge each
    through the scheduler's HG_SIM_SKIP hook, with the same outputs; False evaluates every clock.
    ("force", tests only: also skip a clock at each load, which the checks must catch.)
    exe: a harness built by build_commutation (default: the one for cfg)."""
    n = len(frames)
    if n == 0:
        raise ValueError("no frames")
    if exe is None:
        exe = build_commutation(cfg)
    rec = pack_frames(frames, cfg)
    with tempfile.TemporaryDirectory(dir=ensure(BUILD / "native" / "runs")) as tmp:
        fin, fout = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        rec.tofile(fin)
        t0 = time.perf_counter()
        out = subprocess.run([str(exe), str(fin), str(fout), str(n),
                              skip if isinstance(skip, str) else ("skip" if skip else "noskip")],
                             capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if out.returncode != 0:
            raise RuntimeError(f"commutation harness failed ({out.returncode}): "
                               f"{out.stderr.strip()}")
        stats = dict(kv.split("=") for kv in out.stdout.split())
        data = np.fromfile(fout, dtype=REC_OUT)
    if data.size != n + 1:
        raise RuntimeError(f"commutation harness wrote {data.size} of {n + 1} frames")
    words = data["word"].astype(np.int64)
    funcov.sample_dac(np.flatnonzero((data["at"][1:] > 0).any(axis=0)).tolist(), cfg.clk_hz)
    violations = int(stats.get("violations", 0))
    if out.stderr.strip():
        violations = max(violations, 1)
    return CommRun(codes=cm.decode(words[1:], cfg), load_clocks=data["at"][1:].astype(np.int64),
                   reset_words=words[0], violations=violations,
                   seconds=float(stats.get("seconds", wall)),
                   cpu_seconds=float(stats.get("cpu_seconds", wall)),
                   clocks=int(stats.get("clocks", 0)), edges=int(stats.get("edges", 0)),
                   skips=int(stats.get("skips", 0)))


class CommStream:
    """`run_commutation` chunk by chunk through one harness process (the replay's rtl engine):
    `feed(frames)`, then `take()` for the frames done so far and `finish()` for the rest, each
    as (codes (k, 6), load clocks (k, 6)). The reset frame's words are kept in `reset_words`;
    `finish()` also counts the port violations the harness reported."""

    def __init__(self, cfg: cm.CommutationConfig = cm.CommutationConfig()) -> None:
        self.cfg = cfg
        exe = build_commutation(cfg)
        self.stream = native.Stream(lambda fin, fout: [str(exe), fin, fout, "0", "skip"],
                                    REC_OUT, "commutation harness")
        self.reset_words: np.ndarray | None = None
        self.violations = 0
        self.stats: dict[str, str] = {}

    def feed(self, frames: cm.Frames) -> None:
        self.stream.feed(pack_frames(frames, self.cfg))

    def _split(self, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        words = data["word"].astype(np.int64)
        at = data["at"].astype(np.int64)
        if self.reset_words is None and data.size:
            self.reset_words, words, at = words[0], words[1:], at[1:]
        return cm.decode(words, self.cfg), at

    def take(self) -> tuple[np.ndarray, np.ndarray]:
        return self._split(self.stream.take())

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        last, self.stats, err = self.stream.finish()
        self.violations = int(self.stats.get("violations", 0))
        if err:
            self.violations = max(self.violations, 1)
        return self._split(last)

    def close(self) -> None:
        self.stream.close()


def schedule_errors(run: CommRun, cfg: cm.CommutationConfig) -> int:
    """Frames whose load clocks differ from the documented schedule (k * SKEW + LOAD), plus one
    if the reset frame was not zero torque, plus the harness's port violations."""
    want = cm.load_clocks(cfg)
    bad = int(np.count_nonzero(np.any(run.load_clocks != want[None, :], axis=1)))
    zero = cm.encode(np.zeros(6, dtype=np.int64), cfg)
    return bad + int(not np.array_equal(run.reset_words, zero)) + run.violations
