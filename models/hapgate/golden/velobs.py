"""Tracking velocity observer: the bit-exact integer model of rtl/interp/vel_observer.v.

A type-II tracking loop (the AD2S1210 / ODrive PLL family) on the interpolated position of one
axis, one update per ADC sample, with an optional acceleration state (type III). It sits beside
the window FIR of enc_interp (parameter VEL_OBS = 1); a register bit chooses which velocity the
register file reports. Its output has the FIR's units: counts per W = 2^vel_log2w samples.

State (two's complement integers, F = 28 fraction bits):
    P   position estimate, PI + F = 16 + 28 = 44 bits, wraps (only the low 16 integer bits of
        the position matter: the error is taken mod 2^16 counts)
    V   velocity estimate, counts/sample, saturated to [-2^(9+F), 2^(9+F) - 1] (+-512 counts per
        sample, twice the 244 rev/s a 1 MSPS decoder can follow)
    A   acceleration estimate, counts/sample^2, saturated to [-2^F, 2^F - 1] (+-1 count per
        sample^2, about 9.5e5 rev/s^2); always 0 in type II

Per sample n (pos = the 32-bit position of the interpolator for that sample, s = the bandwidth
code clamped to 2..8, x = 2^-s):
    e = ((pos mod 2^16) << F) - P, wrapped to 44 bits signed     (wrap-aware position error)
    seed = first sample after reset, or an overspeed (two-quadrant) step on this sample, or the
           first sample after a hold, or |e| >= 2^(12+F) (lost lock: more than 4 lines off)
    hold = the interpolator's signal-loss fault is set (sticky, until the DSP clears it)
    hold:      nothing changes (but the previous position below is still updated)
    seed:      P = (pos mod 2^16) << F, A = 0, and V = 0 after reset, V kept after a hold,
               otherwise (overspeed step, lost lock) V = sat(d << F) with d = the last step
               pos[n] - pos[n-1] mod 2^16 (signed): the loop restarts at the speed it sees
    type II:   P += V + (e >> (s-1));                  V += e >> 2s           (gains 2x, x^2)
    type III:  P += V + (e >> (s-1)) + (e >> s);       V += A + (e >> (2s-1)) + (e >> 2s);
               A += e >> 3s                                         (gains 3x, 3x^2, x^3)
    (>> is the arithmetic shift, i.e. floor; V and A are saturated after each update; P wraps;
    P's update uses the V of before the update.)
    output vel[n] = clamp((V + 2^(F-L-1)) >> (F-L), -(2^(L+9)), 2^(L+9) - 1), L = vel_log2w:
           the velocity after the update, rounded to counts per 2^L samples (the FIR's unit).

The closed loop's characteristic polynomial in u = z - 1 is u^2 + 2x u + x^2 (type II) and
u^3 + 3x u^2 + 3x^2 u + x^3 (type III): a double (triple) pole at z = 1 - x, critically damped,
stable for every code. Type II lags a constant acceleration a by 2a/x in velocity (2/x samples);
type III follows it without lag (its error is under constant jerk). `float_response` gives the
same loops without quantisation (the tests' reference for the error against the true velocity).

The recurrence is non-linear (floor shifts, saturation, seeding), so it cannot be vectorised over
samples exactly: `run` steps through the samples on Python integers (~0.4 M samples per CPU-s); the
inputs and the output scaling are vectorised. Long runs go through the native harness.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .interp import InterpOut

F = 28                      # fraction bits of P, V, A
PI = 16                     # integer bits of P kept (the error is taken mod 2^16 counts)
PW = PI + F                 # width of P and of the error
V_INT = 9                   # |V| < 2^9 counts/sample
A_INT = 0                   # |A| < 1 count/sample^2
LOCK_LOG2 = 12              # |e| >= 2^12 counts: lost lock, re-seed
S_MIN, S_MAX = 2, 8         # bandwidth codes the hardware uses (others clamp)
BW_RESET = 6                # reset bandwidth code (x = 1/64: about 2.5 kHz)
V_LO, V_HI = -(1 << (V_INT + F)), (1 << (V_INT + F)) - 1
A_LO, A_HI = -(1 << (A_INT + F)), (1 << (A_INT + F)) - 1


@dataclass(frozen=True)
class ObsConfig:
    bw: int = BW_RESET       # bandwidth code s: x = 2^-s of the sample rate (in rad/sample)
    type3: bool = True       # 1: the acceleration state (type III); 0: type II
    vel_log2w: int = 8       # output unit: counts per 2^vel_log2w samples (the FIR's W)

    @property
    def shift(self) -> int:
        return min(max(self.bw, S_MIN), S_MAX)


def run(pos: np.ndarray, faults: np.ndarray | None = None,
        overspeed_step: np.ndarray | None = None, cfg: ObsConfig = ObsConfig(),
        bw: np.ndarray | None = None, type3: np.ndarray | None = None) -> np.ndarray:
    """Observer velocity per sample (counts per 2^vel_log2w samples, int64).

    pos: the interpolator's 32-bit positions; faults: its sticky fault bits per sample (bit 2,
    signal loss, holds the loop); overspeed_step: True on the samples with a two-quadrant step
    (re-seed). bw, type3: per-sample register values (default: cfg's)."""
    p = np.asarray(pos).astype(np.int64) & ((1 << PI) - 1)
    n = p.size
    hold = (np.zeros(n, bool) if faults is None
            else (np.asarray(faults).astype(np.int64) & 4) != 0)
    ovs = np.zeros(n, bool) if overspeed_step is None else np.asarray(overspeed_step, bool)
    s_arr = (np.full(n, cfg.shift, np.int64) if bw is None
             else np.clip(np.asarray(bw, np.int64), S_MIN, S_MAX))
    t3 = (np.full(n, cfg.type3, bool) if type3 is None else np.asarray(type3, bool))
    half = 1 << (PW - 1)
    mask = (1 << PW) - 1
    lock = 1 << (LOCK_LOG2 + F)
    # per-sample shift amounts s - 1, s, 2s - 1, 2s, 3s (type II: 3s = -1 marks "no A")
    sh = np.stack([s_arr - 1, s_arr, 2 * s_arr - 1, 2 * s_arr, np.where(t3, 3 * s_arr, -1)], 1)
    # the last step d (signed, 16 bits) in 2^-F counts per sample, saturated to V's range
    d = ((np.diff(p, prepend=p[0]) + (1 << 15)) & 0xFFFF) - (1 << 15)
    dstep = np.clip(d << F, V_LO, V_HI)
    vs = [0] * n
    pp, vv, aa = 0, 0, 0
    first, was_held = True, False
    for k, (x, h, o, ds, (s1, s0, s21, s2, s3)) in enumerate(
            zip((p << F).tolist(), hold.tolist(), ovs.tolist(), dstep.tolist(), sh.tolist())):
        if h:
            was_held = True
            vs[k] = vv
            continue
        e = ((x - pp + half) & mask) - half
        if first or o or was_held or e >= lock or e <= -lock:
            if not (first or was_held):
                vv = ds
            pp, aa = x, 0
            first = was_held = False
        elif s3 >= 0:                                   # type III
            pp = (pp + vv + (e >> s1) + (e >> s0)) & mask
            vv += aa + (e >> s21) + (e >> s2)
            aa += e >> s3
            if aa > A_HI:
                aa = A_HI
            elif aa < A_LO:
                aa = A_LO
        else:                                           # type II
            pp = (pp + vv + (e >> s1)) & mask
            vv += e >> s2
            aa = 0
        if vv > V_HI:
            vv = V_HI
        elif vv < V_LO:
            vv = V_LO
        vs[k] = vv
    return scale_out(np.array(vs, dtype=np.int64), cfg.vel_log2w)


def scale_out(v: np.ndarray, vel_log2w: int) -> np.ndarray:
    """V (2^-F counts/sample) rounded to counts per 2^vel_log2w samples, clamped."""
    sh = F - vel_log2w
    lim = 1 << (vel_log2w + V_INT)
    return np.clip((np.asarray(v, np.int64) + (1 << (sh - 1))) >> sh, -lim, lim - 1)


def run_interp(out: InterpOut, cfg: ObsConfig = ObsConfig(),
               bw: np.ndarray | None = None, type3: np.ndarray | None = None) -> np.ndarray:
    """The observer on an interpolator result (hapgate.golden.interp.run's InterpOut)."""
    qc = out.extra["qc"].astype(np.int64)
    step = np.zeros(qc.size, bool)
    step[1:] = np.abs(qc[1:] - qc[:-1]) == 2
    return run(out.pos, out.faults, step, cfg, bw, type3)


# ----------------------------------------------------------------------------------------------
# Float loops (no quantisation) and derived figures


def gains(shift: int, type3: bool) -> tuple[float, float, float]:
    x = 2.0 ** -shift
    return (3 * x, 3 * x * x, x ** 3) if type3 else (2 * x, x * x, 0.0)


def closed_loop(shift: int, type3: bool) -> tuple[np.ndarray, np.ndarray]:
    """M, K of the unquantised loop X[n+1] = M X[n] + K p[n], X = (P, V, A) in counts."""
    k1, k2, k3 = gains(shift, type3)
    m = np.array([[1 - k1, 1.0, 0.0], [-k2, 1.0, 1.0 if type3 else 0.0], [-k3, 0.0, 1.0]])
    return m, np.array([k1, k2, k3])


def impulse_response(shift: int, type3: bool, n: int, inject: np.ndarray | None = None
                     ) -> np.ndarray:
    """h[j] = (M^j K)[1]: the velocity (counts/sample) after the update of sample j for a unit
    position impulse at sample 0, j = 0..n-1 (powers by doubling: log2(n) matrix products).
    With `inject` (a state vector) instead of K: the velocity's response to that disturbance of
    the state (e.g. a truncation of one update)."""
    m, k = closed_loop(shift, type3)
    cols = (k if inject is None else np.asarray(inject, np.float64)).reshape(3, 1)
    mp = m
    while cols.shape[1] < n:
        cols = np.concatenate([cols, mp @ cols], axis=1)
        mp = mp @ mp
    return cols[1, :n]


def float_response(pos: np.ndarray, shift: int, type3: bool) -> np.ndarray:
    """The same loop in float64 without quantisation or saturation, seeded at the first sample:
    velocity in counts/sample after each update (a linear filter: an FFT convolution)."""
    x = np.asarray(pos, dtype=np.float64)
    n = x.size
    h = impulse_response(shift, type3, n)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    y = np.fft.irfft(np.fft.rfft(x - x[0], size) * np.fft.rfft(h, size), size)
    return y[:n]
