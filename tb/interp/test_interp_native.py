"""Interpolator on the native Verilator harness (tb/native/interp/, three axes with the sample
strobe): >= 10^6 samples bit-exact per scenario, the same outputs at the lowest and at a board
clock, and the RTL's own outputs against the float truth (accuracy, codes reached, slip,
velocity, fault timing)."""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.golden import encsig, interp
from hapgate.runners import native

CFG = interp.InterpConfig()
MILLION = 1_000_000


def _stack(scs: list[encsig.Scenario]) -> tuple[np.ndarray, ...]:
    return (np.stack([s.a for s in scs], 1), np.stack([s.b for s in scs], 1),
            np.stack([s.index for s in scs], 1))


def _model(sc: encsig.Scenario, cfg: interp.InterpConfig = CFG) -> interp.InterpOut:
    return interp.run(sc.a, sc.b, sc.index, cfg, clear_at=sc.clear_at, arm_at=sc.arm_at)


GROUPS = [encsig.SCENARIOS[0:3], encsig.SCENARIOS[3:6], encsig.SCENARIOS[6:8]]


@pytest.mark.parametrize("group", GROUPS, ids=lambda g: "+".join(g))
def test_million_samples_bit_exact(group: tuple[str, ...]) -> None:
    """Every stress scenario, 10^6 samples on each axis, every output column, every sample."""
    scs = [encsig.scenario(name, MILLION, seed=11 + i) for i, name in enumerate(group)]
    a, b, idx = _stack(scs)
    run = native.run_interp(a, b, idx, CFG, clear_at=[s.clear_at for s in scs],
                            arm_at=[s.arm_at for s in scs])
    for ax, sc in enumerate(scs):
        bad = native.first_mismatch(run.axis(ax), native.model_matrix(_model(sc)))
        assert bad is None, f"{sc.name}: first mismatch at sample {bad[0]}, column {bad[1]}: " \
                            f"RTL {bad[2]} model {bad[3]}"


def test_lowest_and_board_clock_identical() -> None:
    """CLK_HZ = SAMPLE_HZ (one clock per sample) and a 48 MHz board clock give the same bits."""
    scs = [encsig.scenario(n, 12_000, seed=5) for n in ("dropout_controls", "reversals_paper",
                                                         "overspeed")]
    a, b, idx = _stack(scs)
    kw = dict(clear_at=[s.clear_at for s in scs], arm_at=[s.arm_at for s in scs])
    low = native.run_interp(a, b, idx, CFG, clk_hz=interp.MIN_CLK_HZ, **kw)
    board = native.run_interp(a, b, idx, CFG, clk_hz=interp.BOARD_CLK_HZ, **kw)
    assert board.clocks >= 48 * 12_000 > low.clocks
    for ax, sc in enumerate(scs):
        assert native.first_mismatch(low.axis(ax), board.axis(ax)) is None
        assert native.first_mismatch(low.axis(ax), native.model_matrix(_model(sc))) is None


def test_error_vs_truth_ideal_r127() -> None:
    """Ideal signals at R = 127: RMS <= 0.19 deg and max <= 0.6 deg electrical per line, on the
    RTL's own positions; and the codes reached per line (the paper: about half)."""
    x = encsig.constant(37.3, MILLION, start=0.37)      # not commensurate with the sampling
    a, b = encsig.adc_codes(x)
    pos = native.run_interp(a, b, None, CFG, columns=["pos"]).axis(0)["pos"]
    err = interp.counts_to_elec_deg(interp.truth_counts_error(pos, x * CFG.counts_per_line), CFG)
    rms, mx = float(np.sqrt(np.mean(err**2))), float(np.abs(err).max())
    print(f"error vs truth: rms {rms:.4f} deg, max {mx:.4f} deg electrical")
    assert rms <= 0.19
    assert mx <= 0.6
    # codes: only LUT outputs for magnitudes the 8-bit levels can take at R = 127 are reachable.
    # The table is the README's definition written out here, not the generator under test.
    m = np.arange(129)
    table = np.minimum(np.rint(np.degrees(np.arcsin(np.minimum(m, 127) / 127)) * 128 / 45), 127)
    table = table.astype(np.int64)
    reach_f = np.unique(np.concatenate([table[:91], 2 * 128 - table[:91]]))
    reachable = np.unique((np.arange(4)[:, None] * 256 + reach_f[None, :]) % 1024)
    codes = np.unique(pos & 1023)
    print(f"codes reached per line: {codes.size} of 1024 ({codes.size / 1024:.0%}); "
          f"reachable with 8-bit levels: {reachable.size}")
    assert np.isin(codes, reachable).all()
    assert codes.size >= 0.95 * reachable.size
    assert 0.45 <= codes.size / 1024 <= 0.75


def test_no_slip_and_overspeed() -> None:
    """>= 200 revolutions at 150 and at 244 rev/s: position - truth stays constant (and every
    index latch is exactly 2^20 counts from the previous); at 250 rev/s overspeed is flagged."""
    n = 1_400_000
    speeds = (150.0, 244.0, 250.0)
    xs = [encsig.constant(v, n, start=0.1) for v in speeds]
    ab = [encsig.adc_codes(x) for x in xs]
    a = np.stack([p[0] for p in ab], 1)
    b = np.stack([p[1] for p in ab], 1)
    idx = np.stack([encsig.index_bit(x) for x in xs], 1)
    run = native.run_interp(a, b, idx, CFG, columns=["pos", "index_pos", "index_count",
                                                     "faults", "overspeed_count"])
    for ax, (v, x) in enumerate(zip(speeds, xs)):
        out = run.axis(ax)
        revs = (x[-1] - x[0]) / encsig.LINES
        if v <= encsig.MAX_REV_S:
            assert revs >= 200
            err = interp.truth_counts_error(out["pos"], x * CFG.counts_per_line)
            drift = abs(err[-20_000:].mean() - err[:20_000].mean())
            assert np.abs(err).max() < 2.0 and drift < 0.05, (v, np.abs(err).max(), drift)
            assert out["overspeed_count"][-1] == 0 and not (out["faults"] & 1).any()
            edges = np.flatnonzero(np.diff(out["index_count"]) != 0) + 1
            assert edges.size >= 199
            assert np.all(np.diff(out["index_pos"][edges]) == CFG.counts_per_rev)
        else:
            first = int(np.argmax(out["faults"] & interp.FAULT_OVERSPEED))
            assert out["faults"][-1] & interp.FAULT_OVERSPEED
            assert out["overspeed_count"][-1] > 0
            # the jump continues in the running direction: still no slip even when flagged
            err = interp.truth_counts_error(out["pos"], x * CFG.counts_per_line)
            assert np.abs(err).max() < 2.0
            print(f"{v} rev/s: overspeed flagged at sample {first}")


def test_velocity_mean_and_noise() -> None:
    """At constant speed the velocity's mean equals the true speed within its resolution
    (1 count per W samples); at standstill without noise it is exactly 0. W = 256 and the
    unit (counts per W samples) are the README's, not taken from the config under test."""
    w = 256
    speeds = (12.5, -97.0, 200.0)
    n = 300_000
    xs = [encsig.constant(v, n, start=0.2) for v in speeds]
    specs = [encsig.IDEAL, encsig.PAPER_LIKE, encsig.IDEAL]
    ab = [encsig.adc_codes(x, s) for x, s in zip(xs, specs)]
    run = native.run_interp(np.stack([p[0] for p in ab], 1), np.stack([p[1] for p in ab], 1),
                            None, CFG, columns=["vel"])
    for ax, v in enumerate(speeds):
        vel = run.axis(ax)["vel"][w:]
        true = v * 2**20 / 1e6 * w                  # counts per W samples: 2^20/rev at 1 MSPS
        print(f"{v:+.1f} rev/s: mean {vel.mean():.3f}, true {true:.3f}, noise (std) "
              f"{vel.std():.3f} counts/W = "
              f"{vel.std() / w * encsig.SAMPLE_HZ / CFG.counts_per_rev:.4f} rev/s")
        assert abs(vel.mean() - true) <= 1.0
    still = encsig.adc_codes(encsig.standstill(33.0, 5000), encsig.with_spec(encsig.IDEAL,
                                                                              amplitude=120))
    vel = native.run_interp(still[0], still[1], None, CFG, columns=["vel"]).axis(0)["vel"]
    assert np.all(vel == 0)


def test_direction_invert_reverses_the_count() -> None:
    """INVERT: forward rotation counts down at the same speed; the index still homes."""
    n = 200_000
    x = encsig.constant(40.0, n, start=0.1)
    a, b = encsig.adc_codes(x, encsig.with_spec(encsig.IDEAL, amplitude=120))
    idx = encsig.index_bit(x)
    cfg = interp.InterpConfig(invert=True)
    out = native.run_interp(a, b, idx, cfg, arm_at=[[0]]).axis(0)
    fwd = native.run_interp(a, b, idx, CFG).axis(0)
    w = 1 << CFG.vel_log2w
    assert np.all(out["vel"][w:] < 0) and np.all(fwd["vel"][w:] > 0)
    assert abs(out["vel"][w:].mean() + fwd["vel"][w:].mean()) <= 1.0
    assert out["homed"][-1] == 1
    assert native.first_mismatch(out, native.model_matrix(
        interp.run(a, b, idx, cfg, arm_at=[0]))) is None


@pytest.mark.parametrize("speed", [0.0002, 0.004, 0.13])
def test_index_latch_is_the_line_start_from_either_side(speed: float) -> None:
    """The index latch (and the home) is the start of line 0 whether the index is entered
    forwards or backwards, slowly (the zero code sits on the boundary for several samples) or
    fast; regression for the +-1 quadrant home the firmware co-simulation found."""
    n = int(0.6 / speed)
    fwd = -0.3 + speed * np.arange(n)          # through lines = 0 (quadrant 3 -> quadrant 0)
    bwd = 0.55 - speed * np.arange(n)          # through lines = 0.25 (quadrant 1 -> quadrant 0)
    xs = [fwd, bwd]
    ab = [encsig.adc_codes(x) for x in xs]
    a = np.stack([p[0] for p in ab], 1)
    b = np.stack([p[1] for p in ab], 1)
    idx = np.stack([encsig.index_bit(x) for x in xs], 1)
    run = native.run_interp(a, b, idx, CFG, columns=["pos", "index_pos", "index_count",
                                                     "pos_homed", "homed"], arm_at=[[0], [0]])
    for ax, x in enumerate(xs):
        out = run.axis(ax)
        assert out["index_count"][-1] == 1 and out["homed"][-1] == 1
        # the interpolator counts from the line it woke up in (line -1 forwards, 0 backwards):
        # the true line 0 starts at this position
        truth_line0 = -np.floor(x[0]) * CFG.counts_per_line
        assert out["index_pos"][-1] == truth_line0, (ax, out["index_pos"][-1], truth_line0)
        homed = out["homed"] == 1
        err = out["pos_homed"][homed] - x[homed] * CFG.counts_per_line
        assert np.abs(err).max() < 2.0
        model = interp.run(a[:, ax], b[:, ax], idx[:, ax], CFG, arm_at=[0])
        assert model.index_pos[-1] == out["index_pos"][-1]


def test_index_edge_in_each_quadrant_latches_the_nearest_line_start() -> None:
    """An index edge in each quadrant of a line (an index wider or shifted against A/B, as a
    real encoder's can be) latches the nearest line start, rtl/interp/README.md step 6:
    ((qc + 2) & ~3) counts of a quadrant, so quadrants 0 and 1 give the line's own start and
    quadrants 2 (the tie, rounded up) and 3 the next line's. RTL and model, each against that
    formula over the true quadrant; the count steps once per edge."""
    speed = 0.0004                                  # lines per sample: 625 samples a quadrant
    n = int(0.97 / speed)
    x = 3.02 + speed * np.arange(n)                 # through line 3: quadrants 0, 1, 2, 3
    a, b = encsig.adc_codes(x, encsig.with_spec(encsig.IDEAL, amplitude=110))  # no clip
    frac = x - 3.0
    idx = np.zeros(n, dtype=bool)
    for q in range(4):                              # a pulse mid-quadrant, 0.05 line wide
        idx |= (frac >= q / 4 + 0.10) & (frac < q / 4 + 0.15)
    rises = np.flatnonzero(idx[1:] & ~idx[:-1]) + 1
    quad = np.floor(frac[rises] * 4).astype(np.int64)
    assert quad.tolist() == [0, 1, 2, 3]
    qcounts = CFG.counts_per_line // 4
    # counting starts at the line the interpolator woke up in (line 3 = its line 0)
    want = ((quad + 2) & ~3) * qcounts
    assert want.tolist() == [0, 0, CFG.counts_per_line, CFG.counts_per_line]
    run = native.run_interp(a, b, idx, CFG, columns=["pos", "index_pos", "index_count",
                                                     "faults"]).axis(0)
    model = interp.run(a, b, idx, CFG)
    for engine, pos, count in (("rtl", run["index_pos"], run["index_count"]),
                               ("model", model.index_pos, model.index_count)):
        assert np.array_equal(pos[rises], want), (engine, pos[rises], want)
        assert np.array_equal(count[rises], np.arange(1, 5)), (engine, count[rises])
        assert np.all(count[rises - 1] == np.arange(4)), engine     # on the edge's sample
    assert not run["faults"].any()


def test_fault_timing_and_clear() -> None:
    """Dropout raises signal loss after exactly LOSS_SAMPLES samples, clipping and overspeed
    on the very sample; a clear removes a fault that is gone and not one that persists."""
    n = 4000
    x = encsig.constant(20.0, n, start=0.1)
    a, b = encsig.adc_codes(x, encsig.with_spec(encsig.IDEAL, amplitude=100))
    a, b = a.copy(), b.copy()
    a[1000:1100] = 0
    b[1000:1100] = 0            # dropout: 100 samples
    a[2000] = 127               # one clipped sample
    a[2500:2600] = 0
    b[2500:2600] = 0            # a second dropout, still present when cleared at 2550
    # two-quadrant jump: samples 3000..3001 step by 180 deg
    a[3001:], b[3001:] = -a[3001:], -b[3001:]
    clear = [1500, 2300, 2550, 3500]
    out = native.run_interp(a, b, None, CFG, columns=["faults"], clear_at=[clear]).axis(0)
    f = out["faults"]
    loss, clip, ovs = interp.FAULT_LOSS, interp.FAULT_CLIP, interp.FAULT_OVERSPEED
    n_loss = 16                 # LOSS_SAMPLES (rtl/interp/README.md), not the config under test
    assert not f[:1000 + n_loss - 1].any()
    assert f[1000 + n_loss - 1] == loss                            # on the 16th bad sample
    assert np.all(f[1000 + n_loss - 1:1500] & loss)                # sticky after the dropout
    assert not f[1500:2000].any()                                  # cleared
    assert f[2000] == clip and f[1999] == 0                        # on the very sample
    assert not f[2300:2500].any()
    assert f[2550] & loss                                          # persists through a clear
    assert f[3001] & ovs and not f[3000] & ovs                     # on the very sample
    assert not f[3500:].any()
    assert native.first_mismatch(out, {"faults": interp.run(a, b, None, CFG,
                                                             clear_at=clear).faults}) is None
