"""Online encoder calibration: the bit-exact integer model of rtl/interp/enc_calib.v.

Sits between the capture and the angle stage of one interpolator axis (enc_interp with CAL = 1).
It corrects offset, gain and quadrature phase of the raw 8-bit channels a, b into two 12-bit
channels in quarter-LSB units normalised to the arcsine table's amplitude (127 LSB = 508), and
learns the coefficients online with a block sign-LMS on whole encoder lines. No division, no
square root, no multiplier beyond the three of the correction.

Correction (per sample; state x = the internal coefficient registers, applied c = x >> 8):
    a1 = 16 a - OA                      OA, OB: offsets in 1/16 LSB, applied range -512..511
    b1 = 16 b - OB
    ac = (a1 GA + 2^15) >> 16           GA, GB: gains in 2^-14, applied range 8192..32767
    bc = (b1 GB + a1 KP + 2^15) >> 16   KP: phase coupling in 2^-14, applied range -2048..2047
With the identity state (OA = OB = KP = 0, GA = GB = 2^14) ac = 4a, bc = 4b exactly, and the
512-entry table T512[k] = T[k / 4] at k = 4m (see `cal_table`): the paper's angle bit for bit.
A sample captured with calibration disabled uses the identity and resets the state.

Segmentation (raw signals, so it does not depend on the coefficients): the raw sign-bit quadrant
counter qr (the same decoder as the angle stage: zero held, +-2 overspeed steps) cut into cells
of 4 M quadrants, M = 2^lines_log2 lines. A block is the run of samples from a cell crossing to
the next crossing (exclusive). It is valid, and updates the state at its end sample e, when both
crossings go the same way, no step inside went the other way, every sample in it is fault-free
(no raw clipping, raw a^2 + b^2 inside the amplitude window, no two-quadrant step), not frozen,
calibration enabled, and it is shorter than 2^nlog samples. So the estimator sees whole lines
traversed one way (the sums of sin, cos, sign(sin) cos over a line vanish to within one sample,
with zero mean), and stands still at standstill, reversals, chatter and faults.

Update at a valid block end (N samples, sums over the block of the corrected samples):
    Sa = sum ac, Sb = sum bc, Ua = sum |ac|, Ub = sum |bc|, X = sum (ac < 0 ? -bc : bc)
    s = floor(log2 N), c = min(c + 1, 255) (valid blocks since enable), mu_e = min(MU, log2(c) + 1)
    sh = s + mu_e  (the gain 2^-mu_e falls with c like a running mean, then stays at 2^-MU)
    OA += (Sa << 9) >> sh, OB += (Sb << 9) >> sh            (mean -> 0)
    GA += ((T16 N - 16 Ua) << 9) >> sh, GB likewise with Ub  (mean |.| -> 508 * 2 / pi)
    KP -= (X << 13) >> sh                                    (sign(a) b uncorrelated)
each saturated to its register range (so the state can never run away), T16 = 5174. The new
state applies from sample e + 1 on (sample e already used the old one).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .interp import InterpConfig, sign_bits

FRAC = 8                      # internal fraction bits of every coefficient register
OFS_MIN, OFS_MAX = -512, 511  # applied offsets, 1/16 LSB
GAIN_MIN, GAIN_MAX = 8192, 32767  # applied gains, 2^-14 (0.5 .. 2)
KP_MIN, KP_MAX = -2048, 2047  # applied phase coupling, 2^-14 (+-7.2 deg)
GAIN_ONE = 1 << 14
R_Q = 4 * 127                 # target amplitude in quarter-LSB
T16 = 5174                    # round(16 * R_Q * 2 / pi): target mean |ac| in 1/16 quarter-LSB
GEAR_MAX = 255
CORR_BITS = 12                # corrected channel width (signed, quarter-LSB)
TABLE_SIZE = 512              # calibrated arcsine table entries (address min(m, 511))

IDENTITY = (0, 0, GAIN_ONE << FRAC, GAIN_ONE << FRAC, 0)   # OAx, OBx, GAx, GBx, KPx
X_MIN = (OFS_MIN << FRAC, OFS_MIN << FRAC, GAIN_MIN << FRAC, GAIN_MIN << FRAC, KP_MIN << FRAC)
X_MAX = (((OFS_MAX + 1) << FRAC) - 1, ((OFS_MAX + 1) << FRAC) - 1,
         ((GAIN_MAX + 1) << FRAC) - 1, ((GAIN_MAX + 1) << FRAC) - 1, ((KP_MAX + 1) << FRAC) - 1)


@dataclass(frozen=True)
class CalConfig:
    lines_log2: int = 3       # block = 2**lines_log2 encoder lines (RTL CAL_LINES_LOG2)
    nlog: int = 14            # blocks of 2**nlog samples or more are invalid (RTL CAL_NLOG)

    def rtl_params(self) -> dict[str, int]:
        return {"CAL_LINES_LOG2": self.lines_log2, "CAL_NLOG": self.nlog}


def cal_table(cfg: InterpConfig = InterpConfig()) -> np.ndarray:
    """Arcsine table of the calibrated path: 512 entries for the smaller corrected channel in
    quarter-LSB, T512[k] = min(2^L - 1, round(asin(min(k / 4, R) / R) * 2^L / 45deg))."""
    k = np.minimum(np.arange(TABLE_SIZE, dtype=np.float64) / 4.0, cfg.r_nom) / cfg.r_nom
    codes = np.floor(np.arcsin(k) * (1 << cfg.lut_bits) / (np.pi / 4) + 0.5)
    return np.minimum(codes, (1 << cfg.lut_bits) - 1).astype(np.int64)


def correct(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corrected channels for raw a, b and internal states x (shape (5,) or (5, n))."""
    a1 = 16 * np.asarray(a, dtype=np.int64) - (x[0] >> FRAC)
    b1 = 16 * np.asarray(b, dtype=np.int64) - (x[1] >> FRAC)
    ac = (a1 * (x[2] >> FRAC) + (1 << 15)) >> 16
    bc = (b1 * (x[3] >> FRAC) + a1 * (x[4] >> FRAC) + (1 << 15)) >> 16
    return ac, bc


def raw_steps(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw sign-bit quadrant decoder: (step per sample in -2..2, overspeed mask, counter)."""
    sa = sign_bits(a).astype(np.int64)
    sb = sign_bits(b).astype(np.int64)
    q = (sa << 1) | (sa ^ sb)
    step = np.zeros(q.size, dtype=np.int64)
    step[1:] = (q[1:] - q[:-1]) & 3
    step[step == 3] = -1
    ovs = step == 2
    if ovs.any():
        single = np.flatnonzero((step == 1) | (step == -1))
        # direction of the last single step strictly before each sample (+1 before any)
        pos = np.searchsorted(single, np.arange(q.size), side="left") - 1
        last = np.where(pos >= 0, step[single[np.maximum(pos, 0)]], 1) if single.size else 1
        step[ovs] = 2 * np.broadcast_to(last, q.shape)[ovs]
    return step, ovs, np.cumsum(step) + q[0]


@dataclass
class CalOut:
    ac: np.ndarray            # corrected channels (int64), what the angle stage sees
    bc: np.ndarray
    state: np.ndarray         # (5, n) internal state in effect at each sample (OAx..KPx)
    state_after: np.ndarray   # (5, n) internal state after each sample (what the RTL shows)
    gear: np.ndarray          # valid blocks since enable (saturating 255), after each sample
    updates: np.ndarray       # valid blocks since reset (wrapping 16 bits), after each sample
    ends: np.ndarray          # sample index of every applied update


def _as_array(v: np.ndarray | bool | int, n: int, dtype: type) -> np.ndarray:
    return np.broadcast_to(np.asarray(v, dtype=dtype), (n,))


def calibrate(a: np.ndarray, b: np.ndarray, en: np.ndarray | bool = True,
              freeze: np.ndarray | bool = False, mu: np.ndarray | int = 6,
              cfg: InterpConfig = InterpConfig(), cal: CalConfig = CalConfig()) -> CalOut:
    """Run the calibration over a capture (a, b raw codes after the INVERT swap; en, freeze,
    mu per sample or constant: the values captured with each sample)."""
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    n = a.size
    en_a = _as_array(en, n, bool)
    fr_a = _as_array(freeze, n, bool)
    mu_a = _as_array(mu, n, np.int64)

    clip = (a == -128) | (a == 127) | (b == -128) | (b == 127)
    amp2 = a * a + b * b
    bad_amp = (amp2 < cfg.amp_min ** 2) | (amp2 > cfg.amp_max ** 2)
    step, ovs, qcr = raw_steps(a, b)
    cell = qcr >> (cal.lines_log2 + 2)
    xi = np.flatnonzero(np.diff(cell) != 0) + 1          # crossing samples
    bad = clip | bad_amp | ovs | fr_a | ~en_a
    cbad = np.concatenate(([0], np.cumsum(bad)))         # bad count in [i, j) = cbad[j]-cbad[i]
    cf = np.concatenate(([0], np.cumsum(step > 0)))
    cb = np.concatenate(([0], np.cumsum(step < 0)))
    s, e = xi[:-1], xi[1:]
    fwd = step[s] > 0
    opp = np.where(fwd, cb[e] - cb[s + 1], cf[e] - cf[s + 1]) > 0   # inside (s, e)
    valid = ((step[e] > 0) == fwd) & ~opp & (cbad[e] == cbad[s]) & (e - s < (1 << cal.nlog))
    valid &= en_a[e]
    vs, ve = s[valid], e[valid]

    # disable runs: every sample captured with en = 0 resets the state (effective next sample)
    off = ~en_a
    r0 = np.flatnonzero(off & ~np.concatenate(([False], off[:-1])))

    cur = np.array(IDENTITY, dtype=np.int64)
    prev = cur.copy()
    cur_eff = 0
    gear = 0
    lo, hi = np.array(X_MIN, dtype=np.int64), np.array(X_MAX, dtype=np.int64)
    ch_idx: list[int] = [0]
    ch_state: list[np.ndarray] = [cur.copy()]
    gear_idx: list[int] = []
    gear_val: list[int] = []
    ri = 0
    for k in range(vs.size):
        s0, e0 = int(vs[k]), int(ve[k])
        # resets strictly before this block's end (a run cannot overlap a valid block)
        if ri < r0.size and r0[ri] < e0:
            first = int(r0[ri])          # the first reset changes the state; later ones keep it
            while ri < r0.size and r0[ri] < e0:
                gear_idx.append(int(r0[ri]))
                gear_val.append(0)
                ri += 1
            prev = cur
            cur = np.array(IDENTITY, dtype=np.int64)
            cur_eff = first + 1
            ch_idx.append(cur_eff)
            ch_state.append(cur.copy())
            gear = 0
        ac, bc = correct(a[s0:e0], b[s0:e0], cur)
        if cur_eff > s0:   # the first sample still used the previous state
            ac0, bc0 = correct(a[s0:s0 + 1], b[s0:s0 + 1], prev)
            ac[0], bc[0] = ac0[0], bc0[0]
        nn = e0 - s0
        gear = min(gear + 1, GEAR_MAX)
        mu_l = max(int(mu_a[e0]), 1)
        mu_e = min(mu_l, gear.bit_length())
        sh = (nn.bit_length() - 1) + mu_e
        sa_, sb_ = int(ac.sum()), int(bc.sum())
        ua, ub = int(np.abs(ac).sum()), int(np.abs(bc).sum())
        xx = int(np.where(ac < 0, -bc, bc).sum())
        d = np.array([(sa_ << 9) >> sh, (sb_ << 9) >> sh,
                      ((T16 * nn - 16 * ua) << 9) >> sh, ((T16 * nn - 16 * ub) << 9) >> sh,
                      -((xx << 13) >> sh)], dtype=np.int64)
        prev = cur
        cur = np.clip(cur + d, lo, hi)
        cur_eff = e0 + 1
        ch_idx.append(cur_eff)
        ch_state.append(cur.copy())
        gear_idx.append(e0)
        gear_val.append(gear)
    # resets after the last update
    for rr in r0[ri:]:
        ch_idx.append(int(rr) + 1)
        ch_state.append(np.array(IDENTITY, dtype=np.int64))
        gear_idx.append(int(rr))
        gear_val.append(0)

    idx = np.asarray(ch_idx, dtype=np.int64)
    st = np.stack(ch_state)
    k = np.arange(n)
    state = st[np.searchsorted(idx, k, side="right") - 1].T             # used by sample k
    state_after = st[np.searchsorted(idx - 1, k, side="right") - 1].T   # after sample k
    ac, bc = correct(a, b, state)
    ac = np.where(en_a, ac, 4 * a)
    bc = np.where(en_a, bc, 4 * b)

    gi = np.asarray(gear_idx, dtype=np.int64)
    gv = np.asarray(gear_val, dtype=np.int64)
    g_ev = np.zeros(n, dtype=bool)
    g_ev[gi] = True
    gval = np.zeros(n, dtype=np.int64)
    gval[gi] = gv
    last = np.maximum.accumulate(np.where(g_ev, np.arange(n), -1))
    gear_arr = np.where(last >= 0, gval[np.maximum(last, 0)], 0)
    upd = np.zeros(n, dtype=np.int64)
    upd[ve] = 1
    updates = np.cumsum(upd) & 0xFFFF
    return CalOut(ac=ac, bc=bc, state=state, state_after=state_after, gear=gear_arr,
                  updates=updates, ends=ve)


def applied(state: np.ndarray) -> np.ndarray:
    """The applied coefficients (OA, OB, GA, GB, KP) of internal states (5, ...)."""
    return np.asarray(state) >> FRAC
