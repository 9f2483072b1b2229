"""Link compliance in the plant (tb/native/device/plant.cpp, README "Link compliance"): one
structural mode per joint, the rotor (and its encoder) coupled to the linkage by a spring and
a damper. Checked against the two-mass system's closed-form response with the linkage's
inertia from the golden kinematics (independent of the plant's own), static equilibrium in a
rigid grip, the encoder on the rotor, energy, and the rigid default left bit for bit as it was.
Budgets are stated beside each check."""

from __future__ import annotations

import numpy as np
import pytest
from hapgate.device.plant import Plant, PlantError, config
from hapgate.golden import encsig, kinematics

KT, I_FS, DAC_FS = 0.06, 8.0, 8191.0
J_R, M_END = 1.6e-5, 0.03          # the plant's defaults: rotor inertia, endpoint mass
Q0 = np.deg2rad([4.0, 46.0, 43.0])
K_LINK = 500.0                     # N m/rad: a mode near 1 kHz with these inertias


def _torque_codes(q: np.ndarray, amp: list[float]) -> list[int]:
    """DAC codes of a torque KT * amp / DAC_FS * I_FS on each motor (winding 0 at index 0)."""
    codes = []
    for m in range(3):
        th = 2 * q[m]
        codes += [int(round(amp[m] * np.sin(th))), int(round(amp[m] * np.sin(th - 2 * np.pi / 3)))]
    return codes


def _link_inertia(q: np.ndarray, axis: int) -> float:
    """The linkage's inertia seen by joint `axis`, the others held: m |J[:, axis]|^2."""
    jac = kinematics.jacobian(q)
    return M_END * float(jac[:, axis] @ jac[:, axis])


def _step_response(b_link: float) -> tuple[Plant, float, float, float]:
    """Joint 0 alone free, no hand or friction, a torque step from rest at t = 0 (a current
    loop 50x faster than the mode). Returns the plant, the step's torque and the mode's omega
    and decay rate sigma from the two-mass closed form."""
    p = Plant(config(hand_kind=0, q0=Q0, q_index=np.zeros(3), b_visc_nms=[0, 0, 0],
                     free=[1, 0, 0], current_bw_hz=50_000.0,
                     link_k_nm_per_rad=[K_LINK, 0, 0], link_b_nms_per_rad=[b_link, 0, 0]))
    amp = 2000.0
    for ch, c in enumerate(_torque_codes(Q0, [amp, 0, 0])):
        p.set_dac(ch, c)
    tau = KT * amp / DAC_FS * I_FS
    inv = 1 / J_R + 1 / _link_inertia(Q0, 0)
    omega0 = np.sqrt(K_LINK * inv)
    sigma = 0.5 * b_link * inv
    return p, tau, float(np.sqrt(omega0**2 - sigma**2)), float(sigma)


def _deflection(p: Plant) -> float:
    o = p.read()
    return float(o["qm"][0] - o["q"][0])


def test_undamped_mode_rings_at_the_two_mass_frequency():
    """A torque step on a free joint: deflection d(t) = d_ss (1 - cos w t), d_ss = tau / (J_r
    w^2), w^2 = k (1/J_r + 1/J_l). Read at a quarter, half and whole period: d_ss, 2 d_ss, 0,
    within 3 % of d_ss (the 3.2 us current-loop lag shifts the phase by w * 3.2 us = 2 %; the
    1 us Euler step's frequency error is (w dt)^2 / 24, 1e-6)."""
    p, tau, w, _ = _step_response(0.0)
    d_ss = tau / (J_R * w**2)
    period_us = 2 * np.pi / w * 1e6
    seen = []
    t = 0
    for frac in (0.25, 0.5, 1.0):
        n = int(round(frac * period_us)) - t
        p.step(n)
        t += n
        seen.append(_deflection(p))
    np.testing.assert_allclose(np.array(seen) / d_ss, [1.0, 2.0, 0.0], atol=0.03)
    assert 900 < w / (2 * np.pi) < 1200     # the mode is where the test means it to be


def test_damped_mode_decays_at_the_two_mass_rate():
    """With a link damper b: the overshoot at half the damped period is d_ss exp(-sigma T/2),
    sigma = b/2 (1/J_r + 1/J_l), within 3 % of d_ss."""
    b = 0.01
    p, tau, w, sigma = _step_response(b)
    d_ss = tau / (J_R * (w**2 + sigma**2))
    p.step(int(round(np.pi / w * 1e6)))
    over = _deflection(p) / d_ss - 1
    assert abs(over - np.exp(-sigma * np.pi / w)) < 0.03, (over, np.exp(-sigma * np.pi / w))
    assert over < 0.95                      # it did decay (the undamped overshoot is 1)


def test_rigid_grip_deflects_the_rotor_by_tau_over_k_and_holds_jt_force():
    """hand = fixed with a damped link: after settling, each rotor stands tau/k off the held
    joint (within 1e-3 of it) and the hand's force is J^-T tau, the rigid plant's (within
    1e-6 N); the encoder reads the rotor: its codes are encsig's of the rotor angle."""
    b = 2 * 0.7 * np.sqrt(K_LINK * J_R)    # damping ratio 0.7 of the rotor against the spring
    p = Plant(config(hand_kind=2, q0=Q0, q_index=np.zeros(3), link_k_nm_per_rad=[K_LINK] * 3,
                     link_b_nms_per_rad=[b] * 3, enc_noise_lsb=[0, 0, 0]))
    amp = [1000.0, 3000.0, -2500.0]
    for ch, c in enumerate(_torque_codes(Q0, amp)):
        p.set_dac(ch, c)
    p.step(20_000)
    o = p.read()
    np.testing.assert_allclose(o["q"], Q0, atol=0)
    defl = o["qm"] - Q0
    np.testing.assert_allclose(defl * K_LINK / o["tau"], 1.0, atol=1e-3)
    f = np.linalg.solve(kinematics.jacobian(Q0).T, o["tau"])
    np.testing.assert_allclose(o["f_hand"], f, atol=1e-6)
    a, bb, _ = p.adc()
    for i in range(3):
        ea, eb = encsig.adc_codes(np.array([o["qm"][i] / (2 * np.pi) * 1024]),
                                  encsig.SignalSpec(amplitude=110.0))
        assert (a[i], bb[i]) == (int(ea[0]), int(eb[0])), i
    assert np.abs(defl).min() > 1e-5           # the deflection is real (> 2 encoder counts)


def test_undamped_link_conserves_energy():
    """All joints free, no friction, no damper: a 2 ms torque kick sets the links ringing,
    then (currents off, a 50 kHz current loop: gone in 0.5 ms) kinetic + spring energy is
    conserved over 0.3 s (budgets below)."""
    p = Plant(config(hand_kind=0, q0=Q0, q_index=np.zeros(3), b_visc_nms=[0, 0, 0],
                     current_bw_hz=50_000.0,
                     link_k_nm_per_rad=[K_LINK, 2 * K_LINK, 3 * K_LINK]))
    for ch, c in enumerate(_torque_codes(Q0, [3000.0, -2000.0, 2500.0])):
        p.set_dac(ch, c)
    p.step(2000)
    for ch in range(6):
        p.set_dac(ch, 0)
    p.step(500)
    es = []
    for _ in range(300):
        p.step(1000)
        es.append(p.read()["energy"])
    es = np.array(es)
    # the symplectic step's energy error oscillates with the stiff modes (amplitude ~ w dt / 2
    # of their share, w dt = 0.01 here; measured 1.8e-4) and does not grow: no drift between
    # the first and the last 0.1 s beyond 2e-5 (measured 1e-6)
    assert np.abs(es / es[0] - 1).max() < 5e-4
    assert abs(es[-100:].mean() / es[:100].mean() - 1) < 2e-5
    assert np.abs(p.read()["qm"] - p.read()["q"]).max() > 1e-6   # the links did flex


def test_the_rigid_default_is_unchanged_by_a_zero_link():
    """link_k = 0 is the rigid plant: the same state bit for bit as a configuration without
    the keys, after 20 ms of a driven free linkage; and qm is q."""
    base = dict(hand_kind=0, q0=Q0, q_index=np.zeros(3))
    p0, p1 = Plant(config(**base)), Plant(config(**base, link_k_nm_per_rad=[0, 0, 0]))
    for p in (p0, p1):
        for ch, c in enumerate(_torque_codes(Q0, [800.0, -600.0, 700.0])):
            p.set_dac(ch, c)
        p.step(20_000)
    o0, o1 = p0.read(), p1.read()
    for k in ("q", "qd", "tau", "energy"):
        np.testing.assert_array_equal(o0[k], o1[k])
    np.testing.assert_array_equal(o0["qm"], o0["q"])
    assert np.abs(o0["q"] - Q0).max() > 1e-3


@pytest.mark.parametrize("text", ["link_k_nm_per_rad = -1 0 0\n",
                                  "link_b_nms_per_rad = 0 0.1 0\n",
                                  "link_k_nm_per_rad = 1 2\n"])
def test_bad_link_configuration_is_refused(text: str):
    with pytest.raises(PlantError, match="link_"):
        Plant(text)
