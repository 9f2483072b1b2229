"""The virtual device in a closed loop (tb/native/device/): real gateware, unchanged firmware,
plant and hand. Short scenes (tens of ms of simulated time, one axis where the check allows).
Budgets are derived in each docstring; timing is in simulated time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.device import runner
from hapgate.device import scene as sc
from hapgate.golden import kinematics

SCENES = ROOT / "scenes"
CLK_BITS = 2 * math.pi / (1 << 20)        # rad per count


def _short(**changes: object) -> sc.Scene:
    return sc.load(SCENES / "short.toml").override(changes)


def _wall_budget(s: sc.Scene, f: float, speed: float) -> float:
    """Steady-state force error budget: the interpolator's error on R = 110 signals (<= 25 counts
    per joint, the arcsine table assumes R = 127) through the Jacobian and the wall's stiffness;
    k * speed * (one servo period of sample-and-hold + 0.2 ms of current loop and velocity
    filter) while the contact still settles; the commutation's 0.3 % ripple; 5 mN for
    torque-code and DAC rounding."""
    q0 = s.q0_rad
    jn = np.linalg.norm(kinematics.jacobian(q0), 2)
    return (s.env.k * jn * math.sqrt(3) * 25 * CLK_BITS
            + s.env.k * speed * (1.0 / s.run.servo_hz + 2e-4) + 0.003 * f + 0.005)


@pytest.mark.parametrize("servo_hz", [1000, 10000])
def test_wall_renders_its_force_law(servo_hz):
    s = _short(**{"run.servo_hz": servo_hz, "run.duration_s": 0.04})
    r = runner.run(s)
    f = np.linalg.norm(r.arrays["f_hand"][-1])
    assert f > 0.3, "the hand must push into the wall"
    assert r.metrics["force_samples"] > 1000           # 25 ms of frames
    budget = _wall_budget(s, 1.2, r.metrics["force_speed_max"])
    assert r.metrics["force_error_n"] <= budget, (r.metrics, budget)
    assert r.metrics["fw_error"] == "NONE"
    # the device pushes back along the wall's normal (into free space): J^-T tau
    n = np.asarray(s.env.normal) / np.linalg.norm(s.env.normal)
    q, tau = r.arrays["q"][-1], r.arrays["tau"][-1]
    f_dev = np.linalg.solve(kinematics.jacobian(q).T, tau)
    assert float(f_dev @ n) > 0.99 * np.linalg.norm(f_dev) > 0.3


def test_skipped_and_unskipped_runs_are_bit_identical():
    """The short scene (one axis) at the lowest clock with only its axis built, against the full
    48 MHz build with every interpolator: every recorded frame and every firmware tick of the
    scene are bit-identical (README, "Why any clock gives the same result")."""
    s = _short(**{"run.duration_s": 0.012})
    low = runner.simulate(s)
    full = runner.simulate(s, clk_hz=runner.FULL_CLK_HZ, mask=7)
    assert low.clk_hz == runner.MIN_CLK_HZ and low.mask == 2
    assert low.frames.size > 700 and low.frames.size == full.frames.size
    for name in runner.FRAME_DT.names:
        assert np.array_equal(low.frames[name], full.frames[name]), name
    tl, tf = low.ticks[low.ticks["t"] >= 0], full.ticks[full.ticks["t"] >= 0]
    assert tl.size >= 11
    for name in runner.TICK_DT.names:
        assert np.array_equal(tl[name], tf[name]), name
    assert np.abs(low.frames["dac"]).max() > 100      # it was driving


@pytest.mark.parametrize("kind, axis, err", [("dropout", 1, "AXIS_FAULT"),
                                             ("dropout", 0, "AXIS_FAULT"),
                                             ("dropout", 2, "AXIS_FAULT"),
                                             ("watchdog", None, "WATCHDOG"),
                                             ("hang", None, "OVERRUN")])
def test_fault_means_zero_torque_within_one_frame(kind, axis, err):
    """From the cause (the interpolator's loss on the 16th bad sample; the watchdog's expiry)
    every affected DAC channel is zero within one frame (16 us) plus the load pipeline (9
    clocks) and stays zero; the firmware latches the matching error. A dropout on axis 0 or 2
    runs all three axes (the build of test_position_tracks_the_true_angle_without_slip)."""
    fault = {"at_s": 0.01, "kind": kind} | ({"axis": axis} if axis is not None else {})
    dur = 0.016 if kind == "dropout" else 0.025 if kind == "watchdog" else 0.03
    s = _short(**{"run.duration_s": dur, "fault": [fault]}
               | ({"run.axes": [0, 1, 2]} if axis in (0, 2) else {}))
    r = runner.run(s)
    assert len(r.events) == 1
    ev = r.events[0]
    bound_us = 16.0 + 10 / r.clk_hz * 1e6
    assert 0 <= ev["reaction_us"] <= bound_us, ev
    assert r.metrics["fw_error"] == err
    if kind == "dropout":
        assert r.metrics["fw_error_axis"] == axis
    # the motors were driving before the fault (not a vacuous zero)
    t = r.arrays["t"]
    before = (t > 0.009) & (t < 0.0099)
    assert np.abs(r.arrays["dac"][before]).max() > 50


def test_miscommutated_motor_loses_cos_delta():
    """A commutation offset error of 32/1024 electrical cycle (11.25 deg) on the beta motor: it
    delivers cos(11.25 deg) = 0.981 of the firmware's command (motor model); the correctly
    commutated control run delivers 1.000. Budget +-0.006: torque-code and DAC rounding at
    these torques plus the ROM's 0.25 % ripple."""
    base = {"run.duration_s": 0.03}
    ok = runner.run(_short(**base))
    bad = runner.run(_short(**base, **{"firmware.comm_offset_error_counts": [0, 32, 0]}))
    r_ok, r_bad = ok.per_axis["torque_ratio"][1], bad.per_axis["torque_ratio"][1]
    assert abs(r_ok - 1.0) < 0.006, r_ok
    assert abs(r_bad - math.cos(2 * math.pi * 32 / 1024)) < 0.006, r_bad


def test_position_tracks_the_true_angle_without_slip():
    """The firmware's joint angles (snapshot) against the true angle of the same sample, over a
    moving scene: within the interpolator's error at R = 110 (25 counts), no slip."""
    r = runner.run(_short(**{"run.duration_s": 0.02, "run.axes": [0, 1, 2]}))
    assert r.metrics["slips"] == 0
    assert r.metrics["position_error_counts"] <= 25
    moved = np.abs(r.arrays["q"][-1] - r.arrays["q"][0]).max()
    assert moved > 1e-3


def test_unbuilt_axis_is_held_still():
    r = runner.run(_short(**{"run.duration_s": 0.01}))
    q = r.arrays["q"]
    assert np.ptp(q[:, 0]) == 0 and np.ptp(q[:, 2]) == 0
    assert np.ptp(q[:, 1]) > 0
    assert any("axis 0" in x for x in r.skipped) and any("axis 2" in x for x in r.skipped)


def test_link_garbage_is_dropped_and_the_pc_force_expires():
    """The scripted PC pushes 1 N through the link (SET_FORCE every 5 ms); at 30 ms 512 seeded
    random bytes arrive, then silence. The firmware counts bad frames and acts on none of them
    (its good-frame count is exactly the PC's ENABLE and SET_FORCE frames), renders the PC's force
    while it lives and from (last good frame + timeout) at most one servo tick on renders zero,
    without latching an error."""
    s = sc.load(SCENES / "link_garbage.toml").override({
        "run.axes": [1], "run.duration_s": 0.05, "fault": [
            {"at_s": 0.03, "kind": "link_garbage", "bytes": 512}],
        "firmware.pc_force_timeout_ms": 10.0, "expect": {}})
    r = runner.run(s)
    m = r.metrics
    sent = 1 + 6                                       # ENABLE + SET_FORCE at 0, 5, ..., 25 ms
    assert m["link_good_frames"] == sent, m
    assert m["link_bad_frames"] >= 1 and m["fw_error"] == "NONE", m
    tick_ms = 1e3 / s.run.servo_hz
    assert 10.0 - tick_ms <= m["pc_force_zero_ms"] <= 10.0 + tick_ms, m
    t, f = r.arrays["tick_t"], r.arrays["tick_f_cmd"]
    live = (t > 0.002) & (t < 0.03)
    assert np.allclose(f[live], s.pc.force_n, atol=1e-6), f[live][:3]
    assert not np.any(f[t > 0.03 + 0.010 + 2 * tick_ms * 1e-3])



@pytest.mark.parametrize("axes, fault", [([0, 1, 2], "dropout"), ([1], "dropout"),
                                         ([0, 1, 2], "watchdog")])
def test_stage_clocks_change_nothing(axes, fault):
    """The simulation-only stage clocks (HG_SIM_GATE, the rtl fidelity's default: the
    interpolators' stages, the commutator's datapath, the bus slave and the access-written
    registers) against the same build with everything on clk: through the homing sweep, the
    firmware's bring-up and every servo tick's bus accesses, the wall, encoder noise and a third
    harmonic, and a fault — an encoder dropout (signal loss, the axis fault, zero torque) or lost
    watchdog keys (expiry, zero torque) — every frame, firmware tick, DAC load and ADC word is
    bit-identical."""
    at, dur = (0.009, 0.012) if fault == "dropout" else (0.001, 0.014)
    f = {"at_s": at, "kind": fault} | ({"axis": axes[0]} if fault == "dropout" else {})
    s = _short(**{
        "run.duration_s": dur, "run.axes": axes,
        "run.record": ["q", "p", "f_hand", "tau", "dac", "adc"],
        "fault": [f], "expect": {},
        "encoder.noise_lsb": 1.5, "encoder.h3": 0.02})
    gated, plain = runner.simulate(s), runner.simulate(s, gate=False)
    assert gated.frames.size > 500 and gated.loads.size > 1000 and gated.adc is not None
    for a, b in ((gated.frames, plain.frames), (gated.ticks, plain.ticks),
                 (gated.loads, plain.loads), (gated.adc, plain.adc)):
        assert a.size == b.size and a.tobytes() == b.tobytes()
    # the run did what the docstring says: the fault zeroed every DAC word after it
    tk = gated.ticks[gated.ticks["t"] > dur - 0.0025]
    assert tk.size and np.all(tk["err"] == tk["err"][-1]) and int(tk["err"][-1]) != 0
    assert not np.any(gated.loads["code"][-200:])
    assert np.abs(gated.frames["dac"]).max() > 300       # it was driving before the fault


def test_pgo_build_changes_nothing(monkeypatch):
    """The rtl fidelity's default build for users (profile-guided optimisation, trained on a short
    wall scene: runner.build(pgo=True)) against the plain build the suite uses: a scene unlike
    the training (one fault, encoder noise and a third harmonic, two axes) gives bit-identical
    frames, ticks, DAC loads and ADC words; and the build really was trained (its log says so)."""
    s = _short(**{"run.duration_s": 0.012, "run.axes": [0, 2],
                  "run.record": ["q", "p", "f_hand", "tau", "dac", "adc"],
                  "fault": [{"at_s": 0.006, "kind": "dropout", "axis": 2}], "expect": {},
                  "encoder.noise_lsb": 1.5, "encoder.h3": 0.02})
    clk, mask = runner.choose_clock(s), runner.axis_mask(s)
    exe = runner.build(clk, mask, pgo=True)
    assert exe != runner.build(clk, mask, pgo=False)
    assert "== pgo: trained ==" in (exe.parent / "build.log").read_text()
    assert list(exe.parent.glob("*.gcda")), "the training run wrote no profile"
    monkeypatch.setenv("HG_PGO", "1")
    opt = runner.simulate(s)
    monkeypatch.setenv("HG_PGO", "0")
    plain = runner.simulate(s)
    assert opt.frames.size > 500 and opt.loads.size > 1000 and opt.adc is not None
    for a, b in ((opt.frames, plain.frames), (opt.ticks, plain.ticks),
                 (opt.loads, plain.loads), (opt.adc, plain.adc)):
        assert a.size == b.size and a.tobytes() == b.tobytes()
    assert int(opt.ticks["err"][-1]) != 0      # the dropout happened in both


def _vcd_rises(path, name: str) -> np.ndarray:
    """The times at which the top-level 1-bit signal `name` rose in a VCD file."""
    text = path.read_text()
    head, _, body = text.partition("$enddefinitions")
    ids = [ln.split()[3] for ln in head.splitlines()
           if ln.strip().startswith("$var") and ln.split()[4] == name]
    assert ids, f"{name} is not in the trace"
    code = ids[0]
    rises, level = [], None
    for block in body.split("\n#")[1:]:          # one block per time step
        t, _, changes = block.partition("\n")
        for ch in changes.splitlines():
            if ch[1:] == code and ch[0] in "01":
                if ch[0] == "1" and level == "0":
                    rises.append(int(t))
                level = ch[0]
    return np.asarray(rises, dtype=np.int64)


def test_traced_build_changes_nothing_and_traces_every_edge(tmp_path):
    """The waveform build (run.trace: Verilator's --trace, every edge through the model's public
    eval() with the falling edges evaluated, the trace written by the shared testbench wrapper
    tb/native/device/testb.h) against the default build: bit-identical frames, firmware ticks,
    DAC loads and ADC words; and its VCD puts rising edge n of clk at time 2n, so the DAC write
    strobe rises at twice every load's edge and clk rises at every even time step."""
    s = _short(**{"run.duration_s": 0.002, "fault": [], "expect": {},
                  "run.record": ["q", "p", "f_hand", "tau", "dac", "adc"]})
    traced = runner.simulate(s.override({"run.trace": True}), out_dir=tmp_path)
    plain = runner.simulate(s)
    assert traced.trace is not None and traced.loads.size > 100
    for a, b in ((traced.frames, plain.frames), (traced.ticks, plain.ticks),
                 (traced.loads, plain.loads), (traced.adc, plain.adc)):
        assert a.size == b.size and a.tobytes() == b.tobytes()
    wr = _vcd_rises(traced.trace, "dac_wr_n")
    assert np.array_equal(wr, 2 * traced.loads["edge"].astype(np.int64))
    clk = _vcd_rises(traced.trace, "clk")
    assert clk.size > 1000 and np.all(clk % 2 == 0) and np.all(np.diff(clk) == 2)
