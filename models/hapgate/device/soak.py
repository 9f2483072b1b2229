"""The interpolator soak: seeded random motion through the native Verilated interpolator
(rtl/interp/enc_interp3.v, three axes), checked against the true angle on every sample.

One job = `n` samples on each of the three axes (3·n ADC samples), a pure function of its seed.
Each axis's motion is a chain of segments (random length), each segment of one class:

- `clean`: ideal signals, no noise; speed piecewise linear between random knots in
  ±V_CLEAN_MAX = 244.1 rev/s (reversals through zero; a third of the knots within 0.1 % of the
  limit). A sign-bit quadrant decoder steps one quadrant per sample up to 244.14 rev/s, so no
  overspeed may be flagged here.
- `noisy`: the paper-like imperfections, drawn per segment inside the documented envelope
  (amplitude, offsets, gain mismatch, quadrature phase, 2nd/3rd harmonics, noise; ENVELOPE), and
  speeds up to that segment's `v_safe`: 244.14 rev/s scaled by the narrowest quadrant the
  imperfect signals have, less a 6-sigma noise and 1/2-LSB rounding margin (`safe_speed`). Why
  not 244.1 here: offsets and quadrature error make some quadrants narrower than 90°, and a
  sign-bit decoder truly sees a quadrant skipped once the shaft crosses a narrow quadrant within
  one sample; noise moves the zero crossings by a fraction of a degree per sample. Above v_safe
  an "overspeed" is the signal's truth, not a false alarm. No overspeed may be flagged here.
- `over`: ideal signals at a constant 244.2..450 rev/s (1.0003..1.84 quadrants per sample):
  every such segment must be flagged (the sticky fault bit, cleared at each segment start), and
  the counter still tracks (steps of one or two quadrants in the known direction).

On every axis and every sample: no slip, i.e. |interpolated − true position| < 512 counts (half
a line) and every index latch equals the true revolution's line start exactly (so consecutive
latches differ by exactly 2^20 counts per revolution travelled).
"""

from __future__ import annotations

import math
import resource
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..golden import encsig, interp
from ..golden.interp import InterpConfig
from ..runners import native

AXES = 3
V_LIMIT = encsig.MAX_REV_S                 # 244.14 rev/s: one quadrant per sample
V_CLEAN_MAX = 244.1
V_OVER = (244.2, 450.0)
SEG_LEN = (20_000, 200_000)                # samples per segment
CLASSES = ("clean", "noisy", "over")
CLASS_P = (0.45, 0.45, 0.10)
# the noisy segments' envelope: each drawn uniformly in [lo, hi] (the paper-like values inside)
ENVELOPE = {"amplitude": (95.0, 115.0), "offset_a": (-3.0, 3.0), "offset_b": (-3.0, 3.0),
            "gain_a": (0.97, 1.03), "gain_b": (0.97, 1.03), "phase_deg": (-1.5, 1.5),
            "h2": (0.0, 0.01), "h3": (0.0, 0.01), "noise_lsb": (0.0, 0.5)}
NOISE_SIGMAS = 6.0
COUNTS_PER_LINE = 1024


def safe_speed(spec: encsig.SignalSpec) -> float:
    """The speed (rev/s) below which a sign-bit decoder cannot see a two-quadrant step on these
    signals: 244.14 rev/s x (narrowest quadrant - margin) / 90°, the quadrant boundaries being
    the zero crossings of the noise-free A and B, the margin 6 sigma of the difference of two
    samples' noise plus 1/2 LSB of rounding, as an angle at the smaller channel amplitude."""
    phi = np.linspace(0.0, 2 * np.pi, 72_001)
    ph = math.radians(spec.phase_deg)
    a = spec.amplitude * spec.gain_a * (np.sin(phi) + spec.h2 * np.sin(2 * phi)
                                        + spec.h3 * np.sin(3 * phi)) + spec.offset_a
    b = spec.amplitude * spec.gain_b * (np.cos(phi + ph) + spec.h2 * np.cos(2 * (phi + ph))
                                        + spec.h3 * np.cos(3 * (phi + ph))) + spec.offset_b
    za = np.flatnonzero(np.signbit(a[1:]) != np.signbit(a[:-1]))
    zb = np.flatnonzero(np.signbit(b[1:]) != np.signbit(b[:-1]))
    z = np.sort(phi[np.concatenate([za, zb])])
    widths = np.diff(np.concatenate([z, z[:1] + 2 * np.pi]))
    r = spec.amplitude * min(spec.gain_a, spec.gain_b)
    margin = (NOISE_SIGMAS * math.sqrt(2) * spec.noise_lsb + 0.5) / r     # rad
    return float(V_LIMIT * max(widths.min() - margin, 0.0) / (np.pi / 2))


def _axis_motion(rng: np.random.Generator, n: int) -> dict[str, Any]:
    """Segments and the per-sample speed (lines/sample) of one axis."""
    lens: list[int] = []
    while sum(lens) < n:
        lens.append(int(rng.integers(*SEG_LEN)))
    lens[-1] -= sum(lens) - n
    if lens[-1] < 2:
        lens.pop()
        lens[-1] += n - sum(lens)
    m = len(lens)
    cls = rng.choice(len(CLASSES), size=m, p=CLASS_P)
    specs: list[encsig.SignalSpec] = []
    vmax = np.empty(m)
    for s in range(m):                                # per segment, not per sample
        if CLASSES[cls[s]] == "noisy":
            kw = {k: float(rng.uniform(*v)) for k, v in ENVELOPE.items()}
            spec = encsig.SignalSpec(**kw, seed=int(rng.integers(1 << 31)))
            vmax[s] = safe_speed(spec)
        else:
            spec = encsig.IDEAL
            vmax[s] = V_CLEAN_MAX
        specs.append(spec)
    # speed knots (continuous speed: a reversal passes through zero, and an overspeed is entered
    # and left by a ramp, so the decoder's last single step gives the true direction)
    near = rng.random(m) < 1 / 3
    u1 = rng.uniform(-1.0, 1.0, m)
    u1 = np.where(near, np.sign(u1) * (1 - 1e-3 * rng.random(m)), u1)
    over = cls == CLASSES.index("over")
    vo = rng.uniform(*V_OVER, m) * np.where(rng.random(m) < 0.5, -1.0, 1.0)
    v1 = np.where(over, np.sign(vo) * np.abs(u1) * V_CLEAN_MAX, u1 * vmax)
    v0 = np.clip(np.concatenate(([0.0], v1[:-1])), -vmax, vmax)
    L = np.asarray(lens)
    start = np.concatenate(([0], np.cumsum(L)[:-1]))
    end = start + L - 1
    q1, q3 = start + L // 4, start + 3 * L // 4
    kx = np.where(over[:, None], np.stack([start, q1, q3, end], 1),
                  np.stack([start, start + 1, end - 1, end], 1)).ravel()
    kv = np.where(over[:, None], np.stack([v0, vo, vo, v1], 1),
                  np.stack([v0, v0 + (v1 - v0) / L, v1 - (v1 - v0) / L, v1], 1)).ravel()
    rev_s = np.interp(np.arange(n), kx, kv)
    seg = np.repeat(np.arange(m), L)
    return {"lens": L, "start": start, "cls": cls, "specs": specs, "seg": seg,
            "lines_per_sample": rev_s * encsig.LINES / encsig.SAMPLE_HZ, "vmax": vmax,
            "peak": np.where(over, np.abs(vo), np.maximum(np.abs(v0), np.abs(v1)))}


def stimulus(seed: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          list[dict[str, Any]]]:
    """A, B, index (n x 3), the true position in lines (n x 3) and each axis's segments."""
    rng = np.random.default_rng(seed)
    a = np.empty((n, AXES), np.int8)
    b = np.empty((n, AXES), np.int8)
    idx = np.empty((n, AXES), bool)
    x = np.empty((n, AXES))
    motions = []
    for ax in range(AXES):
        mo = _axis_motion(rng, n)
        xa = rng.uniform(0, encsig.LINES) + np.cumsum(mo["lines_per_sample"])
        x[:, ax] = xa
        for s, (st, ln) in enumerate(zip(mo["start"], mo["lens"])):
            a[st:st + ln, ax], b[st:st + ln, ax] = encsig.adc_codes(xa[st:st + ln],
                                                                    mo["specs"][s])
        idx[:, ax] = encsig.index_bit(xa)
        motions.append(mo)
    return a, b, idx, x, motions


def check(p: Mapping[str, Any]) -> None:
    n = p.get("n")
    if not isinstance(n, int) or isinstance(n, bool) or not 1000 <= n <= 50_000_000:
        raise ValueError("fixed.n: samples per axis per job, an integer in 1000..5e7")


def job(p: Mapping[str, Any]) -> dict[str, Any]:
    """One soak shard: n samples x 3 axes, seeded; the record of what held."""
    check(p)
    seed, n = int(p["seed"]), int(p["n"])
    c0 = cpu_seconds()
    t0 = time.perf_counter()
    a, b, idx, x, motions = stimulus(seed, n)
    t_gen = time.perf_counter() - t0
    clear_at = [mo["start"][1:] for mo in motions]
    r = native.run_interp(a, b, idx, InterpConfig(), columns=("pos", "index_pos", "index_count",
                                                               "faults"), clear_at=clear_at)
    rec: dict[str, Any] = {"samples": n * AXES, "harness_s": r.seconds, "gen_s": t_gen}
    rec.update(evaluate(x, motions, r.outputs))
    rec["samples_per_s"] = n * AXES / r.seconds if r.seconds > 0 else 0.0
    rec["cpu_s"] = cpu_seconds() - c0
    return rec


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process and its finished children (the harness):
    the cost of a shard whatever the machine's load (wall time is not)."""
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def evaluate(x: np.ndarray, motions: list[dict[str, Any]],
             outputs: list[dict[str, np.ndarray]]) -> dict[str, Any]:
    """The soak's checks of one shard's outputs (per axis: pos, index_pos, index_count, faults)
    against the true positions and the segments."""
    pos_err_max = 0.0
    latch_bad = latches = 0
    false_ovs = missed_ovs = over_segs = below_segs = 0
    v_noisy_min = math.inf
    peak_clean = 0.0
    for ax in range(AXES):
        o, mo = outputs[ax], motions[ax]
        xa = x[:, ax]
        # the counter starts at the first sample's decoded quadrant in line 0: truth in counts
        # from the first sample's line (a whole-line ambiguity at sample 0 is not a slip)
        truth = (xa - math.floor(xa[0])) * COUNTS_PER_LINE
        err = interp.truth_counts_error(o["pos"], truth)
        line0 = int(round(float(err[0]) / COUNTS_PER_LINE)) * COUNTS_PER_LINE
        err = err - line0
        pos_err_max = max(pos_err_max, float(np.abs(err).max()))
        rise = np.flatnonzero(np.diff(o["index_count"]) != 0) + 1
        if rise.size:
            # the revolution whose index the shaft crossed: the line-0 start nearest the truth
            rev_line = np.round(xa[rise] / encsig.LINES) * encsig.LINES
            want = ((rev_line - math.floor(xa[0])) * COUNTS_PER_LINE).astype(np.int64) + line0
            got = o["index_pos"][rise].astype(np.int64)
            latch_bad += int((((got - want) + (1 << 31)) % (1 << 32) - (1 << 31) != 0).sum())
            latches += int(rise.size)
        end = mo["start"] + mo["lens"] - 1
        flagged = (o["faults"][end] & interp.FAULT_OVERSPEED) != 0
        over = mo["cls"] == CLASSES.index("over")
        false_ovs += int((flagged & ~over).sum())
        missed_ovs += int((~flagged & over).sum())
        over_segs += int(over.sum())
        below_segs += int((~over).sum())
        noisy = mo["cls"] == CLASSES.index("noisy")
        if noisy.any():
            v_noisy_min = min(v_noisy_min, float(mo["vmax"][noisy].min()))
        clean = mo["cls"] == CLASSES.index("clean")
        if clean.any():
            peak_clean = max(peak_clean, float(mo["peak"][clean].max()))
    return {"pos_err_max_counts": pos_err_max, "slips": int(pos_err_max >= 512) + latch_bad,
                "index_latches": latches, "index_latch_errors": latch_bad,
                "segments_below": below_segs, "segments_over": over_segs,
                "false_overspeed": false_ovs, "missed_overspeed": missed_ovs,
                "peak_clean_rev_s": peak_clean,
                "v_safe_noisy_min_rev_s": v_noisy_min if math.isfinite(v_noisy_min) else 0.0}
