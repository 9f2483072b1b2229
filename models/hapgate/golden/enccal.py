"""Online encoder calibration: the bit-exact integer model of rtl/interp/enc_calib.v.

Sits between the capture and the angle stage of one interpolator axis (enc_interp with CAL = 1).
It corrects offset, gain and quadrature phase of the raw 8-bit channels a, b into two 12-bit
channels in quarter-LSB units normalised to the arcsine table's amplitude (127 LSB = 508), and
learns the coefficients online with a block LMS on whole encoder lines. No division, no square
root; one multiplier (a b) beyond the three of the correction. (The cross term is a product, not
sign(a) b: the sign's jumps, sampled at 4..8 samples per line, give errors that add up coherently
at speeds where a half line is close to a whole number of samples.)

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
calibration enabled, it is shorter than 2^nlog samples, and its two halves (2^lines_log2 / 2
lines each, cut where the counter passes the middle of the cell) took the same number of
samples to within N / 32 (about constant speed). So the estimator sees whole lines
traversed one way at a steady speed (the sums of sin, cos, sin cos over whole lines vanish to
within one sample, with zero mean), and stands still at standstill, reversals, chatter and
faults.

Update at a valid block end (N samples, sums over the block of the corrected samples):
    Sa = sum ac, Sb = sum bc, Ua = sum |ac|, Ub = sum |bc|, X = sum ac bc
    s = floor(log2 N) + (bit below the leading one of N)   (so N / 2^s is in [0.75, 1.5))
    c = min(c + 1, 255) (valid blocks since enable), mu_e = min(max(MU, 1), floor(log2 c))
    sh = s + mu_e  (the gain 2^-mu_e falls with c like a running mean, then stays at 2^-MU)
    OA += (Sa << 10) >> sh, OB += (Sb << 10) >> sh          (mean -> 0)
    GA += ((T16 N - 16 Ua) << 10) >> sh, GB likewise with Ub (mean |.| -> 508 * 2 / pi)
    KP -= (X << 5) >> sh                                     (a and b uncorrelated)
(>> is the arithmetic shift, i.e. floor). The loop gains are 0.8..1.7 x 2^-mu_e for all five.
each saturated to its register range (so the state can never run away), T16 = 5174. The new
state applies from sample e + 1 on (sample e already used the old one).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .encsig import LINES, PAPER_LIKE, SAMPLE_HZ, adc_codes, constant, with_spec
from .interpcfg import TABLE_SIZE as TABLE_SIZE
from .interpcfg import Decoder, InterpConfig, decode
from .interpcfg import cal_table as cal_table

FRAC = 8                      # internal fraction bits of every coefficient register
OFS_MIN, OFS_MAX = -512, 511  # applied offsets, 1/16 LSB
GAIN_MIN, GAIN_MAX = 8192, 32767  # applied gains, 2^-14 (0.5 .. 2)
KP_MIN, KP_MAX = -2048, 2047  # applied phase coupling, 2^-14 (+-7.2 deg)
GAIN_ONE = 1 << 14
R_Q = 4 * 127                 # target amplitude in quarter-LSB
T16 = 5174                    # round(16 * R_Q * 2 / pi): target mean |ac| in 1/16 quarter-LSB
GEAR_MAX = 255
CORR_BITS = 12                # corrected channel width (signed, quarter-LSB)

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


def correct(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corrected channels for raw a, b and internal states x (shape (5,) or (5, n))."""
    a1 = 16 * np.asarray(a, dtype=np.int64) - (x[0] >> FRAC)
    b1 = 16 * np.asarray(b, dtype=np.int64) - (x[1] >> FRAC)
    ac = (a1 * (x[2] >> FRAC) + (1 << 15)) >> 16
    bc = (b1 * (x[3] >> FRAC) + a1 * (x[4] >> FRAC) + (1 << 15)) >> 16
    return ac, bc


def raw_steps(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw sign-bit quadrant decoder: (step per sample in -2..2, overspeed mask, counter)."""
    _, step, ovs, qc, _ = decode(a, b)
    return step, ovs, qc


@dataclass(frozen=True)
class CalState:
    """What the calibration carries from one chunk to the next (`calibrate(..., state=)`).

    The open block (from the last cell crossing to the end of the chunk) cannot be judged before
    its end crossing: its raw samples and controls are carried (`tail_*`, at most 2^nlog
    samples: a longer block is invalid whatever follows, and is dropped) and run again at the
    front of the next chunk, from the decoder and coefficient state in effect at its first
    sample. Every update and gear value at that first sample is already in the state."""
    tail_a: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    tail_b: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    tail_en: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    tail_fr: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    tail_mu: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dec: Decoder = Decoder()                  # the raw decoder before the tail's first sample
    cur: tuple[int, ...] = IDENTITY           # coefficient registers at the tail's start
    prev: tuple[int, ...] = IDENTITY          # the registers before the last change
    cur_eff: int = -(1 << 62)                 # first sample (tail-relative) that uses `cur`
    gear: int = 0
    updates: int = 0                          # valid blocks before the tail (not wrapped)
    off_prev: bool = False                    # the sample before the tail had en = 0


@dataclass
class CalOut:
    ac: np.ndarray            # corrected channels (int64), what the angle stage sees
    bc: np.ndarray
    state: np.ndarray         # (5, n) internal state in effect at each sample (OAx..KPx)
    state_after: np.ndarray   # (5, n) internal state after each sample (what the RTL shows)
    gear: np.ndarray          # valid blocks since enable (saturating 255), after each sample
    updates: np.ndarray       # valid blocks since reset (wrapping 16 bits), after each sample
    ends: np.ndarray          # sample index of every applied update (chunk-relative)
    carry: CalState = field(default_factory=CalState)   # the state for the next chunk


def _as_array(v: np.ndarray | bool | int, n: int, dtype: type) -> np.ndarray:
    return np.broadcast_to(np.asarray(v, dtype=dtype), (n,))


def calibrate(a: np.ndarray, b: np.ndarray, en: np.ndarray | bool = True,
              freeze: np.ndarray | bool = False, mu: np.ndarray | int = 6,
              cfg: InterpConfig = InterpConfig(), cal: CalConfig = CalConfig(),
              state: CalState | None = None) -> CalOut:
    """Run the calibration over a capture (a, b raw codes after the INVERT swap; en, freeze,
    mu per sample or constant: the values captured with each sample). `state`: what the
    previous chunk left (CalOut.carry); a capture cut anywhere into chunks gives the same
    outputs as the whole."""
    st = CalState() if state is None else state
    nt = st.tail_a.size
    n_chunk = np.asarray(a).size
    a = np.concatenate((st.tail_a, np.asarray(a, dtype=np.int64)))
    b = np.concatenate((st.tail_b, np.asarray(b, dtype=np.int64)))
    n = a.size
    en_a = np.concatenate((st.tail_en, _as_array(en, n_chunk, bool)))
    fr_a = np.concatenate((st.tail_fr, _as_array(freeze, n_chunk, bool)))
    mu_a = np.concatenate((st.tail_mu, _as_array(mu, n_chunk, np.int64)))

    clip = (a == -128) | (a == 127) | (b == -128) | (b == 127)
    amp2 = a * a + b * b
    bad_amp = (amp2 < cfg.amp_min ** 2) | (amp2 > cfg.amp_max ** 2)
    _, step, ovs, qcr, _ = decode(a, b, st.dec)
    cell = qcr >> (cal.lines_log2 + 2)
    prev_cell = cell[0] if st.dec.q is None else st.dec.qc >> (cal.lines_log2 + 2)
    xi = np.flatnonzero(np.diff(cell, prepend=prev_cell) != 0)   # crossing samples
    bad = clip | bad_amp | ovs | fr_a | ~en_a
    cbad = np.concatenate(([0], np.cumsum(bad)))         # bad count in [i, j) = cbad[j]-cbad[i]
    cf = np.concatenate(([0], np.cumsum(step > 0)))
    cb = np.concatenate(([0], np.cumsum(step < 0)))
    s, e = xi[:-1], xi[1:]
    fwd = step[s] > 0
    opp = np.where(fwd, cb[e] - cb[s + 1], cf[e] - cf[s + 1]) > 0   # inside (s, e)
    valid = ((step[e] > 0) == fwd) & ~opp & (cbad[e] == cbad[s]) & (e - s < (1 << cal.nlog))
    # speed about constant: the two half-blocks (2M lines each) differ by <= N/32 samples
    half = (qcr >> (cal.lines_log2 + 1)) & 1
    ht = np.flatnonzero(np.diff(half) != 0) + 1
    t = ht[np.minimum(np.searchsorted(ht, s, side="right"), max(ht.size - 1, 0))] if ht.size \
        else e
    t = np.where((t > s) & (t < e), t, s)
    valid &= np.abs(2 * t - s - e) <= (e - s) >> 5
    valid &= en_a[e]
    vs, ve = s[valid], e[valid]

    # disable runs: every sample captured with en = 0 resets the state (effective next sample)
    off = ~en_a
    r0 = np.flatnonzero(off & ~np.concatenate(([st.off_prev], off[:-1])))

    # The recursion runs once per valid block (not per sample), on Python ints for the state
    # and numpy slices for the block sums.
    a16, b16 = 16 * a, 16 * b
    lo, hi = X_MIN, X_MAX
    cur: tuple[int, ...] = st.cur
    prev = st.prev
    cur_eff = st.cur_eff
    gear = st.gear
    ch_idx: list[int] = [-(1 << 62), cur_eff]
    ch_state: list[tuple[int, ...]] = [prev, cur]
    gear_idx: list[int] = []
    gear_val: list[int] = []
    ri = 0
    mu_l_all = np.maximum(mu_a, 1)
    for s0, e0 in zip(vs.tolist(), ve.tolist()):
        # resets strictly before this block's end (a run cannot overlap a valid block)
        if ri < r0.size and r0[ri] < e0:
            first = int(r0[ri])          # the first reset changes the state; later ones keep it
            while ri < r0.size and r0[ri] < e0:
                gear_idx.append(int(r0[ri]))
                gear_val.append(0)
                ri += 1
            cur = IDENTITY
            cur_eff = first + 1
            ch_idx.append(cur_eff)
            ch_state.append(cur)
            gear = 0
        oa, ob, ga, gb, kp = (v >> FRAC for v in cur)
        a1 = a16[s0:e0] - oa
        b1 = b16[s0:e0] - ob
        ac = (a1 * ga + 32768) >> 16
        bc = (b1 * gb + a1 * kp + 32768) >> 16
        if cur_eff > s0:   # the first sample still used the previous state
            poa, pob, pga, pgb, pkp = (v >> FRAC for v in prev)
            pa1, pb1 = int(a16[s0]) - poa, int(b16[s0]) - pob
            ac[0] = (pa1 * pga + 32768) >> 16
            bc[0] = (pb1 * pgb + pa1 * pkp + 32768) >> 16
        nn = e0 - s0
        gear = min(gear + 1, GEAR_MAX)
        mu_e = min(int(mu_l_all[e0]), gear.bit_length() - 1)
        s_n = (nn.bit_length() - 1) + ((nn >> (nn.bit_length() - 2)) & 1)
        sh = s_n + mu_e
        sa_, sb_ = int(ac.sum()), int(bc.sum())
        ua, ub = int(np.abs(ac).sum()), int(np.abs(bc).sum())
        xx = int((ac * bc).sum())
        d = ((sa_ << 10) >> sh, (sb_ << 10) >> sh, ((T16 * nn - 16 * ua) << 10) >> sh,
             ((T16 * nn - 16 * ub) << 10) >> sh, -((xx << 5) >> sh))
        prev = cur
        cur = tuple(min(max(c + dd, lw), hg) for c, dd, lw, hg in zip(cur, d, lo, hi))
        cur_eff = e0 + 1
        ch_idx.append(cur_eff)
        ch_state.append(cur)
        gear_idx.append(e0)
        gear_val.append(gear)
    # the carry: the open block from the last crossing on (dropped if already too long)
    s_new = int(xi[-1]) if xi.size and n - int(xi[-1]) < (1 << cal.nlog) else n
    # resets after the last update: those before the open block are in the carried state
    for j, rr in enumerate(r0[ri:].tolist()):
        ch_idx.append(rr + 1)
        ch_state.append(IDENTITY)
        gear_idx.append(rr)
        gear_val.append(0)
        if rr < s_new:
            if j == 0:
                cur, cur_eff = IDENTITY, rr + 1
            gear = 0
    if s_new == 0:
        dec_new = st.dec
    else:
        _, _, _, _, dec_new = decode(a[:s_new], b[:s_new], st.dec)
    carry = CalState(tail_a=a[s_new:].copy(), tail_b=b[s_new:].copy(), tail_en=en_a[s_new:].copy(),
                     tail_fr=fr_a[s_new:].copy(), tail_mu=mu_a[s_new:].copy(), dec=dec_new,
                     cur=cur, prev=prev, cur_eff=max(cur_eff - s_new, -(1 << 62)), gear=gear,
                     updates=st.updates + ve.size,
                     off_prev=bool(off[s_new - 1]) if s_new else st.off_prev)

    idx = np.asarray(ch_idx, dtype=np.int64)
    stt = np.array(ch_state, dtype=np.int64)
    k = np.arange(nt, n)
    state = stt[np.searchsorted(idx, k, side="right") - 1].T             # used by sample k
    state_after = stt[np.searchsorted(idx - 1, k, side="right") - 1].T   # after sample k
    ac, bc = correct(a[nt:], b[nt:], state)
    ac = np.where(en_a[nt:], ac, 4 * a[nt:])
    bc = np.where(en_a[nt:], bc, 4 * b[nt:])

    gi = np.asarray(gear_idx, dtype=np.int64)
    gv = np.asarray(gear_val, dtype=np.int64)
    g_ev = np.zeros(n, dtype=bool)
    g_ev[gi] = True
    gval = np.zeros(n, dtype=np.int64)
    gval[gi] = gv
    last = np.maximum.accumulate(np.where(g_ev, np.arange(n), -1))
    gear_arr = np.where(last >= 0, gval[np.maximum(last, 0)], st.gear)[nt:]
    upd = np.zeros(n, dtype=np.int64)
    upd[ve] = 1
    updates = (st.updates + np.cumsum(upd)[nt:]) & 0xFFFF
    return CalOut(ac=ac, bc=bc, state=state, state_after=state_after, gear=gear_arr,
                  updates=updates, ends=ve[ve >= nt] - nt, carry=carry)


def applied(state: np.ndarray) -> np.ndarray:
    """The applied coefficients (OA, OB, GA, GB, KP) of internal states (5, ...)."""
    return np.asarray(state) >> FRAC


# ----------------------------------------------------------------------------------------------
# Stimuli for the calibration's tests and benchmark (paper-like front end, seeded)


def paper_truth(n: int, rev_s: float = 37.3, start: float = 0.37) -> np.ndarray:
    """Constant speed, not commensurate with the sampling (the bench's accuracy runs)."""
    return constant(rev_s, n, start=start)


def mixed_motion(n: int, seed: int = 1) -> np.ndarray:
    """True position in lines: ramps, reversals through zero speed, standstill, fast runs."""
    rng = np.random.default_rng(seed)
    k = np.arange(n) / SAMPLE_HZ
    # speed (rev/s): a slow random walk of segments between -200 and 200 plus stops
    seg = max(1, n // 40)
    levels = rng.uniform(-200.0, 200.0, n // seg + 2)
    levels[rng.random(levels.size) < 0.2] = 0.0
    ramp = np.interp(np.arange(n), np.arange(levels.size) * seg, levels)
    wob = 30.0 * np.sin(2 * np.pi * 150.0 * k)
    v = ramp + wob * (ramp != 0)
    return 0.3 + np.cumsum(v) * LINES / SAMPLE_HZ


def disturbed_codes(x: np.ndarray, seed: int = 3, period: int = 250_000
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Paper-like codes for truth x with, every `period` samples, a noise burst (sigma 6 LSB,
    3000 samples), an over-range burst (amplitude x 1.35, clipping, 4000 samples) and a dropout
    (A = B = 0, 400 samples). Returns a, b and the mask of clean samples (outside bursts and
    within them the 20000 samples that follow, where the error is allowed to recover)."""
    n = x.size
    spec = with_spec(PAPER_LIKE, seed=seed)
    a, b = adc_codes(x, spec)
    rng = np.random.default_rng(seed + 1)
    clean = np.ones(n, dtype=bool)
    for p0 in range(period // 2, n - 30_000, period):
        nb = slice(p0, p0 + 3000)
        na, nb_ = adc_codes(x[nb], with_spec(spec, noise_lsb=6.0, seed=int(rng.integers(1 << 30))))
        a[nb], b[nb] = na, nb_
        cb = slice(p0 + 8000, p0 + 12_000)
        ca, cbb = adc_codes(x[cb], with_spec(spec, amplitude=spec.amplitude * 1.35))
        a[cb], b[cb] = ca, cbb
        d = slice(p0 + 16_000, p0 + 16_400)
        a[d], b[d] = 0, 0
        clean[p0:p0 + 16_400 + 20_000] = False
    return a, b, clean
