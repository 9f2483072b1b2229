"""The DAC schedule's documented numbers at their boundaries (issue 29, "Boundaries"): the 2 us
channel skew and the 16 us frame at every clock we ship, each load on exactly its clock (one
clock early or late fails), and the two configuration limits at their edge and one clock either
side. The clock counts are derived here from the spec's numbers and the clock (never read from
the configuration under test); the native Verilator harness of the commutator and its scheduler
(tb/native/commutation/) and the model's schedule must both equal them.

Spec (docs/design/SPEC.md, "Data flow": "6 DAC channels loaded one after another, 2 us apart,
frame limited by 16 us DAC settling -> 62.5 kHz"; docs/blocks/dac-scheduler.md: "Latency
(position latched -> DAC load): k 2.000 us + (7 + WR_CYCLES) clocks, k = 0..5 ... every channel
reloaded every 16.000 us", "48 MHz: 96 clocks of skew, 768 per frame", the shipped clocks "the
48 MHz default and the iCE40 board's 12 MHz"; docs/blocks/commutator.md: "6 skew <= frame >=
settling")."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hapgate.flows import blocks, boards, flow
from hapgate.golden import commutation as cm
from hapgate.golden.dacsched import random_frames
from hapgate.runners import native_comm

SKEW_S = Fraction(2, 10**6)        # 2 us
FRAME_S = Fraction(16, 10**6)      # 16 us
SHIPPED_HZ = (48_000_000, 12_000_000)
WR_CYCLES = 1                      # commutator.md: WR_CYCLES default 1
N = 40


def spec_clocks(clk_hz: int) -> tuple[int, int]:
    skew, frame = SKEW_S * clk_hz, FRAME_S * clk_hz
    assert skew.denominator == 1 and frame.denominator == 1, "not whole clocks"
    return int(skew), int(frame)


def test_shipped_clocks_are_the_spec_s() -> None:
    """The default build and every board run at a clock this file checks."""
    assert cm.CommutationConfig().clk_hz in SHIPPED_HZ
    assert {b.clk_hz for b in boards.BOARDS.values()} <= set(SHIPPED_HZ)
    assert spec_clocks(48_000_000) == (96, 768)          # dac-scheduler.md, as written there


@pytest.mark.parametrize("clk_hz", SHIPPED_HZ)
def test_skew_and_frame_at_shipped_clock_model_and_rtl(clk_hz: int) -> None:
    skew, frame = spec_clocks(clk_hz)
    want = np.arange(6) * skew + 7 + WR_CYCLES           # clocks from the frame start
    cfg = cm.CommutationConfig(clk_hz=clk_hz)
    # the model's schedule
    assert np.array_equal(cm.load_clocks(cfg), want)
    assert (cfg.skew_clocks, cfg.frame_clocks) == (skew, frame)
    # the RTL: N frames, every load of every frame on its clock, one frame every 16 us
    frames = random_frames(np.random.default_rng(29), N, cfg)
    run = native_comm.run_commutation(frames, cfg)
    assert run.violations == 0
    assert np.array_equal(run.load_clocks, np.broadcast_to(want, (N, 6))), run.load_clocks[0]
    assert run.clocks == (N + 1) * frame
    assert np.array_equal(run.codes, cm.commutate(frames, cfg))
    # in seconds: the skew is exactly 2 us and the last load 10 us + 8 clocks after the start
    gaps = {Fraction(int(d), clk_hz) for d in np.diff(run.load_clocks[0])}
    assert gaps == {SKEW_S}
    assert Fraction(int(run.load_clocks[0, 5]) - 8, clk_hz) == 5 * SKEW_S
    # 62.5 kHz
    assert Fraction(clk_hz, frame) == 62_500


# The configuration limits at 50 MHz, where one clock is exactly 20 ns: 6 x skew = frame and
# frame = settling are accepted, one clock past either is refused (by the RTL at elaboration
# and by the harness runner's check before a build), one clock inside is accepted.
CLK = 50_000_000
LIMITS = [
    ({"SKEW_NS": 2000, "FRAME_NS": 12000, "SETTLE_NS": 12000}, None),
    ({"SKEW_NS": 2000, "FRAME_NS": 12020, "SETTLE_NS": 12000}, None),
    ({"SKEW_NS": 2000, "FRAME_NS": 11980, "SETTLE_NS": 11980},
     "dac_sched_CHANNELS_times_SKEW_must_not_exceed_FRAME"),
    ({"SKEW_NS": 2000, "FRAME_NS": 16000, "SETTLE_NS": 15980}, None),
    ({"SKEW_NS": 2000, "FRAME_NS": 16000, "SETTLE_NS": 16020},
     "dac_sched_FRAME_NS_must_be_at_least_SETTLE_NS"),
]


def test_configuration_limits_at_their_edge() -> None:
    block = blocks.get("dac_sched")
    for change, refusal in LIMITS:
        params = {**block.params(), "CLK_HZ": CLK, **change}
        r = flow.lint_verilator(block, params)
        cfg = cm.CommutationConfig(clk_hz=CLK, skew_ns=change["SKEW_NS"],
                                   frame_ns=change["FRAME_NS"], settle_ns=change["SETTLE_NS"])
        if refusal is None:
            assert r.ok, (change, r.detail)
            native_comm.check_config(cfg)
        else:
            assert not r.ok and refusal in r.detail, (change, r.detail)
            with pytest.raises(ValueError):
                native_comm.check_config(cfg)
