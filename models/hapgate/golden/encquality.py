"""Encoder signal quality from a capture of raw A/B ADC codes (the capture buffer, rtl/capture/;
the HEIDENHAIN PWM-style diagnostics of issue 26): amplitude per channel, A/B ratio, offsets,
phase error, 2nd and 3rd harmonic, spread of the Lissajous radius, each beside its pass band.

Method (numpy, vectorised over the samples). The capture must be taken while the shaft turns at
a roughly steady speed (a polynomial of degree 3 in time fits its electrical angle) through at
least MIN_CYCLES lines, at most a quarter line per recorded sample. The angle phi(t) is the
polynomial fitted to the unwrapped atan2 of the corrected signals; each channel is then fitted
by least squares as c0 + sum_k (s_k sin k phi + c_k cos k phi), k = 1..3, and the correction
refined from that fit (ITERATIONS times), so the harmonics, offsets and ellipse of the signals
average out of phi over whole lines instead of biasing it. From the final fit:

- amp_a, amp_b: the fundamental's amplitude (ADC codes); ratio = amp_a / amp_b;
- offset_a, offset_b: c0 (ADC codes);
- phase_deg: B's fundamental phase minus A's, minus 90 degrees (B = cos(phi + phase_deg) for
  A = sin phi, the convention of `hapgate.golden.encsig`);
- h2_pct, h3_pct: the larger over both channels of |k-th| / |fundamental|, percent;
- radius_spread_pct: (max - min) / mean of the radius of the offset-free samples (A - c0,
  B - c0), percent: the shape of the Lissajous figure (offsets are reported on their own).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

MIN_CYCLES = 4          # whole lines the capture must span (the fit averages over them)
ITERATIONS = 3
FULL_SCALE = 127        # ADC codes: the 8-bit converter's positive full scale

# Pass bands. HEIDENHAIN's standard tolerances for 1 Vpp sin/cos encoders (PWM 20 user manual,
# "Standard signal amplitudes and tolerance ranges"; interface description): amplitude
# 0.6..1.2 Vpp (typ. 1), amplitude ratio 0.8..1.25, phase angle 90 +- 10 deg, asymmetry
# |P - N| / 2M <= 0.065. With the front end scaling the largest allowed signal (1.2 Vpp) to the
# ADC's full scale, 0.6 Vpp is half of it. The asymmetry of a channel with offset o and amplitude
# m is |(m + o) - (m - o)| / (2 * 2m) = |o| / 2m, so |o| <= 0.13 m.
AMP_MIN = 0.6 / 1.2 * FULL_SCALE          # 63.5 codes
AMP_MAX = float(FULL_SCALE)               # above it the converter clips (interpolator fault)
RATIO_MIN, RATIO_MAX = 0.8, 1.25
OFFSET_MAX_REL = 2 * 0.065                # |offset| / amplitude
PHASE_MAX_DEG = 10.0
# Harmonics (no HEIDENHAIN figure): a k-th harmonic h on both channels bends the Lissajous
# angle by up to h rad, i.e. h / (2 pi) of a line; 2 % is 0.0032 line = 3.3 of the
# interpolator's 1024 counts per line, the budget this project accepts per harmonic.
H_MAX_PCT = 2.0
# Radius spread: a figure at the edge of the ratio band alone (one channel 0.8 of the other)
# spreads (1 - 0.8) / 0.9 = 22 %; 25 % leaves the quantisation (+-0.5 LSB at 63.5 codes: 1.6 %).
SPREAD_MAX_PCT = 25.0


@dataclass(frozen=True)
class Quality:
    amp_a: float
    amp_b: float
    ratio: float
    offset_a: float
    offset_b: float
    phase_deg: float
    h2_pct: float
    h3_pct: float
    radius_spread_pct: float
    cycles: float             # lines the capture spans

    def as_dict(self) -> dict[str, float]:
        d = asdict(self)
        d.pop("cycles")
        return d


@dataclass(frozen=True)
class Check:
    name: str
    value: float
    limit: str
    unit: str
    result: str               # "PASS" / "FAIL"


def _basis(phi: np.ndarray) -> np.ndarray:
    cols = [np.ones_like(phi)]
    for k in (1, 2, 3):
        cols += [np.sin(k * phi), np.cos(k * phi)]
    return np.stack(cols, axis=1)


def _angle(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The polynomial (degree 3 in t) through the unwrapped atan2(a, b)."""
    raw = np.unwrap(np.arctan2(a, b))
    steps = np.abs(np.diff(raw))
    if steps.size and steps.max() > np.pi / 2:
        raise ValueError(f"the shaft moved {steps.max() / (2 * np.pi):.2f} line between two "
                         "recorded samples; at most 1/4 (lower the speed or DECIM)")
    coef = np.polynomial.polynomial.polyfit(t, raw, 3)
    return np.polynomial.polynomial.polyval(t, coef)


def analyse(a: np.ndarray, b: np.ndarray) -> Quality:
    """Signal quality of one axis from its captured A and B codes (equally spaced samples)."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    if a.shape != b.shape or a.ndim != 1 or a.size < 64:
        raise ValueError(f"need two equal 1-D captures of at least 64 samples, got {a.shape} "
                         f"and {b.shape}")
    t = np.linspace(-1.0, 1.0, a.size)
    # first correction: centre and scale from the extremes
    oa, ob = (a.max() + a.min()) / 2, (b.max() + b.min()) / 2
    ga, gb = (a.max() - a.min()) / 2, (b.max() - b.min()) / 2
    if min(ga, gb) <= 0:
        raise ValueError("a channel is constant: no signal")
    ca, cb = (a - oa) / ga, (b - ob) / gb
    for _ in range(ITERATIONS):
        phi = _angle(ca, cb, t)
        m = _basis(phi)
        xa = np.linalg.lstsq(m, a, rcond=None)[0]
        xb = np.linalg.lstsq(m, b, rcond=None)[0]
        # Heydemann-style correction from the fundamentals: A ~ oa + ma sin(phi + pa), B ~ ob +
        # mb cos(phi + pb); sin(phi) and cos(phi) back out of them
        ma, pa = np.hypot(xa[1], xa[2]), np.arctan2(xa[2], xa[1])
        mb, pb = np.hypot(xb[1], xb[2]), np.arctan2(xb[2], xb[1]) - np.pi / 2
        ua = (a - xa[0]) / ma          # sin(phi + pa)
        ub = (b - xb[0]) / mb          # cos(phi + pb) = sin(phi + pb + pi/2)
        d = pb - pa
        # rotate to a common phase: phi + pa as the reference
        ca = ua
        cb = (ub + ua * np.sin(d)) / np.cos(d)
    amp_a, amp_b = float(ma), float(mb)
    phase = float(np.rad2deg((d + np.pi) % (2 * np.pi) - np.pi))
    h2 = max(np.hypot(xa[3], xa[4]) / ma, np.hypot(xb[3], xb[4]) / mb) * 100
    h3 = max(np.hypot(xa[5], xa[6]) / ma, np.hypot(xb[5], xb[6]) / mb) * 100
    r = np.hypot(a - xa[0], b - xb[0])
    spread = float((r.max() - r.min()) / r.mean() * 100)
    cycles = float(abs(phi[-1] - phi[0]) / (2 * np.pi))
    if cycles < MIN_CYCLES:
        raise ValueError(f"the capture spans {cycles:.2f} lines; need at least {MIN_CYCLES} "
                         "(move faster or raise DECIM)")
    return Quality(amp_a=amp_a, amp_b=amp_b, ratio=amp_a / amp_b, offset_a=float(xa[0]),
                   offset_b=float(xb[0]), phase_deg=phase, h2_pct=float(h2), h3_pct=float(h3),
                   radius_spread_pct=spread, cycles=cycles)


def _check(name: str, value: float, ok: bool, limit: str, unit: str) -> Check:
    return Check(name, round(float(value), 4), limit, unit, "PASS" if ok else "FAIL")


def checks(q: Quality) -> list[Check]:
    """Each figure beside its pass band."""
    rel_a, rel_b = abs(q.offset_a) / q.amp_a, abs(q.offset_b) / q.amp_b
    return [
        _check("amp_a", q.amp_a, AMP_MIN <= q.amp_a <= AMP_MAX,
               f"{AMP_MIN:.1f}..{AMP_MAX:.0f}", "ADC codes"),
        _check("amp_b", q.amp_b, AMP_MIN <= q.amp_b <= AMP_MAX,
               f"{AMP_MIN:.1f}..{AMP_MAX:.0f}", "ADC codes"),
        _check("ratio", q.ratio, RATIO_MIN <= q.ratio <= RATIO_MAX,
               f"{RATIO_MIN}..{RATIO_MAX}", ""),
        _check("offset_a", q.offset_a, rel_a <= OFFSET_MAX_REL,
               f"|.| <= {OFFSET_MAX_REL:.2f} amp_a", "ADC codes"),
        _check("offset_b", q.offset_b, rel_b <= OFFSET_MAX_REL,
               f"|.| <= {OFFSET_MAX_REL:.2f} amp_b", "ADC codes"),
        _check("phase_deg", q.phase_deg, abs(q.phase_deg) <= PHASE_MAX_DEG,
               f"|.| <= {PHASE_MAX_DEG:g}", "deg"),
        _check("h2_pct", q.h2_pct, q.h2_pct <= H_MAX_PCT, f"<= {H_MAX_PCT:g}", "%"),
        _check("h3_pct", q.h3_pct, q.h3_pct <= H_MAX_PCT, f"<= {H_MAX_PCT:g}", "%"),
        _check("radius_spread_pct", q.radius_spread_pct, q.radius_spread_pct <= SPREAD_MAX_PCT,
               f"<= {SPREAD_MAX_PCT:g}", "%"),
    ]
