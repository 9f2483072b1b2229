"""The DAC schedule of rtl/commutation/commutator.v and rtl/dac_sched/dac_sched.v, in plain
Python (no simulator): the simulated clock period and the tolerance it implies, the recorded
loads, the checks on a recorded schedule (`check_schedule`, so a test can show that they fail on
a wrong schedule) and random input frames. The cocotb side (the frame driver and the DAC model
that records every load from simulation time) is hapgate.runners.cocotb_dac.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from .commutation import CommutationConfig, Frames, encode, load_clocks


def period_ps(cfg: CommutationConfig) -> int:
    """The simulated clock period, ps (the simulators run at 1 ps precision; cocotb's Clock
    needs an even number of steps). Exact when 10**12 / CLK_HZ is a whole even number of ps
    (50, 25, 12.5 MHz); otherwise the nearest even number of ps: 20834 ps for the 48 MHz default
    (exact 20833.33), 83334 ps for the board's 12 MHz (exact 83333.33).

    The RTL is synchronous, so every event it makes falls on a clock edge. `check_schedule`
    therefore (1) requires every time difference to be a whole number of simulated periods,
    (2) compares the clock counts with the spec (the documented latencies), and (3) asserts the
    simulated times against the spec's real times (2 us skew, 16 us frame) with the tolerance
    this rounding implies and nothing more: N clocks of simulated period p differ from N clocks
    of the exact period by N * |p - 10**12 / CLK_HZ| (64 ps over a 96-clock skew at 48 MHz,
    512 ps over a frame), less than one clock, so a schedule one clock off still fails."""
    if cfg.clk_hz <= 0:
        raise ValueError(f"CLK_HZ {cfg.clk_hz} must be positive")
    p = round(10**12 / cfg.clk_hz / 2) * 2
    if p < 2:
        raise ValueError(f"CLK_HZ {cfg.clk_hz}: the period is below 2 ps")
    return p


def period_error_ps(cfg: CommutationConfig) -> Fraction:
    """|simulated period - exact period|, ps (0 where the period is exact)."""
    return abs(Fraction(period_ps(cfg)) - Fraction(10**12, cfg.clk_hz))


def spec_tolerance_ps(cfg: CommutationConfig, spec_ps: int) -> Fraction:
    """The largest difference between a simulated and a real time of `spec_ps` (a whole number
    of exact clock periods): its clock count times the period error."""
    n = Fraction(spec_ps) / Fraction(10**12, cfg.clk_hz)
    if n.denominator != 1:
        raise ValueError(f"{spec_ps} ps is not a whole number of clocks at {cfg.clk_hz} Hz")
    return n * period_error_ps(cfg)


@dataclass
class Load:
    t_ps: int
    addr: int
    word: int


def pack(values: np.ndarray, width: int) -> int:
    out = 0
    for i, v in enumerate(np.asarray(values, dtype=np.int64).tolist()):
        out |= (int(v) & ((1 << width) - 1)) << (i * width)
    return out


def check_schedule(loads: list[Load], latches: list[int], cfg: CommutationConfig,
                   t0_ps: int | None = None) -> np.ndarray:
    """Check the recorded loads against the spec and return the words, shape (frames, 6).

    Frame i = the loads from latches[i] on. Asserted in simulation time: channel order
    0..5 in every frame; every load on a clock edge (a whole number of periods after the frame
    start); latency from the frame start to channel k exactly the model's load clocks; skew
    between successive channels and frame start to frame start of channel 0 equal to skew_ns and
    frame_ns, exactly where the simulated period is exact and otherwise within the rounding
    tolerance of `period_ps` (less than a clock). With t0_ps (the start of frame 0 after reset),
    the six loads before the first latch must be zero torque in the same timing."""
    p = period_ps(cfg)
    skew_ps, frame_ps = cfg.skew_ns * 1000, cfg.frame_ns * 1000
    tol_skew, tol_frame = spec_tolerance_ps(cfg, skew_ps), spec_tolerance_ps(cfg, frame_ps)
    t = np.array([ld.t_ps for ld in loads], dtype=np.int64)
    a = np.array([ld.addr for ld in loads], dtype=np.int64)
    w = np.array([ld.word for ld in loads], dtype=np.int64)
    starts = list(latches)
    if t0_ps is not None:
        starts = [t0_ps] + starts
    want_lat = load_clocks(cfg) * p
    words = []
    prev0 = None
    for ts in starts:
        sel = (t >= ts) & (t < ts + cfg.frame_clocks * p)
        assert np.count_nonzero(sel) == 6, f"frame at {ts} ps: {np.count_nonzero(sel)} loads, not 6"
        tf, af = t[sel], a[sel]
        assert np.array_equal(af, np.arange(6)), f"frame at {ts} ps: channel order {af.tolist()}"
        assert np.all((tf - ts) % p == 0), f"frame at {ts} ps: a load off the clock edges"
        skew = np.diff(tf)
        assert np.all(np.abs(skew - skew_ps) <= tol_skew), (
            f"frame at {ts} ps: skew {skew.tolist()} ps, spec {skew_ps} +- {float(tol_skew):g}")
        assert np.array_equal(tf - ts, want_lat), (
            f"frame at {ts} ps: latency {(tf - ts).tolist()} ps, documented {want_lat.tolist()}")
        if prev0 is not None:
            assert abs(int(tf[0] - prev0) - frame_ps) <= tol_frame, (
                f"frame period {tf[0] - prev0} ps, spec {frame_ps} +- {float(tol_frame):g}")
        prev0 = tf[0]
        words.append(w[sel])
    out = np.array(words, dtype=np.int64).reshape(len(starts), 6)
    if t0_ps is not None:
        zero = encode(np.zeros(6, dtype=np.int64), cfg)
        assert np.array_equal(out[0], zero), (
            f"frame 0 after reset wrote {out[0].tolist()}, not zero")
        out = out[1:]
    return out


def random_frames(rng: np.random.Generator, n: int, cfg: CommutationConfig,
                  modes: tuple[int, ...] = (0, 1, 2, 3)) -> Frames:
    """Random rows: positions, offsets, torques (with extremes), modes, enable, faults, limit."""
    pos = rng.integers(0, 1 << 32, (n, 3), dtype=np.int64)
    torque = rng.integers(-32768, 32768, (n, 3))
    ext = rng.random((n, 3)) < 0.2
    torque = np.where(ext, rng.choice([-32768, -32767, 32767, 0, 1, -1], (n, 3)), torque)
    offset = rng.integers(0, cfg.codes, (n, 3))
    mode = rng.choice(np.array(modes), (n, 3), p=None)
    enable = (rng.random(n) < 0.9).astype(np.int64)
    fault = (rng.random((n, 3)) < 0.1).astype(np.int64)
    limit = np.where(rng.random(n) < 0.5, 65535, rng.integers(0, 65536, n))
    return Frames(pos, torque, offset, mode, enable, fault, limit)
