"""The three-axis wrapper (rtl/interp/enc_interp3.v) with every axis different at once, through
the native harness (one clock per sample): distinct per-axis settings (calibration shift, the
observer's bandwidth and loop type, changed during the run), controls (calibration enable and
freeze, harmonic enable, fault clear, home arm) and stimuli (motion both ways through zero, large
ADC offsets and gains that change sign and size mid-run, clipping, dropouts, jumps), every column
of every axis bit-exact against hapgate.golden.interp (+ golden.velobs) on every sample. Then the
16-bit counters at their tops: the index count wraps, the overspeed count saturates (the spec's
65535, hapgate.golden.interp step 6 and the RTL's port comments). A coverage run counts these
builds' port toggles (issue 29)."""

from __future__ import annotations

import numpy as np
from hapgate.golden import interp, velobs
from hapgate.runners import native

# (2-line calibration blocks: many updates in a short run)
CFG = interp.InterpConfig(cal=True, vel_obs=True, cal_lines_log2=1)
AXES = 3
N = 48_000
COUNTER_TOP = 65535            # the spec's 16-bit counters: index wraps, overspeed saturates


def _axis_stimulus(ax: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """One axis: a sinusoidal travel of +-amp lines around a random start near 0 (positions and
    velocities both signs), the signal's offsets and amplitude switched between two settings
    per third of the run (the calibration's offsets cross zero, its gains cross 2^14), a
    dropout, a clipping burst, a jump of two quadrants, index pulses at every 20th line
    (latches of both signs)."""
    k = np.arange(N)
    amp = rng.uniform(40, 60)
    period = amp * rng.uniform(32, 40)   # peak speed 2 pi amp / period < 0.2 lines per sample
    x = amp * np.sin(2 * np.pi * k / period + rng.uniform(0, 2 * np.pi)) * \
        np.minimum(1, k / 2000) + rng.uniform(-0.5, 0.5)
    jump = rng.integers(N // 2, N // 2 + 4000)
    x[jump:] += 0.5 - (x[jump] - x[jump - 1])                # two quadrants in one sample
    third = np.minimum(k * 3 // N, 2)
    sign = np.array([1, -1, 1])[third] * (1 if ax % 2 == 0 else -1)
    # per third: a small sine (gains learned above 1), a flattened sine (its mean |.| above a
    # full-scale sine's: gains learned below 1 without clipping), a larger sine
    amp_seg = np.array([rng.uniform(65, 80), rng.uniform(96, 100), rng.uniform(95, 104)])[third]
    flat = np.array([1.0, 3.0, 1.0])[third]
    ofs_a = sign * rng.uniform(14, 22)
    ofs_b = -sign * rng.uniform(14, 22)
    phi = 2 * np.pi * x
    sa = np.clip(flat * np.sin(phi), -1, 1)
    cb = np.clip(flat * np.cos(phi + np.deg2rad(2.0 * sign)), -1, 1)
    a = np.clip(np.rint(amp_seg * sa + ofs_a), -128, 127).astype(np.int8)
    b = np.clip(np.rint(amp_seg * cb + ofs_b), -128, 127).astype(np.int8)
    clip = rng.integers(N // 3, N // 3 + 3000)
    a[clip:clip + 5] = 127                                    # a clipping burst
    drop = rng.integers(N // 6, N // 6 + 3000)
    a[drop:drop + 40] = 0                                     # signal loss (16 samples)
    b[drop:drop + 40] = 0
    index = (np.floor(x).astype(np.int64) % 20 == 0) & (np.mod(x, 1.0) < 0.25)
    return {"a": a, "b": b, "index": index}


def _levels(rng: np.random.Generator, period: int) -> np.ndarray:
    """A level switched at random points about `period` samples apart (starting high)."""
    n_sw = N // period
    at = np.sort(rng.choice(np.arange(1, N), n_sw, replace=False))
    return (np.searchsorted(at, np.arange(N), side="right") % 2) == 0


def _windows(rng: np.random.Generator, count: int) -> np.ndarray:
    """True in `count` random windows of 200..800 samples, False elsewhere."""
    m = np.zeros(N, dtype=bool)
    for s, w in zip(rng.integers(0, N - 800, count), rng.integers(200, 800, count), strict=True):
        m[s:s + w] = True
    return m


def test_three_axes_independent_bit_exact() -> None:
    """Three axes, each its own settings, controls and stimulus, all at once: every column of
    every axis equals the model of that axis alone (so a control or setting of one axis changes
    only that axis) on every sample."""
    rng = np.random.default_rng(29)
    st = [_axis_stimulus(ax, rng) for ax in range(AXES)]
    a = np.stack([s["a"] for s in st], 1)
    b = np.stack([s["b"] for s in st], 1)
    index = np.stack([s["index"] for s in st], 1)
    cal_en = np.stack([~_windows(rng, c) for c in (3, 5, 4)], 1)
    cal_fr = np.stack([_windows(rng, c) for c in (4, 3, 5)], 1)
    harm_en = np.stack([_levels(rng, p) for p in (5_000, 3_000, 8_000)], 1)
    clear_at = [np.sort(rng.choice(N, 6, replace=False)) for _ in range(AXES)]
    arm_at = [np.sort(rng.choice(N, 4, replace=False)) for _ in range(AXES)]
    # settings: (mu, bw, type3) per axis, distinct, changed during the run so that every bit of
    # every axis's settings goes both ways (x, then its complement, then y, its complement, y);
    # the middle (the calibration's sign changes) runs on the faster shifts
    first = [(3, 4, True), (6, 7, False), (4, 10, True)]
    change = [N // 12, N // 6, 11 * N // 12, 23 * N // 24]
    later = [[(12, 11, False), (9, 8, True), (11, 5, False)],
             [(5, 6, True), (2, 3, False), (7, 2, False)],
             [(10, 9, False), (13, 12, True), (8, 13, True)],
             [(5, 6, True), (2, 3, False), (7, 2, True)]]
    schedule = dict(zip(change, later, strict=True))
    for c in change:        # frozen around a change: no update reads the shift there
        cal_fr[c - 32:c + 32] = True
    run = native.run_interp(a, b, index, CFG, columns=native.HARNESS_COLUMNS, clear_at=clear_at,
                            arm_at=arm_at, cal_en=cal_en, cal_freeze=cal_fr, harm_en=harm_en,
                            cal_mu=[f[0] for f in first], obs_bw=[f[1] for f in first],
                            obs_type3=[f[2] for f in first], schedule=schedule,
                            cov_toggle=True)
    # the observer's settings are levels read latency - 2 clocks after a sample's capture
    # (one sample per clock here: those driven with sample k + latency - 2; cocotb_vel_observer)
    at = np.minimum(np.arange(N) + CFG.latency - 2, N - 1)
    for ax in range(AXES):
        seg = np.searchsorted(change, np.arange(N), side="right")
        sets = np.array([first[ax], *(later[j][ax] for j in range(len(change)))])[seg]
        mu, bw, t3 = sets[:, 0], sets[:, 1], sets[:, 2].astype(bool)
        out = interp.run(a[:, ax], b[:, ax], index[:, ax], CFG, clear_at=clear_at[ax],
                         arm_at=arm_at[ax], cal_en=cal_en[:, ax], cal_freeze=cal_fr[:, ax],
                         cal_mu=mu, harm_en=harm_en[:, ax])
        model = native.model_matrix(out) | native.cal_columns(out)
        model["vel_obs"] = velobs.run_interp(out, velobs.ObsConfig(vel_log2w=CFG.vel_log2w),
                                             bw=bw[at], type3=t3[at])
        # the shift is read at a calibration update: none within 16 samples of a change (frozen
        # there), so the check does not hang on the sample the new shift is first read at
        upd = np.flatnonzero(np.diff(model["cal_updates"]))
        assert all(np.min(np.abs(upd - c)) > 16 for c in change), f"axis {ax}: an update near"
        bad = native.first_mismatch(run.axis(ax), model)
        assert bad is None, f"axis {ax}: first mismatch at sample {bad[0]}, column {bad[1]}: " \
                            f"RTL {bad[2]} model {bad[3]}"
        # the run reaches what it is for, on this axis: both signs of position, velocity, the
        # observer's velocity, index latch and learned offsets; gains both sides of 2^14;
        # every fault kind; homed and unhomed; adaptation at work
        for c in ("pos", "vel", "vel_obs", "index_pos", "cal_ofs_a", "cal_ofs_b", "cal_phase"):
            assert model[c].min() < 0 < model[c].max(), f"axis {ax}: {c} keeps one sign"
        for c in ("cal_gain_a", "cal_gain_b"):
            assert model[c].min() < 1 << 14 < model[c].max(), f"axis {ax}: {c} one side of 1"
        assert np.bitwise_or.reduce(model["faults"]) == 7, f"axis {ax}: a fault kind missing"
        assert np.any(np.diff(model["homed"]) < 0), f"axis {ax}: never unhomed by an arm"
        assert model["cal_updates"].max() > 100, f"axis {ax}: too few calibration updates"


def test_counters_at_their_top() -> None:
    """The index count wraps 65535 -> 0 and the overspeed count stops at 65535 (spec: 16 bits,
    index wraps, overspeed saturates), on all three axes, against the spec's numbers and the
    model: index edges every 2 samples (65540 before the reset) while the signal jumps two quadrants
    every sample (an overspeed step each). Then a reset mid-run: the samples in flight are lost
    (latency - 1 of them at one clock per sample), and from the next sample on every axis
    restarts from the reset state (counts 0, unhomed, position from the first sample), equal
    to the model run from there."""
    n = 2 * (COUNTER_TOP + 8) + 6000
    r = n - 3000                                          # the reset, before sample r
    k = np.arange(n)
    ax_off = np.arange(AXES)
    # quadrants 0 and 2 alternately: a two-quadrant step at every sample after the first
    q = (k[:, None] + ax_off) % 2 * 2
    phi = 2 * np.pi * (q / 4 + 0.125)
    a = np.rint(100 * np.sin(phi)).astype(np.int8)
    b = np.rint(100 * np.cos(phi)).astype(np.int8)
    index = (k[:, None] + ax_off) % 2 == 1
    arm = [[100 + ax] for ax in range(AXES)]              # homed at the next index edge
    cfg = interp.InterpConfig()
    cols = ("pos", "index_count", "overspeed_count", "homed")
    run = native.run_interp(a, b, index, cfg, columns=cols, arm_at=arm, reset_at=[r],
                            cov_toggle=True)
    # in flight at the reset: the harness drives a sample before a clock edge and reads m_valid
    # after one, so a sample's result is read latency - 1 iterations after it was driven
    lost = slice(r - (cfg.latency - 1), r)
    for ax in range(AXES):
        rtl = run.axis(ax)
        before = interp.run(a[:r, ax], b[:r, ax], index[:r, ax], cfg, arm_at=arm[ax])
        after = interp.run(a[r:, ax], b[r:, ax], index[r:, ax], cfg)
        for c in cols:
            got = rtl[c]
            assert np.all(got[lost] == (-1 if c == "pos" else (1 << 16) - 1 if c != "homed"
                                        else 255)), f"axis {ax}: {c} of a lost sample"
            np.testing.assert_array_equal(got[:lost.start],
                                          np.asarray(getattr(before, c))[:lost.start],
                                          err_msg=f"axis {ax}: {c} before the reset")
            np.testing.assert_array_equal(got[r:], np.asarray(getattr(after, c)),
                                          err_msg=f"axis {ax}: {c} after the reset")
        # the spec's numbers: rising edges of the index so far (high before sample 0)
        prev = np.concatenate([[True], index[:-1, ax]])
        edges = np.cumsum(index[:, ax] & ~prev)[:lost.start]
        np.testing.assert_array_equal(rtl["index_count"][:lost.start], edges % (COUNTER_TOP + 1))
        assert edges[-1] > COUNTER_TOP + 1
        steps = np.arange(lost.start)                     # one per sample after the first
        np.testing.assert_array_equal(rtl["overspeed_count"][:lost.start],
                                      np.minimum(steps, COUNTER_TOP))
        assert steps[-1] > COUNTER_TOP
        assert rtl["homed"][lost.start - 1] == 1
        # the reset state: the first sample after the reset counts nothing and is not homed
        assert rtl["overspeed_count"][r] == 0 and rtl["homed"][r] == 0
        assert rtl["index_count"][r] == 0


def test_ratio_operands_at_full_width() -> None:
    """The ratio stage's divider (ANGLE = 1) behind the calibration (CAL = 1: 12-bit operands):
    gains and offsets learned on a small offset signal (70 codes, -20 codes offset), then
    frozen while a full-scale flattened signal arrives, so the corrected magnitudes reach 2^10
    on both channels at once (bounded by (16 * 127 + 512) * 32767 / 2^16 < 2^11, the applied
    ranges of enccal). Every column bit-exact against the model on every sample."""
    cfg = interp.InterpConfig(cal=True, ratio=True)
    n = 30_000
    k = np.arange(n)
    late = k >= n // 2
    phi = 2 * np.pi * (0.02 * k + 0.1)                    # forwards, 0.02 lines per sample
    amp = np.where(late, 127 * 3.0, 70.0)                 # (late: clipped to a square)
    ofs = np.where(late, 0.0, -20.0)
    a = np.clip(np.rint(amp * np.sin(phi) + ofs), -128, 127).astype(np.int8)
    b = np.clip(np.rint(amp * np.cos(phi) + ofs), -128, 127).astype(np.int8)
    run = native.run_interp(a, b, None, cfg, columns=native.ALL_COLUMNS, cal_en=True,
                            cal_freeze=late, cal_mu=3, cov_toggle=True)
    out = interp.run(a, b, None, cfg, cal_en=True, cal_freeze=late, cal_mu=3)
    model = native.model_matrix(out) | native.cal_columns(out)
    bad = native.first_mismatch(run.axis(0), model)
    assert bad is None, f"first mismatch at sample {bad[0]}, column {bad[1]}: " \
                        f"RTL {bad[2]} model {bad[3]}"
    ac, bc = np.abs(out.extra["cal_ac"]), np.abs(out.extra["cal_bc"])
    assert np.minimum(ac, bc).max() >= 1 << 10, "the smaller operand stays below 2^10"
    assert np.maximum(ac, bc).max() < 1 << 11
