"""The plant of the virtual device (tb/native/device/plant.cpp) against independent references:
the golden motor model and kinematics, the encoder signal model, energy conservation and
static equilibrium. Budgets are stated beside each check (tb/native/device/README.md)."""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.device.plant import Plant, PlantError, config
from hapgate.golden import commutation, encsig, kinematics

KT, I_FS, DAC_FS = 0.06, 8.0, 8191.0
Q0 = np.deg2rad([4.0, 46.0, 43.0])


def _settle_currents(p: Plant, codes: list[int], us: int = 5000) -> None:
    for ch, c in enumerate(codes):
        p.set_dac(ch, c)
    p.step(us)          # 5 ms = 63 time constants of the 2 kHz current loop


def test_motor_torque_matches_the_golden_winding_model():
    """Torque = sum of phase current x winding function of the true electrical angle; the
    same as hapgate.golden.commutation.motor_torque (scaled by kt * 2/3) on random currents and
    angles, within 1e-12 N m."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, 3)
        qi = rng.uniform(-np.pi, np.pi, 3)
        p = Plant(config(hand_kind=2, q0=q, q_index=qi))
        p.hold(True)
        codes = [int(c) for c in rng.integers(-8191, 8192, 6)]
        _settle_currents(p, codes)
        o = p.read()
        ia = np.array(codes[0::2]) / DAC_FS * I_FS
        ib = np.array(codes[1::2]) / DAC_FS * I_FS
        theta = 2 * (q - qi)
        _, ref = commutation.motor_torque(ia, ib, theta)
        np.testing.assert_allclose(o["tau"], KT * 2 / 3 * ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(o["theta_e"], theta, rtol=0, atol=1e-12)


def test_the_mechanics_step_drives_the_winding_model_torque():
    """The torque the mechanics step itself applies (its own trigonometry: the joints' and the
    electrical angles' sine and cosine rotated step by step between exact resyncs,
    plant.cpp joint_trig) is the golden winding model's at the true angle, within 1e-12 N m
    and 1e-12 rad, on a moving linkage with random index offsets over 300 steps (past four
    resyncs), for 1 us steps and for the multirate plant's 16 us ones."""
    rng = np.random.default_rng(11)
    for n_us in (1, 16):
        qi = rng.uniform(-np.pi, np.pi, 3)
        p = Plant(config(hand_kind=0, q0=Q0, q_index=qi, b_visc_nms=[0.0] * 3))
        p.hold(True)                     # the currents settle on their commands, joints held
        _settle_currents(p, [int(c) for c in rng.choice([-1, 1], 6) * rng.integers(1000, 2001, 6)])
        p.hold(False)
        p.set_q(Q0, np.array([3.0, -2.0, 1.5]))              # rad/s: 3 urad per 1 us step
        moved = 0.0
        for _ in range(300):
            o = p.mech_read(n_us)
            ia, ib = o["i_ab"][0::2], o["i_ab"][1::2]
            assert np.abs(o["i_ab"]).min() > 0.9               # A: a torque to get right
            _, ref = commutation.motor_torque(ia, ib, 2 * (o["q"] - qi))
            np.testing.assert_allclose(o["tau"], KT * 2 / 3 * ref, rtol=0, atol=1e-12)
            np.testing.assert_allclose(o["theta_e"], 2 * (o["q"] - qi), rtol=0, atol=1e-12)
            moved = max(moved, float(np.abs(o["q"] - Q0).max()))
        assert moved > 0.5 * 1.5 * 300 * n_us * 1e-6      # the joints moved (>= 1.5 rad/s)


@pytest.mark.parametrize("delta_deg", [0.0, 11.25, 45.0, 90.0])
def test_commutation_offset_costs_cos_delta(delta_deg):
    """A sine drive aimed delta away from the true electrical angle delivers kt I cos(delta)."""
    q = Q0.copy()
    qi = np.zeros(3)
    p = Plant(config(hand_kind=2, q0=q, q_index=qi))
    p.hold(True)
    th = 2 * q + np.deg2rad(delta_deg)
    amp = 4000
    codes = []
    for m in range(3):
        codes += [int(round(amp * np.sin(th[m]))), int(round(amp * np.sin(th[m] - 2 * np.pi / 3)))]
    _settle_currents(p, codes)
    expect = KT * amp / DAC_FS * I_FS * np.cos(np.deg2rad(delta_deg))
    # budget: the codes' rounding, 0.5/4000 of the amplitude per phase
    np.testing.assert_allclose(p.read()["tau"], expect, atol=KT * I_FS * 1.5 / DAC_FS)


def test_current_loop_is_a_first_order_lag_with_the_amplifier_limit():
    p = Plant(config(hand_kind=2, q0=Q0, current_bw_hz=2000.0))
    p.hold(True)
    p.set_dac(0, 4096)                     # 4 A command
    tau_us = 1e6 / (2 * np.pi * 2000.0)    # 79.6 us
    p.step(int(round(tau_us)))
    i = p.read()["i_ab"][0]
    assert abs(i / (4096 / DAC_FS * I_FS) - (1 - np.exp(-round(tau_us) / tau_us))) < 1e-9
    p.set_dac(1, 20000)                    # beyond full scale: limited to 8 A
    p.step(5000)
    assert abs(p.read()["i_ab"][1] - 8.0) < 1e-9


def test_rigid_grip_holds_the_static_force_jt_tau():
    """hand = fixed: the force on the hand is J^-T tau (static equilibrium) at the held pose,
    against the golden kinematics, within 1e-9 N."""
    q = Q0.copy()
    p = Plant(config(hand_kind=2, q0=q, q_index=np.zeros(3)))
    th = 2 * q
    amp = np.array([1000, 3000, -2500])
    codes = []
    for m in range(3):
        codes += [int(round(amp[m] * np.sin(th[m]))),
                  int(round(amp[m] * np.sin(th[m] - 2 * np.pi / 3)))]
    _settle_currents(p, codes, 5000)
    o = p.read()
    jac = kinematics.jacobian(q)
    f = np.linalg.solve(jac.T, o["tau"])
    np.testing.assert_allclose(o["f_hand"], f, atol=1e-9)
    np.testing.assert_allclose(o["q"], q, atol=0)           # the grip does not let it move
    assert np.linalg.norm(f) > 0.5                           # a real force was measured


def test_free_frictionless_linkage_conserves_energy():
    """No torque, no friction, no hand: kinetic energy 0.5 qd^T M(q) qd is conserved by the
    semi-implicit Euler step at dt = 1 us within 1e-5 of its value over 0.3 s of motion that
    sweeps the configuration (budget 1e-5: the step's error is O(dt |qdd|) and bounded for a
    symplectic step; measured 3.4e-7)."""
    p = Plant(config(hand_kind=0, q0=Q0, b_visc_nms=[0, 0, 0]))
    p.set_q(Q0, np.array([0.8, -1.1, 1.4]))    # rad/s
    e0 = None
    es = []
    for _ in range(300):
        p.step(1000)
        o = p.read()
        e0 = o["energy"] if e0 is None else e0
        es.append(o["energy"])
    es = np.array(es)
    drift = np.abs(es / e0 - 1).max()
    assert drift < 1e-5, drift
    # and it did move through the workspace (not a trivial check)
    assert np.abs(p.read()["q"] - Q0).max() > 0.1


def test_friction_dissipates():
    p = Plant(config(hand_kind=0, q0=Q0, b_visc_nms=[2e-3, 2e-3, 2e-3]))
    p.set_q(Q0, np.array([1.0, 1.0, 1.0]))
    p.step(1000)
    e1 = p.read()["energy"]
    p.step(100000)
    assert p.read()["energy"] < 0.5 * e1


@pytest.mark.parametrize("phase_deg", [1.3, 0.0])   # (0: the plant's one-sincos path)
def test_encoder_front_end_is_the_encsig_model(phase_deg):
    """The same signal model as hapgate.golden.encsig: identical codes (noise-free) for
    imperfect signals over many lines, and the noise's standard deviation."""
    spec = encsig.SignalSpec(amplitude=112.0, offset_a=2.1, offset_b=-1.7, gain_a=1.013,
                             gain_b=0.991, phase_deg=phase_deg, h2=0.011, h3=0.007)
    p = Plant(config(enc_amplitude=[112.0] * 3, enc_offset_a=[2.1] * 3, enc_offset_b=[-1.7] * 3,
                     enc_gain_a=[1.013] * 3, enc_gain_b=[0.991] * 3,
                     enc_phase_deg=[phase_deg] * 3, enc_h2=[0.011] * 3, enc_h3=[0.007] * 3))
    lines = np.random.default_rng(5).uniform(-3000, 3000, 200_000)
    a, b = p.encode(1, lines)
    ra, rb = encsig.adc_codes(lines, spec)
    assert np.array_equal(a, ra) and np.array_equal(b, rb)   # same expressions, same libm
    # noise: 0.7 LSB sigma on every channel, measured at a fixed angle
    pn = Plant(config(enc_noise_lsb=[0.7] * 3, enc_amplitude=[100.0] * 3, q0=[0.3, 0.3, 0.3]))
    samples = np.array([pn.adc()[0] for _ in range(20000)], dtype=float)
    std = samples.std(axis=0)
    assert np.all(np.abs(std - 0.7) < 0.07), std


def test_index_channel_matches_encsig():
    p = Plant(config(q0=[0.0, 0.0, 0.0], q_index=[0.0, 0.0, 0.0]))
    qs = np.linspace(-0.02, 0.02, 4001)
    got = []
    for q in qs:
        p.set_q([q, q, q])
        got.append(p.adc()[2][0])
    ref = encsig.index_bit(qs / (2 * np.pi) * 1024)
    assert np.array_equal(np.array(got, bool), ref)
    assert ref.sum() > 0


def test_bad_configuration_is_refused():
    with pytest.raises(PlantError, match="unknown key"):
        Plant("no_such_key = 1\n")
    with pytest.raises(PlantError, match="expected 3 values"):
        Plant("q0 = 1 2\n")
    with pytest.raises(PlantError, match="bad number"):
        Plant("dt_s = nan\n")


def test_bringup_errors_in_the_windings_and_the_encoder():
    """comm_offset_deg c: the windings' zero c after the index, so a drive aimed at
    2 (q - q_index) + c delivers kt I; swapped phases: channel a feeds winding 1, b winding 0,
    so a drive must aim at -te - 60 deg (te the true electrical angle) and one aimed at te
    delivers kt I cos(2 te + 60 deg); encoder_dir -1: the A and B codes swapped at the ADC."""
    q = Q0.copy()
    c_deg = np.array([40.0, -120.0, 200.0])
    te = 2 * q + np.deg2rad(c_deg)
    amp = 4000
    full = KT * amp / DAC_FS * I_FS
    tol = KT * I_FS * 1.5 / DAC_FS          # the codes' rounding (as above)

    def drive(th: np.ndarray) -> list[int]:
        out = []
        for m in range(3):
            out += [int(round(amp * np.sin(th[m]))),
                    int(round(amp * np.sin(th[m] - 2 * np.pi / 3)))]
        return out

    base = dict(hand_kind=2, q0=q, q_index=np.zeros(3), comm_offset_deg=c_deg)
    p = Plant(config(**base))
    p.hold(True)
    _settle_currents(p, drive(te))
    np.testing.assert_allclose(p.read()["tau"], full, atol=tol)
    np.testing.assert_allclose(p.read()["theta_e"], te, atol=1e-12)
    sw = Plant(config(**base, phases_swapped=[1, 1, 1]))
    sw.hold(True)
    _settle_currents(sw, drive(-te - np.pi / 3))
    np.testing.assert_allclose(sw.read()["tau"], full, atol=tol)
    _settle_currents(sw, drive(te))
    np.testing.assert_allclose(sw.read()["tau"], full * np.cos(2 * te + np.pi / 3), atol=tol)
    # the encoder: axis 1 reversed, the others as before (channel A offset: A and B differ)
    lines = np.linspace(-3.0, 3.0, 977)
    ref = Plant(config(hand_kind=2, q0=q, enc_offset_a=[5, 5, 5]))
    rev = Plant(config(hand_kind=2, q0=q, encoder_dir=[1, -1, 1], enc_offset_a=[5, 5, 5]))
    for axis in range(3):
        a0, b0 = ref.encode(axis, lines)
        a1, b1 = rev.encode(axis, lines)
        assert not np.array_equal(a0, b0)
        assert (np.array_equal(a1, b0) and np.array_equal(b1, a0)) if axis == 1 else \
            (np.array_equal(a1, a0) and np.array_equal(b1, b0))
    with pytest.raises(PlantError, match="encoder_dir"):
        Plant(config(encoder_dir=[1, 0, 1]))
