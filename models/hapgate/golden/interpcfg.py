"""The interpolator's configuration and the pieces both its model (interp) and its calibration
stage (enccal) build on: the arcsine tables and the sign-bit decoder. (Kept apart so that
interp -> enccal -> interpcfg has no cycle.)"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..base.block import Params
from ..base.tables import TableFile
from .angle import HARM_FRAC, ratio_name, ratio_table
from .angle import latency as angle_latency


@dataclass(frozen=True)
class InterpConfig:
    lut_bits: int = 7          # arcsine LUT codes per 45deg = 2**lut_bits (5..9 swept by the bench)
    r_nom: int = 127           # amplitude the arcsine table assumes (ADC codes)
    vel_log2w: int = 8         # velocity window W = 2**vel_log2w samples
    amp_min: int = 40          # signal-loss window on sqrt(a^2 + b^2), ADC codes
    amp_max: int = 170
    loss_samples: int = 16     # consecutive out-of-window samples that raise signal loss
    lines: int = 1024          # encoder lines per revolution (for unit conversions only)
    invert: bool = False       # count the other way: A and B swapped at capture (90deg - phi)
    cal: bool = False          # build the online calibration stage (RTL CAL; hapgate.golden.enccal)
    cal_lines_log2: int = 3    # calibration block = 2**cal_lines_log2 lines (RTL CAL_LINES_LOG2)
    cal_nlog: int = 14         # calibration blocks of >= 2**cal_nlog samples are ignored
    coarse: bool = False       # plain quadrature: the fine angle zeroed (RTL COARSE), 4 steps/line
    ratio: bool = False        # fine angle atan(smaller / larger) (RTL ANGLE = 1; golden.angle)
    ratio_bits: int = 10       # ratio table 2**ratio_bits entries (RTL RATIO_BITS)
    angle_reg: bool = False    # register after the angle select (RTL ANGLE_REG): latency + 1
    harm: bool = False         # harmonic correction table (RTL HARM; needs ratio): latency + 1
    harm_log2: int = 6         # harmonic table 2**harm_log2 entries per line (RTL HARM_LOG2)
    vel_obs: bool = False      # build the tracking velocity observer (RTL VEL_OBS; golden.velobs)

    @property
    def fine_bits(self) -> int:
        """Bits of the fine angle within a quadrant (f ranges 0..2**fine_bits)."""
        return self.lut_bits + 1

    @property
    def counts_per_line(self) -> int:
        return 8 << self.lut_bits

    @property
    def counts_per_rev(self) -> int:
        return self.counts_per_line * self.lines

    @property
    def vel_store_bits(self) -> int:
        return self.lut_bits + self.vel_log2w + 4

    @property
    def lut_name(self) -> str:
        return f"asin_l{self.lut_bits}_r{self.r_nom}"

    @property
    def cal_lut_name(self) -> str:
        return f"asin512_l{self.lut_bits}_r{self.r_nom}"

    def rtl_params(self) -> Params:
        """Parameters of rtl/interp/enc_interp.v for this configuration. Pure: the tables are
        `TableFile`s, written by `base.tables.write_tables(params)` (the build step)."""
        p: Params = {"LUT_BITS": self.lut_bits, "VEL_LOG2W": self.vel_log2w,
                     "AMP_MIN": self.amp_min, "AMP_MAX": self.amp_max,
                     "LOSS_SAMPLES": self.loss_samples, "LUT_FILE": self.lut_file(),
                     "INVERT": int(self.invert)}
        if self.cal:
            p.update({"CAL": 1, "CAL_LUT_FILE": self.cal_lut_file(),
                      "CAL_LINES_LOG2": self.cal_lines_log2, "CAL_NLOG": self.cal_nlog})
        if self.coarse:
            p["COARSE"] = 1
        if self.ratio:
            lb = self.lut_bits + HARM_FRAC
            p.update({"ANGLE": 1, "RATIO_BITS": self.ratio_bits,
                      "RATIO_FILE": TableFile.of(ratio_name(lb, self.ratio_bits),
                                                 partial(ratio_table, lb, self.ratio_bits),
                                                 lb + 1)})
        if self.harm:
            p.update({"HARM": 1, "HARM_LOG2": self.harm_log2})
        if self.angle_reg:
            p["ANGLE_REG"] = 1
        if self.vel_obs:
            p["VEL_OBS"] = 1
        return p

    def lut_file(self) -> TableFile:
        """The arcsine table (asin_table), build/gen/<lut_name>.hex."""
        return TableFile.of(self.lut_name, partial(asin_table, self), self.lut_bits)

    def cal_lut_file(self) -> TableFile:
        """The calibrated path's 512-entry arcsine table (cal_table)."""
        return TableFile.of(self.cal_lut_name, partial(cal_table, self), self.lut_bits)

    @property
    def latency(self) -> int:
        """Clocks from the s_valid cycle to the m_valid cycle of enc_interp."""
        return angle_latency(self.cal, self.ratio, self.angle_reg, self.ratio_bits, self.harm)


TABLE_SIZE = 512              # calibrated arcsine table entries (address min(m, 511))


def asin_table(cfg: InterpConfig = InterpConfig()) -> np.ndarray:
    """Arcsine LUT, 129 entries for magnitudes 0..128 (entries above R_NOM saturate)."""
    m = np.minimum(np.arange(129, dtype=np.float64), cfg.r_nom) / cfg.r_nom
    codes = np.floor(np.arcsin(m) * (1 << cfg.lut_bits) / (np.pi / 4) + 0.5)
    return np.minimum(codes, (1 << cfg.lut_bits) - 1).astype(np.int64)


def cal_table(cfg: InterpConfig = InterpConfig()) -> np.ndarray:
    """Arcsine table of the calibrated path (hapgate.golden.enccal): 512 entries for the smaller
    corrected channel in quarter-LSB, T512[k] = min(2^L - 1, round(asin(min(k / 4, R) / R) *
    2^L / 45deg))."""
    k = np.minimum(np.arange(TABLE_SIZE, dtype=np.float64) / 4.0, cfg.r_nom) / cfg.r_nom
    codes = np.floor(np.arcsin(k) * (1 << cfg.lut_bits) / (np.pi / 4) + 0.5)
    return np.minimum(codes, (1 << cfg.lut_bits) - 1).astype(np.int64)


def sign_bits(v: np.ndarray, prev: bool = False) -> np.ndarray:
    """Sign of each sample with the zero code held: a 0 keeps the previous sample's sign
    (non-negative before the first non-zero sample; `prev`: the sign held from before this
    chunk). This gives the sign bit a hysteresis of
    +-1/2 LSB, so both zero crossings of a channel are decided at the same distance from the
    true zero and every quadrant is exactly 90 deg wide: the 1 MSPS sign decoder then tracks
    all the way to 244.14 rev/s, and standstill noise under 1/2 LSB never chatters the
    quadrant. (The position is the same either way when a channel is 0, see the docs.)"""
    v = np.asarray(v)
    neg = v < 0
    nz = np.flatnonzero(v != 0)
    if nz.size == v.size:
        return neg
    reps = np.diff(np.concatenate(([0], nz, [v.size])))
    return np.repeat(np.concatenate(([bool(prev)], neg[nz])), reps)


@dataclass(frozen=True)
class Decoder:
    """The sign-bit quadrant decoder's state between chunks: the held sign bits, the last
    quadrant (None before the first sample), the direction of the last single step (+1 before
    any) and the quadrant counter after the last sample."""
    sa: bool = False
    sb: bool = False
    q: int | None = None
    last_dir: int = 1
    qc: int = 0


def decode(a: np.ndarray, b: np.ndarray, dec: Decoder = Decoder()
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Decoder]:
    """Sign-bit quadrant decoder over a chunk: (q 0..3, step per sample in -2..2, the overspeed
    mask, the quadrant counter after each sample (int64, not wrapped), the state after the
    chunk). A two-quadrant step moves +-2 in the direction of the last single step before it
    (+2 before any). At the first sample of all the step is 0 and the counter starts at q."""
    sa = sign_bits(a, dec.sa)
    sb = sign_bits(b, dec.sb)
    q = ((sa.astype(np.int64) << 1) | (sa ^ sb)).astype(np.int64)
    n = q.size
    q_prev = int(q[0]) if dec.q is None else dec.q
    step = np.empty(n, dtype=np.int64)
    step[0] = (int(q[0]) - q_prev) & 3
    step[1:] = (q[1:] - q[:-1]) & 3
    step[step == 3] = -1
    ovs = step == 2
    single = np.flatnonzero((step == 1) | (step == -1))
    last_dir = int(step[single[-1]]) if single.size else dec.last_dir
    if ovs.any() and not single.size:       # (no single step yet: the carried direction)
        step[ovs] = 2 * dec.last_dir
    elif ovs.any():
        k = np.searchsorted(single, np.flatnonzero(ovs), side="left") - 1
        step[ovs] = 2 * np.where(k >= 0, step[single[np.maximum(k, 0)]], dec.last_dir)
    qc = np.cumsum(step) + (int(q[0]) if dec.q is None else dec.qc)
    return q, step, ovs, qc, Decoder(bool(sa[-1]), bool(sb[-1]), int(q[-1]), last_dir,
                                     int(qc[-1]))
