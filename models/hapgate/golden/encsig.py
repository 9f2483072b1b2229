"""Encoder signal generator and float truth: seeded, vectorised.

A motion profile gives the true position in lines (float, electrical cycles) per sample; the
signal model turns it into 8-bit A/B ADC codes with the non-idealities of a real encoder and
front end, plus the index bit (high while the shaft is in quadrant 0 of line 0 of a revolution).

Truth in counts: lines * counts_per_line. Profiles start inside line 0 so the interpolator's
position (which starts in the line it wakes up in) and the truth share their origin.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

SAMPLE_HZ = 1_000_000
LINES = 1024
MAX_REV_S = SAMPLE_HZ / (4 * LINES)   # 244.14 rev/s: one quadrant per sample


@dataclass(frozen=True)
class SignalSpec:
    amplitude: float = 127.0    # R, ADC codes (127 = the paper's full scale)
    offset_a: float = 0.0       # ADC codes
    offset_b: float = 0.0
    gain_a: float = 1.0         # relative gain per channel
    gain_b: float = 1.0
    phase_deg: float = 0.0      # quadrature error: B = cos(phi + phase)
    h2: float = 0.0             # 2nd / 3rd harmonic, relative to the fundamental
    h3: float = 0.0
    noise_lsb: float = 0.0      # Gaussian noise sigma, LSB, independent per channel
    seed: int = 0


IDEAL = SignalSpec()
# The benchmark's "paper-like" front end: amplitude -10 %, 2 % offset, 3 % gain mismatch,
# 1 deg quadrature error, 0.3 LSB noise.
PAPER_LIKE = SignalSpec(amplitude=127 * 0.9, offset_a=0.02 * 127, offset_b=-0.02 * 127,
                        gain_a=1.015, gain_b=0.985, phase_deg=1.0, noise_lsb=0.3, seed=7)


def adc_codes(lines: np.ndarray, spec: SignalSpec = IDEAL) -> tuple[np.ndarray, np.ndarray]:
    """A, B as int8 ADC codes (rounded, clipped to -128..127) for true positions in lines."""
    phi = 2 * np.pi * np.asarray(lines, dtype=np.float64)
    ph = np.deg2rad(spec.phase_deg)
    sa = np.sin(phi) + spec.h2 * np.sin(2 * phi) + spec.h3 * np.sin(3 * phi)
    cb = np.cos(phi + ph) + spec.h2 * np.cos(2 * (phi + ph)) + spec.h3 * np.cos(3 * (phi + ph))
    a = spec.amplitude * spec.gain_a * sa + spec.offset_a
    b = spec.amplitude * spec.gain_b * cb + spec.offset_b
    if spec.noise_lsb > 0:
        rng = np.random.default_rng(spec.seed)
        a = a + rng.normal(0.0, spec.noise_lsb, a.shape)
        b = b + rng.normal(0.0, spec.noise_lsb, b.shape)
    qa = np.clip(np.floor(a + 0.5), -128, 127).astype(np.int8)
    qb = np.clip(np.floor(b + 0.5), -128, 127).astype(np.int8)
    return qa, qb


def index_bit(lines: np.ndarray, lines_per_rev: int = LINES) -> np.ndarray:
    """High while the shaft is in quadrant 0 of line 0 of a revolution."""
    x = np.asarray(lines, dtype=np.float64)
    line = np.floor(x)
    return (np.mod(line, lines_per_rev) == 0) & (x - line < 0.25)


# ----------------------------------------------------------------------------------------------
# Motion profiles: true position in lines per sample


def constant(rev_s: float, n: int, start: float = 0.1, sample_hz: float = SAMPLE_HZ,
             lines_per_rev: int = LINES) -> np.ndarray:
    return start + np.arange(n) * (rev_s * lines_per_rev / sample_hz)


def ramp(to_rev_s: float, n: int, start: float = 0.1, sample_hz: float = SAMPLE_HZ,
         lines_per_rev: int = LINES) -> np.ndarray:
    """Constant acceleration from standstill to `to_rev_s` over n samples."""
    t = np.arange(n) / sample_hz
    acc = to_rev_s * lines_per_rev / (n / sample_hz)
    return start + 0.5 * acc * t * t


def reversals(amp_lines: float, hz: float, n: int, start: float = 0.1,
              sample_hz: float = SAMPLE_HZ) -> np.ndarray:
    """Sinusoidal back-and-forth: peak speed 2*pi*hz*amp_lines lines/s."""
    t = np.arange(n) / sample_hz
    return start + amp_lines * np.sin(2 * np.pi * hz * t)


def standstill(at_deg: float, n: int) -> np.ndarray:
    """At rest exactly at an electrical angle (e.g. 90 = a quadrant boundary, 45 = the LUT
    switch) in line 0: with noise, the samples chatter across the boundary."""
    return np.full(n, at_deg / 360.0)


def with_spec(spec: SignalSpec, **kw: float) -> SignalSpec:
    return replace(spec, **kw)


# ----------------------------------------------------------------------------------------------
# Named stress scenarios: the same stimulus for cocotb, the native harness, demo and bench.


@dataclass
class Scenario:
    name: str
    a: np.ndarray
    b: np.ndarray
    index: np.ndarray
    truth_lines: np.ndarray
    clear_at: np.ndarray
    arm_at: np.ndarray


def scenario(name: str, n: int, seed: int = 1) -> Scenario:
    """A named stimulus of n samples (see SCENARIOS for the list)."""
    rng = np.random.default_rng(seed)
    noisy = with_spec(PAPER_LIKE, seed=seed)
    clear_at = np.array([], dtype=np.int64)
    arm_at = np.array([], dtype=np.int64)
    if name == "const150_ideal":
        x, spec = constant(150.0, n, start=rng.uniform(0, 1)), IDEAL
    elif name == "ramp244_paper":
        x, spec = ramp(244.0, n, start=rng.uniform(0, 1)), noisy
    elif name == "reversals_paper":
        # 200 Hz back and forth over +-122 lines: peak 150 rev/s, through the index line
        x, spec = reversals(150.0 * LINES / (2 * np.pi * 200.0), 200.0, n, start=0.3), noisy
    elif name == "reversal_on_boundary":
        # turn around exactly on the 90-degree quadrant boundary, from above and from below
        # (noise-free), then likewise on the 45-degree LUT switch
        k = np.arange(n)
        bounce = 0.004 * np.abs(np.sin(2 * np.pi * 8 * k / n))
        seg = (4 * k) // n
        x = np.choose(seg, [0.25 + bounce, 0.25 - bounce, 0.125 + bounce, 0.125 - bounce])
        spec = with_spec(IDEAL, amplitude=120.0)
    elif name == "standstill_chatter":
        # at rest on the quadrant boundary, then on the 45-degree switch, with 0.7 LSB noise
        x = np.where(np.arange(n) < n // 2, 0.25, 0.125)
        spec = with_spec(IDEAL, amplitude=120.0, noise_lsb=0.7, seed=seed)
    elif name == "clip_harmonics":
        # over-range amplitude (clips at -128/+127) with 2nd/3rd harmonics
        x = constant(60.0, n, start=0.05)
        spec = with_spec(IDEAL, amplitude=135.0, h2=0.03, h3=0.02)
    elif name == "overspeed":
        x, spec = ramp(300.0, n, start=0.1), IDEAL
    elif name == "dropout_controls":
        # index crossings, homing arms, a dropout (A = B = 0) and fault clears
        x = constant(-150.0, n, start=0.6)
        spec = with_spec(IDEAL, amplitude=110.0)
        arm_at = np.array([n // 10, n // 2])
        clear_at = np.array([n // 3, 2 * n // 3, 2 * n // 3 + 5])
    elif name in ("bench_ideal", "bench_paper"):
        # the benchmark's accuracy runs: constant speed, not commensurate with the sampling
        x = constant(37.3, n, start=0.37)
        spec = IDEAL if name == "bench_ideal" else with_spec(PAPER_LIKE, seed=seed)
    else:
        raise ValueError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)}, "
                         "bench_ideal, bench_paper")
    a, b = adc_codes(x, spec)
    if name == "dropout_controls":
        lo, hi = n // 3 - 40, n // 3 + 60
        a[lo:hi] = 0
        b[lo:hi] = 0
    return Scenario(name, a, b, index_bit(x), x, clear_at, arm_at)


SCENARIOS = ("const150_ideal", "ramp244_paper", "reversals_paper", "reversal_on_boundary",
             "standstill_chatter", "clip_harmonics", "overspeed", "dropout_controls")
