"""The SoC's float unit (rtl/soc/hg_fpu_cfu.v) bit for bit against IEEE-754 single precision.

The golden model is numpy's float32 arithmetic (IEEE-754 binary32, round to nearest even, with
subnormals: SSE on the host, checked below to be without flush-to-zero), with every NaN result
replaced by the RISC-V canonical NaN 0x7FC00000, which is what libgcc's soft float returns on
RV32 (libgcc/config/riscv/sfp-machine.h: _FP_KEEPNANFRACP 0, _FP_NANSIGN_S 0; the firmware's
own check against libgcc on the simulated SoC is tb/soc/test_soc_fpu.py). The unit runs alone
in Verilator behind its custom-function port, paced at random as the CPU may pace it:
millions of operand pairs, random bit patterns and operands built to hit the hard cases
(cancellation, ties, subnormal and overflowing results), and every pair of a list of corner
values (signed zeros, subnormals, the normal range's ends, infinities, quiet and signalling
NaNs of both signs).
"""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.runners import soc

F_ADD, F_SUB, F_MUL, F_DIV = 0, 1, 2, 3      # funct3 of the CUSTOM_0 instruction (funct7 0)
QNAN = 0x7FC0_0000                           # libgcc's NaN on RISC-V
N_RANDOM = 300_000                           # random operand pairs per function and family
# clocks from a command's acceptance to its response (rtl/soc/README.md, the float unit)
LATENCY = {F_ADD: 4, F_SUB: 4, F_MUL: 5, F_DIV: 31}
LATENCY_SPECIAL = 1                          # a NaN, infinite or zero operand

CORNERS = np.array([
    0x0000_0000, 0x8000_0000,                # +0, -0
    0x0000_0001, 0x8000_0001, 0x0000_0002, 0x0000_0003,   # the smallest subnormals
    0x0040_0000, 0x007F_FFFF, 0x807F_FFFF, 0x0055_5555,   # subnormals
    0x0080_0000, 0x8080_0000, 0x0080_0001, 0x00FF_FFFF, 0x0100_0000,   # the smallest normals
    0x3F80_0000, 0xBF80_0000, 0x3F80_0001, 0x3F7F_FFFF, 0x3FC0_0000, 0x4040_0000,
    0x3EAA_AAAB, 0x4000_0000, 0x3400_0000, 0x3380_0000, 0x3300_0000,  # 1, 1.5, 3, 1/3, 2**-23..
    0x4B00_0000, 0x4B80_0000, 0x4B7F_FFFF,   # 2**23, 2**24
    0x1F80_0000, 0x5F80_0000, 0x2000_0000, 0x5E80_0000,   # 2**-64, 2**64, products at the ends
    0x7F7F_FFFF, 0xFF7F_FFFF, 0x7F00_0000, 0x7E80_0000, 0x7F7F_FFFE,   # the largest finite
    0x7F80_0000, 0xFF80_0000,                # +inf, -inf
    0x7FC0_0000, 0xFFC0_0000, 0x7F80_0001, 0xFF80_0001, 0x7FBF_FFFF, 0xFFFF_FFFF,   # NaNs
], dtype=np.uint32)


def golden(fid: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The IEEE-754 result bits of each function (numpy float32), NaNs made libgcc's."""
    fa, fb = a.view(np.float32), b.view(np.float32)
    with np.errstate(all="ignore"):
        r = np.select([fid == F_ADD, fid == F_SUB, fid == F_MUL, fid == F_DIV],
                      [fa + fb, fa - fb, fa * fb, fa / fb]).astype(np.float32)
    bits = r.view(np.uint32).copy()
    bits[np.isnan(r)] = QNAN
    return bits


def _pack(sign: np.ndarray, exp: np.ndarray, frac: np.ndarray) -> np.ndarray:
    return ((sign.astype(np.uint32) << 31) | (exp.astype(np.uint32) << 23)
            | frac.astype(np.uint32)).astype(np.uint32)


def operands(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(function id, rs1, rs2) of every test command."""
    rng = np.random.default_rng(seed)
    n = N_RANDOM
    fids, aa, bb = [], [], []

    def add(f: int, a: np.ndarray, b: np.ndarray) -> None:
        fids.append(np.full(len(a), f, np.uint32))
        aa.append(a.astype(np.uint32))
        bb.append(b.astype(np.uint32))

    def sign() -> np.ndarray:
        return rng.integers(0, 2, n)

    def frac() -> np.ndarray:
        return rng.integers(0, 1 << 23, n)

    # every pair of corner values, every function
    ca, cb = np.meshgrid(CORNERS, CORNERS)
    for f in (F_ADD, F_SUB, F_MUL, F_DIV):
        add(f, ca.ravel(), cb.ravel())
        # uniform bit patterns (NaNs, infinities and subnormals at their share)
        add(f, rng.integers(0, 1 << 32, n, dtype=np.uint32),
            rng.integers(0, 1 << 32, n, dtype=np.uint32))
        # subnormal operands: one or both, against any exponent
        sub = _pack(sign(), np.zeros(n), frac())
        anyx = _pack(sign(), rng.integers(0, 255, n), frac())
        pick = rng.integers(0, 3, n)
        add(f, np.where(pick == 1, anyx, sub), np.where(pick == 2, anyx, sub))
    # add and subtract: exponents close (alignment, cancellation), nearly equal magnitudes of
    # either sign (massive cancellation, exact zeros), and ties (the smaller exactly half an ulp
    # of the larger, or 1.5 of it)
    for f in (F_ADD, F_SUB):
        ea = rng.integers(0, 255, n)
        eb = np.clip(ea + rng.integers(-30, 31, n), 0, 254)
        add(f, _pack(sign(), ea, frac()), _pack(sign(), eb, frac()))
        a = _pack(sign(), rng.integers(0, 255, n), frac())
        near = (a & 0x7FFF_FFFF).astype(np.int64) + rng.integers(-4, 5, n)
        b = np.clip(near, 0, 0x7F7F_FFFF).astype(np.uint32) | (sign().astype(np.uint32) << 31)
        add(f, a, b)
        ea = rng.integers(25, 255, n)
        half = _pack(sign(), ea - 24, rng.choice([0, 1 << 22, 1], n))
        add(f, _pack(sign(), ea, frac()), half)
    # multiply and divide: results around the subnormal range and around overflow (the
    # result's exponent field before normalisation: ea + eb - 127, ea - eb + 127)
    for f in (F_MUL, F_DIV):
        for target in (0, 254):
            ea = rng.integers(1, 255, n)
            want = target + rng.integers(-30, 31, n)
            eb = want - ea + 127 if f == F_MUL else ea + 127 - want
            ok = (eb >= 0) & (eb <= 254)
            add(f, _pack(sign(), ea, frac())[ok], _pack(sign(), eb, frac())[ok])
    # the ids of no function: answered with 0
    add(7, CORNERS, CORNERS)
    fids.append(np.array([0x3FF, 0x008, 0x00C], np.uint32))   # funct7 != 0
    aa.append(np.full(3, 0x3F80_0000, np.uint32))
    bb.append(np.full(3, 0x3F80_0000, np.uint32))
    return np.concatenate(fids), np.concatenate(aa), np.concatenate(bb)


def test_numpy_is_ieee_with_subnormals() -> None:
    """The golden model itself: no flush-to-zero, no denormals-are-zero, ties to even."""
    tiny = np.array([0x0000_0001, 0x0080_0000], np.uint32).view(np.float32)
    assert (tiny[1] / np.float32(2)).view(np.uint32) == 0x0040_0000
    assert (tiny[0] * np.float32(3)).view(np.uint32) == 3
    assert (tiny[0] / np.float32(2)).view(np.uint32) == 0             # a tie: to even (0)
    assert (np.float32(1) + np.float32(2.0 ** -24)).view(np.uint32) == 0x3F80_0000
    assert (np.float32(1 + 2.0 ** -23) + np.float32(2.0 ** -24)).view(np.uint32) == 0x3F80_0002


@pytest.fixture(scope="module")
def cases() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return operands(2024)


@pytest.fixture(scope="module")
def fpu_run(cases, tmp_path_factory: pytest.TempPathFactory) -> soc.FpuRun:
    fid, a, b = cases
    return soc.run_fpu(fid, a, b, tmp_path_factory.mktemp("fpu"), seed=7, stall=True)


def test_fpu_is_ieee_exact(cases, fpu_run: soc.FpuRun) -> None:
    """Every result word equals IEEE-754's (NaNs: 0x7FC00000); unknown ids answer 0."""
    fid, a, b = cases
    want = np.where(fid <= F_DIV, golden(fid, a, b), 0).astype(np.uint32)
    got = fpu_run.result
    assert fpu_run.summary["commands"] == fpu_run.summary["responses"] == len(fid)
    assert fpu_run.summary["protocol_errors"] == 0
    bad = np.flatnonzero(got != want)
    msg = "\n".join(f"f{fid[i]} {a[i]:08x} {b[i]:08x}: got {got[i]:08x} want {want[i]:08x}"
                    for i in bad[:20])
    assert bad.size == 0, f"{bad.size} of {len(fid)} differ:\n{msg}"
    # the hard cases were there
    fa, fb, r = a.view(np.float32), b.view(np.float32), want.view(np.float32)
    finite = np.isfinite(fa) & np.isfinite(fb) & (fid <= F_DIV)
    sub_out = finite & (want & 0x7F80_0000 == 0) & (want & 0x007F_FFFF != 0)
    ovf = finite & np.isinf(r)
    zero_sum = finite & (fid <= F_SUB) & (fa != 0) & (r == 0)
    counts = {"subnormal results": int(sub_out.sum()), "overflows": int(ovf.sum()),
              "exact zero sums": int(zero_sum.sum()), "NaN results": int((want == QNAN).sum())}
    assert all(v >= 1000 for v in counts.values()), counts
    print(f"\nfloat unit: {len(fid)} commands bit-exact ({counts})")


def test_fpu_latency(cases, fpu_run: soc.FpuRun) -> None:
    """Clocks from acceptance to response: the datapath's per function, 1 for a special
    operand (the CPU's memory stage waits that long; rtl/soc/README.md)."""
    fid, a, b = cases
    lat = fpu_run.latency
    fa, fb = a.view(np.float32), b.view(np.float32)
    special = ~np.isfinite(fa) | ~np.isfinite(fb) | (fa == 0) | (fb == 0)
    for f, clocks in LATENCY.items():
        on = fid == f
        assert set(np.unique(lat[on & ~special])) == {clocks}, f
        # add and subtract: an infinite or NaN operand is special, a zero is not
        spec = on & (~np.isfinite(fa) | ~np.isfinite(fb)) if f <= F_SUB else on & special
        assert set(np.unique(lat[spec])) == {LATENCY_SPECIAL}, f
    assert set(np.unique(lat[fid > F_DIV])) == {LATENCY_SPECIAL}
