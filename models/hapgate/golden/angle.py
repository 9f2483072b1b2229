"""High-resolution angle stage of the interpolator: the bit-exact integer model of the ratio
path of rtl/interp/enc_interp.v (ANGLE = 1) and rtl/interp/ratio_div.v.

In the local frame of the sign-bit quadrant (step 2 of hapgate.golden.interp) the two
magnitudes are y = sin and x = cos of the local angle theta; the paper reads theta from the
arcsine of the smaller one alone, which assumes the amplitude. The ratio stage divides the
amplitude out: with h = (y >= x), m = h ? x : y (smaller) and M = h ? y : x (larger),

    k = floor(m * 2^RB / M)             (RB = ratio_bits; k = 2^(RB+1) - 1 when M = 0)
    k' = min(k, 2^RB - 1)               (m = M: the last entry)
    T[k'] = round(atan((k' + 1/2) / 2^RB) * 2^(L+2) / 45deg)  k' = 0 .. 2^RB - 1, 0 .. 2^(L+2)
    f4 = h ? 2^(L+3) - T[k'] : T[k']    (the fine angle in 1/4 count)
    f = (f4 - [harmonic correction, below] + 2) >> 2

(L = lut_bits: 2^L codes per 45 deg, 8 * 2^L counts per line; the table is evaluated at the
middle of each ratio bin in quarter counts, L + 3 bits: T = 2^(L+2) is 45 deg; the quarter
counts are what the harmonic correction needs, and keep the RMS at the rounded-atan2 floor
after the final rounding). The divider is a restoring one,
one quotient bit per pipeline stage (RB + 1 stages); m <= M always, so only the first bit can be
the integer bit (m = M). The channels are the raw 8-bit codes or the calibrated 12-bit
quarter-LSB ones (hapgate.golden.enccal): the ratio does not care about the amplitude, so the
same table serves both.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..base.capture import CaptureError
from ..base.tables import write_hex

RATIO_BITS = 10     # default ratio table: 1024 entries (a 1024 x (L + 1) ROM: 2..3 SB_RAM40_4K)


def ratio_table(lut_bits: int, ratio_bits: int = RATIO_BITS) -> np.ndarray:
    """T[k] = round(atan((k + 1/2) / 2^RB) * 2^L / (pi / 4)), k = 0 .. 2^RB - 1."""
    k = np.arange(1 << ratio_bits, dtype=np.float64)
    t = np.arctan((k + 0.5) / (1 << ratio_bits)) * (1 << lut_bits) / (np.pi / 4)
    return np.floor(t + 0.5).astype(np.int64)


def ratio_name(lut_bits: int, ratio_bits: int = RATIO_BITS) -> str:
    return f"atan_l{lut_bits}_q{ratio_bits}"


def write_ratio_table(lut_bits: int, ratio_bits: int = RATIO_BITS,
                      directory: Path | None = None) -> Path:
    return write_hex(ratio_name(lut_bits, ratio_bits), ratio_table(lut_bits, ratio_bits),
                     lut_bits + 1, directory)


def ratio_code(m: np.ndarray, big: np.ndarray, ratio_bits: int = RATIO_BITS) -> np.ndarray:
    """The divider's quotient floor(m 2^RB / M) (m <= M), all ones (2^(RB+1) - 1) for M = 0."""
    m = np.asarray(m, dtype=np.int64)
    big = np.asarray(big, dtype=np.int64)
    q = (m << ratio_bits) // np.maximum(big, 1)
    return np.where(big > 0, q, (2 << ratio_bits) - 1)


def ratio_fine(small: np.ndarray, big: np.ndarray, half: np.ndarray, table: np.ndarray,
               lut_bits: int, ratio_bits: int = RATIO_BITS) -> np.ndarray:
    """Fine angle h ? 2^(lut_bits+1) - T[k'] : T[k'] of the ratio stage (called with the table
    and lut_bits of the quarter-count table, L + 2: the result is f4; see the docstring)."""
    k = np.minimum(ratio_code(small, big, ratio_bits), (1 << ratio_bits) - 1)
    t = table[k]
    return np.where(half, (2 << lut_bits) - t, t)


def latency(cal: bool = False, ratio: bool = False, angle_reg: bool = False,
            ratio_bits: int = RATIO_BITS, harm: bool = False) -> int:
    """Clocks from the s_valid cycle to the m_valid cycle of enc_interp."""
    return 5 + int(cal) + int(angle_reg) + ((ratio_bits + 1) if ratio else 0) + int(harm)


# ----------------------------------------------------------------------------------------------
# Harmonic correction (RTL HARM = 1, needs ANGLE = 1)
#
# The ratio table has HF = 2 fraction bits (it is the table of lut_bits + 2), the fine
# angle f_h = h ? 2^(L+1+HF) - T : T is in 1/4 count, and a table H of 2^HARM_LOG2 signed 8-bit
# entries (1/4 count) indexed by the top HARM_LOG2 bits of the angle within the line,
#     j = ((q << (L+1+HF)) + f_h) mod 2^(L+3+HF) >> (L+3+HF - HARM_LOG2),
# is subtracted before rounding back to counts:
#     f = (f_h - en H[j] + 2^(HF-1)) >> HF        (arithmetic shift; f may leave 0..2^(L+1))
# With en = 0 (or HARM = 0), f = round(f_h / 4) (half up): the plain ratio angle, bit for bit.
# The table is loaded through the write port (registers); `harmonic_fit` learns it from the
# positions of a constant-speed run with the correction off (no truth needed).

HARM_FRAC = 2
HARM_LOG2 = 6


def harm_index(q: np.ndarray, fine_h: np.ndarray, lut_bits: int,
               harm_log2: int = HARM_LOG2) -> np.ndarray:
    fh = lut_bits + 1 + HARM_FRAC
    lp = ((np.asarray(q, dtype=np.int64) << fh) + fine_h) & ((1 << (fh + 2)) - 1)
    return lp >> (fh + 2 - harm_log2)


def harm_correct(q: np.ndarray, fine_h: np.ndarray, en: np.ndarray | bool, table: np.ndarray,
                 lut_bits: int, harm_log2: int = HARM_LOG2) -> np.ndarray:
    """Fine angle in counts after the harmonic table (fine_h in 1/4 count)."""
    fine_h = np.asarray(fine_h, dtype=np.int64)
    tab = np.asarray(table, dtype=np.int64)
    if tab.size != 1 << harm_log2 or tab.min() < -128 or tab.max() > 127:
        raise ValueError(f"harmonic table: {1 << harm_log2} signed 8-bit entries")
    h = tab[harm_index(q, fine_h, lut_bits, harm_log2)]
    h = np.where(np.broadcast_to(np.asarray(en, dtype=bool), fine_h.shape), h, 0)
    return (fine_h - h + (1 << (HARM_FRAC - 1))) >> HARM_FRAC


def harmonic_fit(pos: np.ndarray, lut_bits: int, harm_log2: int = HARM_LOG2) -> np.ndarray:
    """Table for the harmonic correction from the positions of a run at constant speed with the
    correction off: the residual of a straight-line fit of position against sample number,
    averaged per bin of the angle within the line (binned by the position itself), in 1/4
    count, rounded, saturated to 8 bits. (A host or the DSP can do this from a logged run;
    the speed must be constant and the run many lines long so every bin is well averaged.)"""
    p = np.asarray(pos, dtype=np.float64)
    t = np.arange(p.size, dtype=np.float64)
    c1, c0 = np.polyfit(t, p, 1)
    r = p - (c0 + c1 * t)
    cpl = 8 << lut_bits
    j = (np.mod(np.asarray(pos, dtype=np.int64), cpl) << harm_log2) // cpl
    hn = 1 << harm_log2
    cnt = np.bincount(j, minlength=hn)
    if np.any(cnt == 0):
        raise ValueError("harmonic_fit: the run does not visit every bin of the line")
    mean = np.bincount(j, weights=r, minlength=hn) / cnt
    return np.clip(np.floor(mean * (1 << HARM_FRAC) + 0.5), -128, 127).astype(np.int64)


# ----------------------------------------------------------------------------------------------
# Harmonic table files: what `hapgate harm fit` writes and `replay interp --harm FILE` reads.
# $readmemh text: optional `//` comment lines, then one entry per line, two hex digits of the
# 8-bit two's complement (1/4 count): 2^harm_log2 lines. The firmware loads the same entries
# through HARM_ADDR / HARM_DATA (dsp-fw/include/hg_harm.h).

def harm_table_text(table: np.ndarray, note: str = "") -> str:
    t = np.asarray(table, dtype=np.int64)
    if t.ndim != 1 or t.size < 16 or t.size & (t.size - 1) or t.min() < -128 or t.max() > 127:
        raise ValueError("harmonic table: 2^N (N >= 4) signed 8-bit entries")
    head = "".join(f"// {line}\n" for line in note.splitlines())
    return head + "".join(f"{int(v) & 0xFF:02x}\n" for v in t)


def read_harm_table(path: Path, harm_log2: int = HARM_LOG2) -> np.ndarray:
    """The entries of a harmonic table file (signed); CaptureError naming FILE:LINE if the file
    is not 2^harm_log2 entries of two hex digits."""
    n = 1 << harm_log2
    try:
        text = Path(path).read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise CaptureError(f"{path}: cannot read the harmonic table ({exc})") from None
    vals: list[int] = []
    for k, raw in enumerate(text.splitlines(), 1):
        tok = raw.split("//", 1)[0].strip()
        if not tok:
            continue
        if len(tok) > 2 or any(c not in "0123456789abcdefABCDEF" for c in tok):
            raise CaptureError(f"{path}:{k}: {tok!r} is not an entry (two hex digits, the "
                               "8-bit two's complement of 1/4 counts, one per line)")
        if len(vals) == n:
            raise CaptureError(f"{path}:{k}: more than {n} entries (2^{harm_log2})")
        v = int(tok, 16)
        vals.append(v - 256 if v >= 128 else v)
    if len(vals) != n:
        raise CaptureError(f"{path}:{len(text.splitlines())}: {len(vals)} entries, the table "
                           f"has {n} (2^{harm_log2})")
    return np.array(vals, dtype=np.int64)
