"""Z-width of the virtual wall (Colgate & Brown 1994): which wall stiffness K and damping B the
device renders stably, with the Verilated gateware and the unchanged firmware in the loop.

One job = one closed-loop run of the virtual device (`runner.simulate`, rtl fidelity) of the base
scene (scenes/sweeps/zwidth_base.toml) with `env.k`, `env.b`, `run.servo_hz` set: one axis (β;
α and γ held), the wall's normal along β's direction of motion at the start pose (so the contact
is the 1-DOF one β renders; the held joints carry no normal motion), a light hand
(100 N/m, 1 N·s/m spring) whose target lies 2 mm behind the surface presses the handle into the
wall with ~0.2 N; the handle starts pushed in to 1.5 x its static depth d_eq = k_h·2 mm/(k_h + K)
and is released there at t = 0 (a step of half the static depth: in a stable wall it stays in
contact and rings down; in an unstable one the oscillation grows into contact chatter).

Stability criterion (sustained oscillation): with the depth d(t) = (point − p)·n of the true
endpoint and the static depth d_eq, the released step is A0 = |d(0) − d_eq| = d_eq/2; the late
oscillation A_late is half the peak-to-peak of d over the last 40 ms (t = 210..250 ms) after
removing its quadratic trend (a heavily damped wall creeps slowly towards d_eq: that is not an
oscillation). The contact is UNSTABLE when the firmware latched an error, the run is not finite,
or A_late > A_ABS_M = 5 µm (16 counts of the interpolated encoder at the 5 cm arm; 1/15 of one
quadrature step) and A_late > 0.5·A0 (the oscillation did not at least halve in 0.21 s: growing,
sustained or barely damped — a decay rate under ln 2/0.21 s = 3.3 /s, where the physical damping
alone gives b/2m = 15 /s). Else STABLE. The unstable modes of this loop are fast (the phase lag
of the hold and the latency reaches 180° at 10^2..10^3 Hz: several periods in 40 ms).

Further job parameters (issue 37): `hand` (HANDS: "light", the base scene's; "spring", the
same spring undamped; "grip", a rigid grip, judged on the hand's force since the linkage is
held), the plant's `plant.current_bw_hz` and link compliance, and `test = "impact"` (below:
rate-hardness from a 0.1 m/s impact). A stable release also reports `k_static`, the stiffness
felt at the handle (F/x over the late window), so a virtual K is never mistaken for a felt one.

Theory: the endpoint sees a mass m and physical damping b (the hand's 1 N·s/m plus the joint's
viscous friction referred to the endpoint, 0.08 N·s/m): passivity of the sampled wall needs
b > K·T/2 + |B| (Colgate & Schenkel), so K_max(B = 0) ≈ 2b/T. `ideal_kmax` gives the largest
stable K of the idealised loop (mass-damper, wall sampled and held every T, no quantization,
filtering or delay), an exact discrete-time eigenvalue computation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..golden import kinematics
from . import runner
from .scene import load as load_scene

AXIS = 1
TARGET_DEPTH_M = 2e-3
D0_FACTOR = 1.5
LATE_S = 0.04
A_ABS_M = 5e-6
DECAY = 0.5
SCENE_KEYS = ("env.k", "env.b", "run.servo_hz", "run.duration_s", "hand.k", "hand.b",
              "run.clk_hz", "run.position", "plant.current_bw_hz", "plant.link_k_nm_per_rad",
              "plant.link_b_nms_per_rad")
# The hand on the handle (a job parameter `hand`, default "light"): the base scene's light hand
# (a 100 N/m, 1 N s/m spring to a target behind the surface); the same spring undamped; or a
# rigid grip (the plant's hand kind "fixed": the linkage is held where it starts and only the
# rotors move, against the link compliance (plant.link_k_nm_per_rad): a grip's Z-width is that
# of the rotor on its structural mode, and a rigid linkage in a rigid grip has nothing that
# can oscillate). A value None removes the base scene's key (Scene.override).
HANDS: dict[str, dict[str, Any]] = {
    "light": {}, "spring": {"hand.b": 0.0},
    "grip": {"hand.kind": "fixed", "hand.k": None, "hand.b": None}}
F_ABS_N = 5e-3     # a grip's late force oscillation below 5 mN is stable (~15 DAC codes' torque
                   # at the 5 cm arm): the grip's counterpart of A_ABS_M
# The velocity the firmware's wall damping uses: a job parameter `velocity` (a grid axis of a
# spec, default "fir") mapped to the scene overrides that select it: "observer" builds the
# gateware with the tracking observer (VEL_OBS = 1) and VEL_CTRL.SEL reset to it (scene key
# run.velocity), so the unchanged firmware's VEL reads are the observer's.
VELOCITY_SCENE: dict[str, dict[str, Any] | None] = {"fir": {},
                                                    "observer": {"run.velocity": "observer"}}


def geometry(scene: Any) -> dict[str, Any]:
    """Start endpoint, the wall's normal (into free space, against β's motion) and the
    endpoint's mass and physical damping along it: the whole linkage's with a spring hand; in a
    rigid grip, the rotor's alone (its inertia and its bearing's and link's damping referred
    to the endpoint), the only thing that moves."""
    q0 = runner.start_pose(scene)
    p0 = kinematics.fk(q0)
    j1 = kinematics.jacobian(q0[None])[0][:, AXIS]
    r = float(np.linalg.norm(j1))
    n = -j1 / r
    pl = scene.plant
    if scene.hand.kind == "fixed":
        m = pl.j_rotor_kg_m2 / r ** 2
        b = (float(pl.b_visc_nms[AXIS]) + float(pl.link_b_nms_per_rad[AXIS])) / r ** 2
    else:
        m = pl.j_rotor_kg_m2 / r ** 2 + pl.m_link_kg + pl.m_handle_kg
        b = float(pl.b_visc_nms[AXIS]) / r ** 2 + (scene.hand.b if scene.hand.kind == "spring"
                                                   else 0.0)
    return {"q0": q0, "p0": p0, "n": n, "r_m": r, "m_kg": m, "b_nsm": b}


def tau_loop_s(current_bw_hz: float) -> float:
    """The loop's latency beyond the sample-and-hold with the amplifier's current loop of this
    bandwidth (TAU_LOOP_S: the same parts, 2 kHz)."""
    return TAU_FIXED_S + 1 / (2 * math.pi * current_bw_hz)


def scene_of(p: Mapping[str, Any]) -> Any:
    base = load_scene(str(p["base"]))
    k_hand = float(base.hand.k)            # the press (static depth) is the light hand's
    changes = {k: p[k] for k in SCENE_KEYS if k in p}
    changes.update(VELOCITY_SCENE[str(p.get("velocity", "fir"))] or {})
    changes.update(HANDS[str(p.get("hand", "light"))])
    grip = changes.get("hand.kind") == "fixed"
    if "run.servo_hz" in changes:
        changes["run.servo_hz"] = int(changes["run.servo_hz"])
    sc = base.override(changes)
    g = geometry(sc)
    # the hand's target TARGET_DEPTH_M behind the surface; the handle starts at 1.5 x the
    # static depth (a step of half the static depth out of equilibrium, still in contact)
    k = float(sc.env.k)
    d_eq = k_hand * TARGET_DEPTH_M / (k_hand + k)
    d0 = float(p.get("d0_factor", D0_FACTOR)) * d_eq
    point = g["p0"] + d0 * g["n"]
    target = point - TARGET_DEPTH_M * g["n"]
    g["d_eq_m"], g["d0_m"] = d_eq, d0
    place = {"env.point": [float(v) for v in point], "env.normal": [float(v) for v in g["n"]],
             "run.q0_deg": [float(v) for v in np.rad2deg(g["q0"])],
             "run.record": sorted(set(sc.run.record) | {"p", "f_hand"})}
    if not grip:
        place["hand.path"] = [[0.0, *(float(v) for v in target)]]
    return sc.override(place), g


def check(p: Mapping[str, Any]) -> None:
    if "base" not in p:
        raise ValueError("sweep.base: the Z-width job needs a base scene")
    if p.get("run.position", "interpolated") not in ("interpolated", "quadrature"):
        raise ValueError("run.position: 'interpolated' or 'quadrature'")
    if str(p.get("test", "release")) not in ("release", "impact"):
        raise ValueError(f"test: {p.get('test')!r}: 'release' or 'impact'")
    if str(p.get("test", "release")) == "impact":
        v = p.get("impact_mps", 0.1)
        if not isinstance(v, (int, float)) or not 0.01 <= float(v) <= 0.5:
            raise ValueError(f"impact_mps: {v!r} out of range: 0.01..0.5 m/s")
        impact_scene(p)
        return
    if str(p.get("hand", "light")) not in HANDS:
        raise ValueError(f"hand: {p.get('hand')!r}: one of {', '.join(HANDS)}")
    vel = p.get("velocity", "fir")
    if vel not in VELOCITY_SCENE:
        raise ValueError(f"velocity: {vel!r}: one of {', '.join(VELOCITY_SCENE)}")
    if VELOCITY_SCENE[vel] is None:
        raise ValueError(f"velocity: {vel!r} is not available yet (the observer of issue 13 is "
                         "not on main; zwidth.VELOCITY_SCENE is the hook)")
    scene_of(p)


def oscillation(t: np.ndarray, d: np.ndarray) -> float:
    """Half the peak-to-peak of d in the window after removing its quadratic trend: the
    oscillation, not a slow (overdamped) creep towards the static depth."""
    if t.size < 8 or not np.isfinite(d).all():
        return math.nan
    x = (t - t.mean()) / max(float(np.ptp(t)), 1e-12)
    r = d - np.polyval(np.polyfit(x, d, 2), x)
    return float(np.ptp(r) / 2)


def job(p: Mapping[str, Any]) -> dict[str, Any]:
    check(p)
    if str(p.get("test", "release")) == "impact":
        return impact_job(p)
    sc, g = scene_of(p)
    raw = runner.simulate(sc)
    fr = raw.frames
    t = fr["t"]
    n = np.asarray(sc.env.normal)
    depth = (np.asarray(sc.env.point) - fr["p"]) @ n
    force = fr["f_hand"] @ n                # the wall's push on the hand, along the normal
    dur = float(sc.run.duration_s)
    late = t >= dur - LATE_S
    grip = sc.hand.kind == "fixed"
    if grip:   # the linkage is held: the rotor's ringing shows in the hand's force
        a_early, a_abs = float(sc.env.k) * g["d0_m"], F_ABS_N     # the wall's force step
        a_late = oscillation(t[late], force[late])
    else:
        a_early, a_abs = abs(g["d0_m"] - g["d_eq_m"]), A_ABS_M    # the released step
        a_late = oscillation(t[late], depth[late])
    err = int(raw.summary["fw_err"])
    finite = bool(np.isfinite(depth).all() and np.isfinite(force).all())
    stable = (err == 0 and finite and math.isfinite(a_late)
              and not (a_late > a_abs and a_late > DECAY * a_early))
    # the stiffness felt at the handle, F/x over the late window (a stable contact only):
    # the force the hand takes over the depth the true endpoint holds (with a grip: the
    # wall's force over the held depth)
    d_late = float(np.mean(depth[late])) if late.any() else math.nan
    k_static = (float(np.mean(force[late])) / d_late if stable and d_late > 0 else math.nan)
    v = np.diff(depth[late])
    crossings = int((np.signbit(v[1:]) != np.signbit(v[:-1])).sum()) if v.size > 1 else 0
    T = 1.0 / float(sc.run.servo_hz)
    bw = float(sc.plant.current_bw_hz)
    tau = tau_loop_s(bw)
    return {"k": float(sc.env.k), "b_wall": float(sc.env.b), "servo_hz": int(sc.run.servo_hz),
            "position": str(sc.run.position), "velocity": str(p.get("velocity", "fir")),
            "hand": str(p.get("hand", "light")), "current_bw_hz": bw,
            "link_k": float(sc.plant.link_k_nm_per_rad[AXIS]),
            "link_b": float(sc.plant.link_b_nms_per_rad[AXIS]),
            "stable": bool(stable),
            # the oscillation's measure: the depth in um, or with a grip the force in mN
            "a_unit": "mN" if grip else "um",
            "a_early_um": a_early * (1e3 if grip else 1e6),
            "a_late_um": a_late * (1e3 if grip else 1e6),
            "k_static": k_static, "tau_s": tau,
            "latency_k": latency_bound(g["b_nsm"], float(sc.env.b), T, tau),
            "late_half_periods": crossings, "depth_max_um": float(np.nanmax(depth) * 1e6),
            "fw_error": runner.ERR_NAMES[err] if err < len(runner.ERR_NAMES) else str(err),
            "b_phys_nsm": g["b_nsm"], "m_eff_kg": g["m_kg"], "d_eq_um": g["d_eq_m"] * 1e6,
            "passivity_k": 2 * (g["b_nsm"] - abs(float(sc.env.b))) / T,
            "sim_s": float(raw.summary["sim_s"]), "harness_s": raw.wall_s}


# ---------------------------------------------------------------------------------- impact
# Rate-hardness (Lawrence et al., T-RA 16(4), 2000): the initial rate of the contact force over
# the approach speed, in N/m (an ideal spring's is its K; a sampled, delayed wall's is less: a
# virtual K is not what the hand feels at impact). The job parameter `test = "impact"`: the
# hand, a firm grasp (IMPACT_HAND_K, IMPACT_HAND_B: overdamped on the endpoint's mass, so the
# handle follows its target closely), drives the handle from IMPACT_GAP_M outside the wall to
# IMPACT_PUSH_M inside along one smoothstep whose peak speed, at mid-travel (the surface: the
# handle crosses it near its own top speed), is `impact_mps` (default 0.1 m/s). Measured,
# never assumed: the handle's speed as the true endpoint crosses the surface (a least-squares
# slope over the IMPACT_FIT_S before it), the wall's force on the handle J^-T tau along the
# normal, its mean rate over the first IMPACT_RATE_S of contact, and their ratio; and the
# static stiffness F/x at the end, over the last LATE_S.
IMPACT_HAND_K, IMPACT_HAND_B = 2000.0, 20.0      # N/m, N s/m
IMPACT_GAP_M, IMPACT_PUSH_M = 3e-3, 3e-3
IMPACT_FIT_S, IMPACT_RATE_S = 0.5e-3, 2e-3
IMPACT_SETTLE_S = 0.15                           # after the target stops


def impact_scene(p: Mapping[str, Any]) -> tuple[Any, dict[str, Any]]:
    base = load_scene(str(p["base"]))
    changes = {k: p[k] for k in SCENE_KEYS if k in p}
    changes.update(VELOCITY_SCENE[str(p.get("velocity", "fir"))] or {})
    if "run.servo_hz" in changes:
        changes["run.servo_hz"] = int(changes["run.servo_hz"])
    changes.update({"hand.k": IMPACT_HAND_K, "hand.b": IMPACT_HAND_B})
    sc = base.override(changes)
    g = geometry(sc)
    v = float(p.get("impact_mps", 0.1))
    travel = IMPACT_GAP_M + IMPACT_PUSH_M
    t_move = 1.5 * travel / v                 # smoothstep: peak speed 1.5 x the mean
    point = g["p0"] - IMPACT_GAP_M * g["n"]   # the surface IMPACT_GAP_M ahead of the handle
    end = point - IMPACT_PUSH_M * g["n"]
    g.update(v_target=v, t_move_s=t_move)
    return sc.override({
        "env.point": [float(x) for x in point], "env.normal": [float(x) for x in g["n"]],
        "run.q0_deg": [float(x) for x in np.rad2deg(g["q0"])],
        "run.duration_s": round(t_move + IMPACT_SETTLE_S, 6),
        "run.record": sorted(set(sc.run.record) | {"p", "q", "tau"}),
        "hand.path": [[0.0, *(float(x) for x in g["p0"])],
                      [round(t_move, 6), *(float(x) for x in end)]]}), g


def impact_job(p: Mapping[str, Any]) -> dict[str, Any]:
    sc, g = impact_scene(p)
    raw = runner.simulate(sc)
    fr = raw.frames
    t, n = fr["t"], np.asarray(sc.env.normal)
    depth = (np.asarray(sc.env.point) - fr["p"]) @ n
    # the motors' force at the endpoint, F = J^-T tau, along the normal (out of the wall)
    jac = kinematics.jacobian(fr["q"])
    f_dev = np.linalg.solve(np.transpose(jac, (0, 2, 1)), fr["tau"][..., None])[..., 0]
    force = f_dev @ n
    err = int(raw.summary["fw_err"])
    inside = np.flatnonzero(depth >= 0)
    out = {"k": float(sc.env.k), "b_wall": float(sc.env.b), "servo_hz": int(sc.run.servo_hz),
           "hand": "impact", "current_bw_hz": float(sc.plant.current_bw_hz),
           "v_target": g["v_target"], "fw_error": runner.ERR_NAMES[err]
           if err < len(runner.ERR_NAMES) else str(err),
           "sim_s": float(raw.summary["sim_s"]), "harness_s": raw.wall_s}
    if inside.size == 0 or err:
        return out | {"contact": False, "v_contact": math.nan, "rate_hardness": math.nan,
                      "k_static": math.nan}
    i0 = int(inside[0])
    tc = float(t[i0])
    pre = (t >= tc - IMPACT_FIT_S) & (t <= tc)
    v_c = float(np.polyfit(t[pre], depth[pre], 1)[0]) if pre.sum() >= 2 else math.nan
    f0 = float(np.interp(tc, t, force))
    f1 = float(np.interp(tc + IMPACT_RATE_S, t, force))
    late = t >= float(t[-1]) - LATE_S
    d_late = float(np.mean(depth[late]))
    return out | {"contact": True, "t_contact_s": tc, "v_contact": v_c,
                  "rate_hardness": (f1 - f0) / IMPACT_RATE_S / v_c if v_c > 0 else math.nan,
                  "k_static": float(np.mean(force[late])) / d_late if d_late > 0 else math.nan,
                  "depth_late_um": d_late * 1e6}


# ---------------------------------------------------------------------------------- theory
# The loop's latency beyond the sample-and-hold, s: the position snapshot's age at the tick
# (frame latch every 16 us: 8 us on average), the ISR until the torque write (~14 bus accesses
# x 2 us: 28 us), the wait for the next commutation frame (8 us on average), the DAC load (2 us)
# and the amplifier's current loop (first-order lag, 1/(2 pi 2 kHz) = 80 us; tau_loop_s for
# another bandwidth).
TAU_FIXED_S = 8e-6 + 28e-6 + 8e-6 + 2e-6
TAU_LOOP_S = TAU_FIXED_S + 1 / (2 * math.pi * 2000.0)


def latency_bound(b: float, b_wall: float, T: float, tau: float = TAU_LOOP_S) -> float:
    """The passivity bound with the loop's latency: a sampled, delayed spring K acts as the
    negative damping K (T/2 + tau), so b > K (T/2 + tau) + |B|: K_max = (b - |B|)/(T/2 + tau);
    tau = 0 gives Colgate's 2(b - |B|)/T."""
    return max(b - abs(b_wall), 0.0) / (T / 2 + tau)


def ideal_kmax(m: float, b: float, T: float, k_hi: float = 1e7, iters: int = 60) -> float:
    """Largest K for which the idealised sampled wall (m x'' = -b x' - K x(kT) held over T) is
    stable: discrete closed-loop eigenvalues inside the unit circle (bisection on K; the loop
    over bisection steps is over K, not over samples)."""
    a = np.array([[0.0, 1.0], [0.0, -b / m]])
    # exact zero-order-hold discretisation: Phi = e^{aT}, Gamma = int_0^T e^{as} ds (0, 1/m)
    aug = np.zeros((3, 3))
    aug[:2, :2] = a * T
    aug[1, 2] = T / m
    e = _expm(aug)
    phi, gam = e[:2, :2], e[:2, 2]

    def stable(k: float) -> bool:
        cl = phi - np.outer(gam, [k, 0.0])
        return bool(np.max(np.abs(np.linalg.eigvals(cl))) < 1.0)

    lo, hi = 0.0, k_hi
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def _expm(x: np.ndarray, terms: int = 30) -> np.ndarray:
    """Matrix exponential by scaling and squaring of a Taylor series (small matrices)."""
    s = max(0, int(math.ceil(math.log2(max(np.abs(x).sum(), 1e-300)))) + 1)
    y = x / 2.0 ** s
    out = np.eye(x.shape[0])
    term = np.eye(x.shape[0])
    for i in range(1, terms):
        term = term @ y / i
        out = out + term
    for _ in range(s):
        out = out @ out
    return out
