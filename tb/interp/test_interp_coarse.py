"""Plain quadrature (enc_interp COARSE = 1, `InterpConfig(coarse=True)`): the same RTL with the
fine angle zeroed, used by the Z-width sweep to show what the interpolation buys.

Bit-exact: the native Verilated RTL against the model on every sample, every output column.
Against the float truth: the position is the start of the quadrant the sign bits name, so with
ideal signals pos - truth lies in (-256, 0] counts (one quadrant = 256 of the 2^20 counts/rev),
up to the 1/2-LSB rounding at the zero crossings (budget: 1 count beyond each end).
"""

from __future__ import annotations

import numpy as np
from hapgate.golden import encsig, interp
from hapgate.golden.interp import InterpConfig
from hapgate.runners import native


def test_coarse_rtl_bit_exact_and_within_one_quadrant() -> None:
    cfg = InterpConfig(coarse=True)
    for name in ("const150_ideal", "reversals_paper", "dropout_controls"):
        sc = encsig.scenario(name, 100_000)
        rtl = native.run_interp(sc.a, sc.b, sc.index, cfg, clear_at=[sc.clear_at],
                                arm_at=[sc.arm_at]).axis(0)
        model = native.model_matrix(interp.run(sc.a, sc.b, sc.index, cfg,
                                               clear_at=sc.clear_at, arm_at=sc.arm_at))
        assert native.first_mismatch(rtl, model) is None, name
        assert np.all(rtl["pos"] % 256 == 0), name
    sc = encsig.scenario("const150_ideal", 100_000)
    pos = interp.run(sc.a, sc.b, sc.index, cfg).pos
    fine = interp.run(sc.a, sc.b, sc.index, InterpConfig())
    truth = (sc.truth_lines - np.floor(sc.truth_lines[0])) * cfg.counts_per_line
    err = interp.truth_counts_error(pos, truth)
    assert err.max() <= 1.0 and err.min() >= -257.0
    assert err.min() < -250.0                       # it does use the whole quadrant
    assert np.array_equal(pos, fine.pos - fine.extra["fine"])   # the fine angle, dropped
