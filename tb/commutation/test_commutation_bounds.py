"""The commutator's documented numbers at their boundaries (issue 29, "Boundaries"): the sine
ROM's full scale at +-1, ties in the DAC code's rounding and the torque clamp in both directions.
Every expected code is computed here from the spec's own formulas and numbers (never from the
model): one native Verilator run of the commutator (tb/native/commutation/, 48 MHz, the default
build) carries all the cases, the bit-exact model gets the same frames, and both must equal the
spec, so model and RTL moving together still fail.

Spec (docs/blocks/sine-rom.md, docs/blocks/commutator.md):
- ROM entry i = round(FS sin((i + 1/2) 90 deg / 256)), FS = 8191; code k of a 1024-code cycle
  unfolds to T[i], T[255 - i], -T[i], -T[255 - i] in quadrants 0..3 (i = k mod 256);
- channel a = code + offset, channel b = a's code - 341 (step 3), the electrical angle code
  bits 18..9 of the position with two pole pairs (step 1);
- x torque (signed 16, clamped to +-min(limit, 32768)), round half away from zero of v t / 2^15,
  saturate symmetrically to +-8191 ("32767 at sin = 1 gives 8191; -32768 x -8191 gives +8191");
- rtl/regs/hapgate.rdl TQ_LIMIT: "|torque| clamp in command units (0: no torque; >= 32768: no
  clamp)"."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hapgate.golden import commutation as cm
from hapgate.runners import native_comm

FS = 8191                    # sine-rom.md: FS = 8191 for a 14-bit bipolar DAC
ENTRIES = 256                # sine-rom.md: N = 256
PHASE_B = 341                # commutator.md step 3
MAX_CODE = 8191              # commutator.md step 5: saturate to +-8191
NO_LIMIT = 65535             # TQ_LIMIT >= 32768: no clamp


def rom(i: int) -> int:
    """sine-rom.md: round(FS sin((i + 1/2) 90 deg / 256)) (a positive value: round half up)."""
    return int(np.floor(FS * np.sin((i + 0.5) * (np.pi / 2) / ENTRIES) + 0.5))


def rom_value(k: int) -> int:
    q, i = (k % 1024) >> 8, k & 255
    return [rom(i), rom(255 - i), -rom(i), -rom(255 - i)][q]


def rha(num: int, den: int) -> int:
    """Round half away from zero of num / den, exactly."""
    x = Fraction(num, den)
    m = int(abs(x) + Fraction(1, 2))
    return m if x >= 0 else -m


def spec_code(k: int, torque: int, limit: int) -> int:
    lim = min(limit, 32768)
    t = max(-lim, min(lim, torque))
    return max(-MAX_CODE, min(MAX_CODE, rha(rom_value(k) * t, 1 << 15)))


def cases() -> list[tuple[str, int, int, int]]:
    """(what, angle code of channel a, torque, limit); each becomes one motor of one frame."""
    out = []
    # full scale at +-1: the two codes either side of 90 and 270 deg (sin = +-1 between them)
    # and one more each way; +-32767 and -32768 (no limit)
    for k in (253, 254, 255, 256, 257, 258, 765, 766, 767, 768, 769, 770):
        for t in (32767, -32767, -32768, 32766):
            out.append((f"full scale k={k} t={t}", k, t, NO_LIMIT))
    # ties: T[k] odd and t = +-16384 make v t / 2^15 exactly half an integer; t +-1 either side
    for k in (0, 255, 256, 511, 512, 1023):
        for t in (16383, 16384, 16385, -16383, -16384, -16385):
            out.append((f"tie k={k} t={t}", k, t, NO_LIMIT))
    # torque clamp: limits where one command unit changes the code, at L - 1, L, L + 1 and the
    # same negative, plus a command far past the limit either way
    for lim in clamp_limits():
        for t in (lim - 1, lim, lim + 1, -(lim - 1), -lim, -(lim + 1), 32767, -32768):
            out.append((f"clamp L={lim} t={t}", 255, t, lim))
    for lim, t in ((0, 32767), (0, -32768), (2, 32767), (3, 32767), (3, -32768),
                   (32767, -32768), (32768, -32768), (32769, -32768), (65535, 32767)):
        out.append((f"limit {lim} t={t}", 255, t, lim))
    return out


def clamp_limits() -> list[int]:
    """At code 255 (v = T[255]): the first limit >= 10000 where L - 1 and L give different codes
    (a clamp at L - 1 shows), and the first where L and L + 1 do (a clamp at L + 1 shows)."""
    v = rom_value(255)
    below = next(L for L in range(10_000, 32_000) if rha(v * (L - 1), 32768) != rha(v * L, 32768))
    above = next(L for L in range(10_000, 32_000) if rha(v * L, 32768) != rha(v * (L + 1), 32768))
    return [below, above]


def test_sine_full_scale_rounding_ties_and_torque_clamp_model_and_rtl() -> None:
    cfg = cm.CommutationConfig()                  # the default: 48 MHz, 256 entries, 2 pole pairs
    # one limit per frame (the commutator's LIMITS = 1): three cases of the same limit a frame
    rows: list[list[tuple[str, int, int, int]]] = []
    for lim in dict.fromkeys(c[3] for c in cases()):
        group = [c for c in cases() if c[3] == lim]
        group += [group[-1]] * (-len(group) % 3)
        rows += [group[i:i + 3] for i in range(0, len(group), 3)]
    ks = np.array([[c[1] for c in row] for row in rows])
    torque = np.array([[c[2] for c in row] for row in rows])
    limit = np.array([row[0][3] for row in rows])
    # position 0: electrical code 0, so channel a's code is the offset
    frames = cm.Frames.make(np.zeros_like(ks), torque, offset=ks, limit=limit)
    want = np.array([[spec_code(k, t, int(lim)), spec_code(k - PHASE_B, t, int(lim))]
                     for row, lim in zip(rows, limit) for (_, k, t, _) in row]).reshape(-1, 6)
    # the spec's own sentences, as literals
    assert rom(255) == 8191 and spec_code(255, 32767, NO_LIMIT) == 8191
    assert spec_code(767, -32768, NO_LIMIT) == 8191 and spec_code(255, -32768, NO_LIMIT) == -8191
    assert spec_code(0, 16384, NO_LIMIT) == 13 and spec_code(0, -16384, NO_LIMIT) == -13
    model = cm.commutate(frames, cfg)
    rtl = native_comm.run_commutation(frames, cfg)
    assert rtl.violations == 0
    for engine, got in (("model", model), ("rtl", rtl.codes)):
        bad = np.argwhere(got != want)
        if bad.size:
            r, ch = (int(x) for x in bad[0])
            what = rows[r][ch // 2][0]
            raise AssertionError(f"{engine}: {what}, channel {cm.CHANNELS[ch]}: code "
                                 f"{got[r, ch]}, spec {want[r, ch]}")
    # the cases reach what they claim: full scale both ways, exact ties, both clamps
    assert (want == MAX_CODE).any() and (want == -MAX_CODE).any()
    print(f"{len(rows)} frames, {want.size} codes, limits {clamp_limits()}: model and RTL "
          f"equal the spec")
