"""The campaign's classification (hapgate.device.seu.classify) on hand-made record pairs: a
reference of a hand at rest (constant torques, a servo tick every 1 ms, every DAC channel
loaded every 16 us frame) and a run changed in one way per test. The budgets are the ones
scenes/seu/README.md states, written here as literals: 0.01 N m for two frames or more, a
0.02 N m step, zero torque within 50 us of the latch."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hapgate.device import seu
from hapgate.device.seu import Trace

FRAME = 16e-6
N = 1250                    # 20 ms of frames
T_I = 5e-3                  # the injection
ERR_AXIS_FAULT = 2          # hapgate.device.harness.ERR_NAMES
CFG_ERR = 1 << 13           # STATUS.CFG_ERR (rtl/regs/REGISTERS.md)
HOMED = 0x700               # STATUS.HOMED[2:0]: not sticky fault bits


def reference() -> Trace:
    t = np.arange(N) * FRAME
    tau = np.tile([0.002, 0.033, 0.032], (N, 1))
    tick_t = np.arange(1e-3, 20e-3, 1e-3) - 62e-6
    load_t = (t[:, None] + 2e-6 * np.arange(6)).ravel()
    return Trace(t, tau, tick_t, np.zeros(tick_t.size, np.uint8),
                 np.full(tick_t.size, HOMED, np.uint32), load_t,
                 np.tile(np.arange(6, dtype=np.int32), N), np.full(6 * N, 500, np.int32))


def copy(tr: Trace) -> Trace:
    return Trace(**{k: v.copy() for k, v in tr.arrays().items()})


def frames(t0: float, n: int) -> slice:
    i = int(round(t0 / FRAME))
    return slice(i, i + n)


def zero_from(tr: Trace, t0: float) -> None:
    """Every DAC load from t0 on is zero; the delivered torque falls after the loads reach
    the amplifier (two frames later here)."""
    tr.load_code[tr.load_t >= t0] = 0
    tr.tau[tr.t >= t0 + 2 * FRAME] = 0.0


def test_identical_run_is_masked_and_identical():
    r = seu.classify(reference(), reference(), T_I)
    assert r["class"] == "masked" and r["identical"] and not r["dangerous"]
    assert r["max_dev_nm"] == 0.0


@pytest.mark.parametrize("dev, n, cls", [
    (0.009, 400, "masked"),          # inside the budget however long
    (0.0101, 1, "masked"),           # outside for one frame: tolerated (steps 0.0101 < 0.02)
    (0.0101, 2, "silent"),           # two frames in a row: a violation
    (0.03, 1, "silent"),             # one frame, but a 0.03 N m step
    (0.019, 1, "masked"),            # a 0.019 step in and out: under the step budget
])
def test_torque_budget(dev, n, cls):
    run = reference()
    run.tau[frames(T_I + 1e-3, n), 1] += dev
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == cls
    assert r["dangerous"] == (cls == "silent")
    assert not r["identical"]
    if cls == "silent":
        assert r["t_violation_s"] == pytest.approx(T_I + 1e-3, abs=FRAME)


def test_a_deviation_before_the_injection_is_not_judged():
    run = reference()
    run.tau[frames(T_I - 1e-3, 10), 0] += 0.05
    assert seu.classify(reference(), run, T_I)["class"] == "masked"


def test_latched_and_zero_in_time_is_detected():
    run = reference()
    k = int(np.searchsorted(run.tick_t, T_I))
    run.tick_err[k:] = ERR_AXIS_FAULT
    zero_from(run, run.tick_t[k] + 30e-6)      # every channel zero within 30 + 16 < 50 us
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "detected" and r["latched"] and r["safe"] and not r["dangerous"]
    assert r["t_latch_s"] == run.tick_t[k]


def test_zero_before_the_latch_is_detected():
    """The FPGA's own reaction (an axis fault zeroes the DACs) comes before the firmware's
    tick that shows the latch; the torque's fall to zero is not a violation."""
    run = reference()
    k = int(np.searchsorted(run.tick_t, T_I))
    zero_from(run, T_I + 20e-6)
    run.tick_status[k:] |= 1                            # STATUS.FAULT[0], sticky
    run.tick_err[k:] = ERR_AXIS_FAULT
    assert seu.classify(reference(), run, T_I)["class"] == "detected"


def test_latched_but_zero_too_late():
    run = reference()
    k = int(np.searchsorted(run.tick_t, T_I))
    run.tick_err[k:] = ERR_AXIS_FAULT
    zero_from(run, run.tick_t[k] + 60e-6)              # 60 us > 50 us
    assert seu.classify(reference(), run, T_I)["class"] == "latched"
    run.tau[frames(T_I + 0.1e-3, 3), 2] += 0.05        # and a violation before it
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "violation_latched" and r["dangerous"]


def test_a_violation_long_before_the_detection_is_not_detected():
    """Zero within 50 us of the latch, but the violation began more than one servo period
    plus 50 us before the zero: the fault-tolerant interval is exceeded."""
    run = reference()
    k = int(np.searchsorted(run.tick_t, T_I + 2e-3))
    run.tau[frames(T_I, 200), 1] += 0.05               # from T_I, 3.2 ms
    run.tick_err[k:] = ERR_AXIS_FAULT
    zero_from(run, run.tick_t[k] + 20e-6)
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "violation_latched" and r["dangerous"]
    run2 = reference()                                  # began within the interval: detected
    k2 = int(np.searchsorted(run2.tick_t, T_I))
    run2.tau[frames(run2.tick_t[k2] - 0.5e-3, 30), 1] += 0.05
    run2.tick_err[k2:] = ERR_AXIS_FAULT
    zero_from(run2, run2.tick_t[k2] + 20e-6)
    assert seu.classify(reference(), run2, T_I)["class"] == "detected"


def test_a_new_sticky_status_bit_is_a_latch_a_live_bit_is_not():
    run = reference()
    k = int(np.searchsorted(run.tick_t, T_I))
    run.tick_status[k:] |= CFG_ERR
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "latched" and r["status_new"] == CFG_ERR and not r["dangerous"]
    run = reference()
    run.tick_status[k:] &= ~np.uint32(0x100)          # HOMED[0] drops: not a latch
    assert seu.classify(reference(), run, T_I)["class"] == "masked"


def test_an_unannounced_zero_torque_is_silent():
    run = reference()
    zero_from(run, T_I + 1e-3)
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "silent" and r["to_zero"] and r["safe"]


def test_a_dac_that_stops_loading_is_not_safe():
    run = reference()
    keep = run.load_t < T_I + 1e-3                       # no load after: the DAC holds 500
    for k in ("load_t", "load_ch", "load_code"):
        setattr(run, k, getattr(run, k)[keep])
    assert seu.safe_from(run, T_I) == math.inf
    zero = reference()
    zero.load_code[zero.load_t >= T_I + 1e-3] = 0
    assert seu.safe_from(zero, T_I) == pytest.approx(T_I + 1e-3, abs=FRAME)


def test_missing_ticks_are_a_hang():
    run = reference()
    gone = (run.tick_t > T_I) & (run.tick_t < T_I + 3e-3)     # three ticks lost
    for k in ("tick_t", "tick_err", "tick_status"):
        setattr(run, k, getattr(run, k)[~gone])
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "hang" and not r["dangerous"]       # the torque stayed in budget
    one = reference()
    lost = np.flatnonzero(one.tick_t > T_I)[0]
    for k in ("tick_t", "tick_err", "tick_status"):           # one tick lost: served
        setattr(one, k, np.delete(getattr(one, k), lost))
    assert seu.classify(reference(), one, T_I)["class"] == "masked"


def test_a_hang_zeroed_by_the_watchdog_is_judged_up_to_the_zero():
    run = reference()
    gone = run.tick_t > T_I
    for k in ("tick_t", "tick_err", "tick_status"):
        setattr(run, k, getattr(run, k)[~gone])
    zero_from(run, T_I + 10e-3)                               # the watchdog's 10 ms
    r = seu.classify(reference(), run, T_I)
    assert r["class"] == "hang" and r["safe"] and not r["violation"] and not r["dangerous"]
    run.tau[frames(T_I + 2e-3, 5), 0] += 0.05                  # a violation before it
    assert seu.classify(reference(), run, T_I)["dangerous"]


def test_a_harness_that_did_not_finish_is_a_dangerous_hang():
    r = seu.classify(reference(), Trace.failed("killed"), T_I)
    assert r["class"] == "hang" and r["dangerous"]


def test_spfm():
    assert seu.spfm(0, 100) == 1.0
    assert seu.spfm(3, 100) == pytest.approx(0.97)
    assert math.isnan(seu.spfm(0, 0))


def test_budgets_are_the_stated_ones():
    assert (seu.BUDGET_DEV_NM, seu.BUDGET_DEV_FRAMES, seu.BUDGET_STEP_NM, seu.REACT_S) == \
        (0.01, 2, 0.02, 50e-6)
