"""Encoder signal quality (hapgate.golden.encquality) on synthetic captures with known
imperfections built by hapgate.golden.encsig: each imperfection is reported in its own field,
near the value it was built with, and fails its band; a clean signal passes every band. The
expected values come from the construction (SignalSpec), never from the analysis."""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.golden import capture, encquality, encsig

N = 1024                     # one capture of one axis (CAP_DEPTH_LOG2 = 10)
REV_S = 19.0                 # 19 rev/s at 1 MSPS: 19.9 lines in the capture, 51 samples a line
AMP = 127 / 1.2              # 1 Vpp with 1.2 Vpp at the ADC's full scale (encquality's scaling)
CLEAN = encsig.SignalSpec(amplitude=AMP, noise_lsb=0.3, seed=5)
# Accuracy the analysis must reach on the built values: rounding to codes (+-0.5 LSB, uniform:
# 0.29 LSB rms) plus 0.3 LSB noise, averaged over 1024 samples, leave about 0.03 LSB on a fitted
# coefficient; the bounds below are ten times that, relative to the amplitude where it applies.
TOL_CODES = 0.3
TOL_REL = 0.3 / AMP          # on ratios and harmonic fractions
TOL_DEG = np.rad2deg(TOL_REL)

CASES = {   # name: (spec changes, field -> built value, the checks that must fail)
    "clean": ({}, {"amp_a": AMP, "amp_b": AMP, "ratio": 1.0, "offset_a": 0.0,
                   "offset_b": 0.0, "phase_deg": 0.0, "h2_pct": 0.0, "h3_pct": 0.0},
              set()),
    # the spread of a 2:1 ellipse, (1 - 0.5) / 0.75 = 67 %, fails as well
    "weak_b": ({"gain_b": 0.5}, {"amp_a": AMP, "amp_b": AMP / 2, "ratio": 2.0},
               {"amp_b", "ratio", "radius_spread_pct"}),
    "h2_3pct": ({"h2": 0.03}, {"h2_pct": 3.0, "h3_pct": 0.0, "amp_a": AMP}, {"h2_pct"}),
    "h3_3pct": ({"h3": 0.03}, {"h3_pct": 3.0, "h2_pct": 0.0, "amp_b": AMP}, {"h3_pct"}),
    "offset_a": ({"offset_a": 20.0}, {"offset_a": 20.0, "offset_b": 0.0, "amp_a": AMP},
                 {"offset_a"}),
    "phase_12deg": ({"phase_deg": 12.0}, {"phase_deg": 12.0, "amp_b": AMP}, {"phase_deg"}),
}


def _captured(spec: encsig.SignalSpec, rev_s: float = REV_S, decim: int = 0
              ) -> tuple[np.ndarray, np.ndarray]:
    """A and B of one axis as the capture buffer records them (through its golden model)."""
    n = N * (decim + 1)
    x = encsig.constant(rev_s, n, start=0.37)
    qa, qb = encsig.adc_codes(x, spec)
    a = np.zeros((n, 3), np.int64)
    b = np.zeros((n, 3), np.int64)
    a[:, 1], b[:, 1] = qa, qb
    ent = capture.record(a, b, np.zeros((n, 3), np.int64),
                         capture.CapCtrl(True, sel=1, decim=decim))
    return capture.unpack(ent, 1)


def _tol(field: str) -> float:
    if field in ("ratio",):
        return 2 * TOL_REL
    if field.endswith("_pct"):
        return 100 * TOL_REL
    if field == "phase_deg":
        return TOL_DEG
    return TOL_CODES


@pytest.mark.parametrize("name", list(CASES))
def test_imperfection_in_its_field(name: str) -> None:
    change, built, fail = CASES[name]
    q = encquality.analyse(*_captured(encsig.with_spec(CLEAN, **change)))
    got = q.as_dict()
    for field, want in built.items():
        assert abs(got[field] - want) <= _tol(field), (
            f"{name}: {field} = {got[field]:.4f}, built {want:.4f} (tolerance {_tol(field):.4f})")
    failed = {c.name for c in encquality.checks(q) if c.result == "FAIL"}
    assert failed == fail, f"{name}: failed {sorted(failed)}, expected {sorted(fail)}"


def test_decimated_capture() -> None:
    """DECIM = 3: the same figures from every 4th sample of four times as many lines."""
    q = encquality.analyse(*_captured(encsig.with_spec(CLEAN, h2=0.03), rev_s=REV_S,
                                      decim=3))
    assert abs(q.h2_pct - 3.0) <= 100 * TOL_REL and q.cycles > 4 * 19


def test_refuses_what_it_cannot_measure() -> None:
    with pytest.raises(ValueError, match="spans"):      # too slow: under MIN_CYCLES lines
        encquality.analyse(*_captured(CLEAN, rev_s=2.0))
    with pytest.raises(ValueError, match="line between two"):   # too fast to unwrap
        encquality.analyse(*_captured(CLEAN, rev_s=400.0))
    with pytest.raises(ValueError, match="constant"):
        encquality.analyse(np.zeros(100), np.arange(100.0))
