"""The interpolator's arcsine table (rtl/interp/README.md, algorithm step 3), checked so that a
table generated wrong cannot pass: the model and the RTL read the same generated table, so
bit-exactness cannot see a wrong entry; only these checks can.

1. Entry by entry against its float definition, written here from the document (not by calling
   the generator): T[m] = min(2^L - 1, round(asin(min(m, 127)/127) * 2^L / 45deg)), m = 0..128,
   for every LUT_BITS the RTL accepts, on the generator's array and on the hex file the RTL reads.
2. A truth check whose budget a single wrong entry breaks, on the model AND on the RTL (native
   Verilator): a slow sweep of a whole line with ideal R = 127 signals, where every sample's
   error against the float angle must lie inside its own bound (the ADC level's angle interval,
   plus the half code of the table's rounding); and, for the 38 entries m = 91..128 that R = 127
   signals never address (the saturated ones), over-range amplitudes on the 45deg diagonal of
   every quadrant, where the estimate must stay within one code of 45deg.
3. The self-test: every entry corrupted by one code, each alone, must break check 2.
"""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.base import tables
from hapgate.golden import interp
from hapgate.runners import native

R = 127                     # the amplitude the table assumes (README: R_NOM)
L = 7                       # the default LUT_BITS
CFG = interp.InterpConfig()
SWEEP = 1 << 20             # samples for one line: ~1000 per code (entry 85 is 0.002 code
                            # from a rounding tie: its error shows only that close to a level edge)
EPS = 1e-6                  # code: float rounding (a saturated entry meets its bound exactly)
DIAG_FIRST = 91             # R = 127 signals never make the smaller channel exceed 127 sin 45deg


def definition(lut_bits: int) -> np.ndarray:
    """The table as rtl/interp/README.md defines it (float arcsine, rounded, saturated)."""
    m = np.arange(129, dtype=np.float64)
    codes = np.rint(np.degrees(np.arcsin(np.minimum(m, R) / R)) * (1 << lut_bits) / 45.0)
    return np.minimum(codes, (1 << lut_bits) - 1).astype(np.int64)


def adc(x: np.ndarray, amp: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Ideal rounding 8-bit ADC of A = R sin(phi), B = R cos(phi), phi = 2 pi x (x in lines)."""
    phi = 2 * np.pi * x
    a = np.clip(np.floor(amp * np.sin(phi) + 0.5), -128, 127).astype(np.int8)
    b = np.clip(np.floor(amp * np.cos(phi) + 0.5), -128, 127).astype(np.int8)
    return a, b


def sweep(lut_bits: int = L) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One whole line, slowly, not commensurate with the ADC levels: (a, b, truth in lines)."""
    x = 0.0123 + np.arange(SWEEP) * (1.0 / SWEEP)
    a, b = adc(x, R)
    return a, b, x


def sample_excess(err: np.ndarray, truth_counts: np.ndarray, level: np.ndarray,
                  lut_bits: int = L) -> np.ndarray:
    """Per sample, how far the error (position - truth, counts) lies outside what a correct
    table allows (<= 0: inside).

    `level` = min(|a|, |b|), the ADC level the table is addressed with. The channel it belongs
    to is at the true angle psi from its zero: psi = theta (then error = entry - S psi) or
    psi = 90deg - theta (the mirror: error = S psi - entry), theta = the true angle in the
    quadrant; on a tie of the two codes, either. That level lies within R sin(psi) +- 1/2, so the
    table's float value x(m) = S asin(m/R) lies between x(R sin psi - 1/2) and
    x(R sin psi + 1/2); the entry is that rounded (+- 1/2 code), saturated at 2^L - 1.
    S = codes per radian."""
    s = (1 << lut_bits) / (np.pi / 4)
    quad = 2 << lut_bits                      # counts per quadrant
    th = np.mod(truth_counts, quad)
    top = (1 << lut_bits) - 1

    def x(lv: np.ndarray) -> np.ndarray:
        return s * np.arcsin(np.clip(lv / R, 0.0, 1.0))

    excess = np.full(th.shape, np.inf)
    for psi_counts, e in ((th, err), (quad - th, -err)):
        psi = psi_counts / s                  # radians
        lvl = R * np.sin(psi)
        fits = np.abs(level - lvl) <= 0.5 + 1e-9
        hi = np.minimum(x(lvl + 0.5) + 0.5, top) - psi_counts
        lo = np.minimum(x(lvl - 0.5) - 0.5, top) - psi_counts
        excess = np.where(fits, np.minimum(excess, np.maximum(lo - e, e - hi)), excess)
    return excess


def level(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.minimum(np.abs(a.astype(np.int16)), np.abs(b.astype(np.int16)))


def sweep_excess(pos: np.ndarray, a: np.ndarray, b: np.ndarray, x: np.ndarray,
                 lut_bits: int = L) -> np.ndarray:
    """Per sample, the error outside its bound (> 0: a violation)."""
    cpl = 8 << lut_bits
    err = interp.truth_counts_error(pos, x * cpl)
    return sample_excess(err, x * cpl, level(a, b), lut_bits)


def diagonal() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 45deg point of each quadrant in turn (reached by a slow turn at R = 100), and on each
    an amplitude ramp 100 -> 182 -> 100: the smaller channel takes every level 91..127 (and 128
    where both channels are negative)."""
    turn = np.linspace(0.0, 0.25, 2001)[1:]
    ramp = np.concatenate([np.linspace(100, 182, 1500), np.linspace(182, 100, 1500)])
    xs, amps = [np.full(200, 0.125)], [np.full(200, 100.0)]
    for q in range(4):
        xs += [np.full(ramp.size, 0.125 + 0.25 * q)]
        amps += [ramp]
        if q < 3:
            xs += [0.125 + 0.25 * q + turn]
            amps += [np.full(turn.size, 100.0)]
    x = np.concatenate(xs)
    a, b = adc(x, np.concatenate(amps))
    return a, b, x


def diagonal_excess(pos: np.ndarray, a: np.ndarray, b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """On the samples that address a saturated entry (both channels >= 91): |error| - 1 code."""
    m = np.minimum(np.abs(a.astype(np.int16)), np.abs(b.astype(np.int16)))
    sel = m >= DIAG_FIRST
    err = interp.truth_counts_error(pos, x * CFG.counts_per_line)
    return np.abs(err[sel]) - 1.0


@pytest.mark.parametrize("lut_bits", range(2, 11))
def test_entries_match_definition(lut_bits: int, tmp_path) -> None:
    cfg = interp.InterpConfig(lut_bits=lut_bits)
    want = definition(lut_bits)
    got = interp.asin_table(cfg)
    bad = np.flatnonzero(got != want)
    assert bad.size == 0, \
        f"L={lut_bits}: entry {bad[0]} is {got[bad[0]]}, definition {want[bad[0]]}"
    on_file = tables.read_hex(interp.write_lut(cfg, tmp_path), lut_bits)
    assert np.array_equal(on_file, want), "the RTL's hex file differs from the definition"


def test_definition_has_no_near_ties() -> None:
    """Why check 2 can see every +-1 error: no unsaturated entry sits within 0.02 code of a
    rounding tie by more than the sweep's step (2^-20 line = 0.001 code): the closest, entry 85,
    is 0.0019 code from it, so a wrong entry is off its float value by >= 0.5019 code."""
    m = np.arange(0, 90)
    val = np.degrees(np.arcsin(m / R)) * (1 << L) / 45.0
    gap = np.abs(np.abs(val - np.rint(val)) - 0.5)
    assert gap.min() > 1.5 * (8 << L) / SWEEP, (int(np.argmin(gap)), gap.min())


def test_sweep_reaches_every_entry_r127_can() -> None:
    a, b, _ = sweep()
    m = np.unique(np.minimum(np.abs(a.astype(np.int16)), np.abs(b.astype(np.int16))))
    assert np.array_equal(m, np.arange(DIAG_FIRST))
    a, b, _ = diagonal()
    m = np.minimum(np.abs(a.astype(np.int16)), np.abs(b.astype(np.int16)))
    assert np.array_equal(np.unique(m[m >= DIAG_FIRST]), np.arange(DIAG_FIRST, 129))


@pytest.mark.parametrize("engine", ["model", "rtl"])
def test_truth_per_sample_bound(engine: str) -> None:
    """Every sample of the slow sweep within its bound, and every over-range diagonal sample
    within one code of 45deg, on the engine's own positions."""
    results = []
    for a, b, x in (sweep(), diagonal()):
        if engine == "model":
            pos = interp.run(a, b, None, CFG).pos
        else:
            pos = native.run_interp(a, b, None, CFG, columns=["pos"]).axis(0)["pos"]
        results.append((pos, a, b, x))
    (p1, a1, b1, x1), (p2, a2, b2, x2) = results
    ex = sweep_excess(p1, a1, b1, x1)
    worst = int(np.argmax(ex))
    print(f"{engine}: sweep worst margin {-ex.max():.4f} code (sample {worst}); "
          f"diagonal worst |err| {diagonal_excess(p2, a2, b2, x2).max() + 1:.3f} code")
    assert ex.max() <= EPS, f"sample {worst}: error exceeds its bound by {ex[worst]:.4f} code"
    assert diagonal_excess(p2, a2, b2, x2).max() <= EPS


def test_every_single_wrong_entry_is_caught() -> None:
    """A table generated wrong is identical in RTL and model, so only the truth check sees it:
    each entry alone +1 and -1 (where the 7-bit word allows), and check 2 must fail. (To keep
    this short, each corrupted model runs on the sweep's samples that address the entry: between
    two of them the shaft moves at most one quadrant, so the counter follows; and on the whole
    diagonal run for the saturated entries.)"""
    good = definition(L)
    a1, b1, x1 = sweep()
    a2, b2, x2 = diagonal()
    lv = level(a1, b1)
    missed, tried = [], 0
    for m in range(129):
        sel = lv == m
        for delta in (+1, -1):
            t = good.copy()
            t[m] += delta
            if not 0 <= t[m] < 1 << L:
                continue
            tried += 1
            if m < DIAG_FIRST:
                caught = sweep_excess(interp.run(a1[sel], b1[sel], None, CFG, table=t).pos,
                                      a1[sel], b1[sel], x1[sel]).max() > EPS
            else:
                caught = diagonal_excess(interp.run(a2, b2, None, CFG, table=t).pos,
                                         a2, b2, x2).max() > EPS
            if not caught:
                missed.append((m, delta))
    assert tried == 2 * 129 - 1 - 40      # T[0] = 0 cannot go down, the 40 entries at 127 up
    assert not missed, f"wrong entries that pass the truth check: {missed}"
    # and the uncorrupted table passes the same reduced check
    for m in (0, 45, 85, 90):
        sel = lv == m
        pos = interp.run(a1[sel], b1[sel], None, CFG, table=good).pos
        assert sweep_excess(pos, a1[sel], b1[sel], x1[sel]).max() <= EPS
