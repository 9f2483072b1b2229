"""The float unit against libgcc's soft float, on the simulated SoC itself.

The firmware's float arithmetic goes through libgcc's ABI (__addsf3, __subsf3, __mulsf3,
__divsf3) to the float unit (dsp-fw/board/riscv/fpu.c, rtl/soc/hg_fpu_cfu.v). That it gives the
bits libgcc's own routines give, NaNs, signed zeros and subnormals included, is checked where it
matters: a test image (tb/native/soc/fpu_check.c, built by hapgate.runners.soc.build_fpu_check)
links libgcc's four members under other names beside the board's functions, runs each operand
pair through both on the Verilated SoC (VexRiscv_FullCfu, its custom-function port, the unit)
and counts the differences: every pair of a list of corner values, then pseudo-random pairs of
four kinds. tb/soc/test_fpu_cfu.py checks the unit alone against IEEE-754 on millions of pairs.
"""

from __future__ import annotations

import pytest
from hapgate.runners import soc

RANDOM = 250               # pseudo-random pairs per kind (4 kinds) and operation
CORNERS = 46               # fpu_check.c's corner values: every ordered pair, every operation
CLOCKS = 6_000_000         # enough for every pair (about 4.3 million clocks)
OPS = ("add", "sub", "mul", "div")


@pytest.fixture(scope="module")
def check(tmp_path_factory: pytest.TempPathFactory) -> soc.SocRun:
    img = soc.build_fpu_check(random=RANDOM)
    return soc.run(img, CLOCKS, [], tmp_path_factory.mktemp("soc_fpu"),
                   symbols=soc.fpu_check_symbols())


def test_float_unit_gives_libgcc_bits(check: soc.SocRun) -> None:
    """Every pair ran, nothing trapped, and the unit's result word equals libgcc's for each;
    the pairs included NaN and subnormal results of every operation."""
    r = check.ram
    assert r["soc_trap_cause"] == 0, f"trap: mcause 0x{r['soc_trap_cause']:x} at " \
                                     f"0x{r['soc_trap_pc']:x}"
    assert r["check_done"] == 1
    for i, op in enumerate(OPS):
        assert r[f"check_count.{i}"] == CORNERS * CORNERS + 4 * RANDOM, op
        assert r[f"check_nan.{i}"] > 0 and r[f"check_subnormal.{i}"] > 0, op
    bad = [r[f"check_bad.{i}"] for i in range(4)]
    first = [r[f"check_first.{i}"] for i in range(5)]
    assert bad == [0, 0, 0, 0], (f"differences per operation {bad}; the first: "
                                 f"{OPS[first[0]]} {first[1]:08x} {first[2]:08x}: libgcc "
                                 f"{first[3]:08x}, unit {first[4]:08x}")
    print(f"\nfloat unit = libgcc on the SoC: {sum(r[f'check_count.{i}'] for i in range(4))} "
          f"pairs, NaN results {[r[f'check_nan.{i}'] for i in range(4)]}, subnormal "
          f"{[r[f'check_subnormal.{i}'] for i in range(4)]}")
