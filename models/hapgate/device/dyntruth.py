"""The truth that bring-up's dynamics identification is judged against (issue 26,
docs/bringup.md, "Identified dynamics"). Everything comes from the scene's [plant] parameters
and the plant's own code (tb/native/device/plant.cpp through hapgate.device.plant). Nothing
comes from a fit.

The firmware identifies one axis while it holds the other two, so the axis sees:
- inertia: the diagonal entry of the plant's joint-space mass matrix M = J_r I + m J^T J at
  the pose (J from the plant's own Jacobian; m = m_link + m_handle, lumped at the endpoint);
- viscous and Coulomb friction: the plant's `b_visc_nms`, `tau_coulomb_nm` of that joint;
- gravity residual: dU/dq of that joint at the pose, the torque the plant's gravity puts on it
  (probed from the plant: one microsecond from rest with zero current gives M qdd = -dU/dq);
- kt x amplifier gain: the plant's `kt_nm_per_a` (its amplifier gives I_FS_A at full scale).
The fit is in the firmware's nominal torque scale. A plant whose kt differs from the one the
firmware is configured with would show J, b, c and g scaled by configured/true kt. The truth
applies that factor, so it compares like with like.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from . import plant as plant_mod
from . import runner

I_FS_A = 8.0                # tb/native/device/plant.cpp: i_fs (A at DAC full scale)
DAC_FS_CODE = 8191.0        # plant.cpp: dac_fs
REL_BUDGET = 0.05           # the goal: within 5 % of the plant's value ...
ABS_FLOOR_NM = 0.06 * I_FS_A / DAC_FS_CODE   # ... or one DAC step of torque (5.9e-5 N m) ...
N_SE = 3.0                  # ... or three standard errors of the firmware's own fit
KEYS = ("inertia_kg_m2", "b_visc_nms", "tau_coulomb_nm", "tau_gravity_nm")


def _plant(scene: Any, q: np.ndarray) -> plant_mod.Plant:
    text = runner.plant_config(scene, q)
    text = re.sub(r"(?m)^hand_kind = .*$", "hand_kind = 0", text)   # identification: hand off
    return plant_mod.Plant(text)


def mass_matrix(scene: Any, q: Any) -> np.ndarray:
    """The plant's joint-space mass matrix at q (rad)."""
    pl = scene.plant
    q = np.asarray(q, dtype=float)
    jac = _plant(scene, q).jacobian(q)
    m = pl.m_link_kg + pl.m_handle_kg
    return pl.j_rotor_kg_m2 * np.eye(3) + m * jac.T @ jac


def gravity(scene: Any, q: Any) -> np.ndarray:
    """dU/dq (N m) at q: the plant's gravity torque on each joint, from rest, zero current."""
    if not scene.plant.gravity_k:
        return np.zeros(3)
    q = np.asarray(q, dtype=float)
    p = _plant(scene, q)
    p.set_q(q)
    dt = scene.plant.dt_s
    p.step(1)
    qd = np.asarray(p.read()["qd"], dtype=float)
    return -mass_matrix(scene, q) @ qd / dt


def truth(scene: Any, axis: int, q: Any, kt_configured: float) -> dict[str, float]:
    """What the identification of `axis` at pose q should find, in the firmware's nominal
    torque scale (kt_configured: the kt it reports)."""
    pl = scene.plant
    scale = kt_configured / pl.kt_nm_per_a
    return {"inertia_kg_m2": float(mass_matrix(scene, q)[axis, axis]) * scale,
            "b_visc_nms": float(pl.b_visc_nms[axis]) * scale,
            "tau_coulomb_nm": float(pl.tau_coulomb_nm[axis]) * scale,
            "tau_gravity_nm": float(gravity(scene, q)[axis]) * scale,
            "kt_nm_per_a": float(pl.kt_nm_per_a)}


def budget(key: str, true_value: float, std_err: float = 0.0) -> float:
    """The allowed |identified - truth|: 5 % of the truth; for the torques (Coulomb, gravity)
    at least one DAC step, the smallest constant torque the device can command; and at least
    three standard errors of the fit (what the excitation resolves: the viscous term is a few
    % of the torque, and the encoder's interpolation error limits it)."""
    rel = REL_BUDGET * abs(true_value)
    if key in ("tau_coulomb_nm", "tau_gravity_nm"):
        rel = max(rel, ABS_FLOOR_NM)
    return max(rel, N_SE * std_err)


def errors(found: dict[str, float], true: dict[str, float]) -> dict[str, dict[str, float]]:
    """Per parameter: truth, found, error (found - truth), error in % of truth (None when the
    truth is 0), the budget and whether the error is within it."""
    out = {}
    se = found.get("std_err") or {}
    for k in (*KEYS, "kt_nm_per_a"):
        t, f = true[k], float(found[k])
        b = budget(k, t, float(se.get(k, 0.0)))
        out[k] = {"truth": t, "found": f, "error": f - t,
                  "error_pct": 100.0 * (f - t) / t if t else None, "budget": b,
                  "ok": bool(abs(f - t) <= b)}
    return out
