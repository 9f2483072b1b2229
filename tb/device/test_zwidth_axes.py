"""The Z-width job's further axes (hapgate.device.zwidth; issue 37, item 4): the hand (the light
hand, an undamped spring, a rigid grip), the amplifier's current-loop bandwidth, the link
compliance, the static stiffness felt at the handle (F/x) and rate-hardness from a 0.1 m/s
impact. Each check is a physical prediction made outside the job: the bounds' ordering, the
series stiffness of the wall and the link, an ideal spring's rate-hardness K."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.device import zwidth
from hapgate.device.scene import load as load_scene

BASE = str(Path(__file__).resolve().parents[2] / "scenes" / "sweeps" / "zwidth_base.toml")


def _job(**kw: object) -> dict[str, object]:
    return zwidth.job({"base": BASE, **kw})


def test_the_hand_sets_the_damping_the_wall_can_spend():
    """At 1 kHz a 600 N/m wall is stable in the light hand (b = 1.08 N s/m: latency bound
    1726 N/m) and unstable in the same spring undamped (b = 0.08 N s/m: bound 128 N/m); the
    stable wall is felt at the handle as 600 N/m within 2 % (F/x of the true endpoint)."""
    light = _job(**{"env.k": 600.0})
    spring = _job(**{"env.k": 600.0, "hand": "spring"})
    assert light["stable"] and not spring["stable"], (light, spring)
    assert spring["latency_k"] < 600.0 < light["latency_k"]
    assert light["k_static"] == pytest.approx(600.0, rel=0.02)


def test_a_rigid_grip_feels_the_wall_in_series_with_the_link():
    """A rigid grip holds the linkage. On a rigid linkage nothing moves: stable, and the felt
    stiffness is K within 0.5 % (the encoder's quantisation). With a link spring k_l the rotor
    yields under the wall's own force, so the hand feels K and k_l / r^2 in series, within 2 %
    (r: the joint's lever at this pose)."""
    k = 3000.0
    rigid = _job(**{"env.k": k, "hand": "grip"})
    assert rigid["stable"] and rigid["k_static"] == pytest.approx(k, rel=0.005), rigid
    k_link = 150.0
    soft = _job(**{"env.k": k, "hand": "grip", "plant.link_k_nm_per_rad": [0.0, k_link, 0.0],
                   "plant.link_b_nms_per_rad": [0.0, 0.002, 0.0]})
    r = zwidth.geometry(load_scene(BASE))["r_m"]
    series = 1 / (1 / k + r**2 / k_link)
    assert soft["stable"], soft
    assert soft["k_static"] == pytest.approx(series, rel=0.02), (soft["k_static"], series)
    assert series < 0.97 * k                                  # the link's share is measurable


def test_a_faster_current_loop_widens_the_z_width():
    """At a 10 kHz servo the amplifier's lag dominates the loop's latency: a 5300 N/m wall at
    B = 0 is beyond the 2 kHz amplifier's K_max (3158..4460 N/m measured, scenes/sweeps) and
    stable with a 10 kHz one; the latency bound orders them the same way."""
    slow = _job(**{"env.k": 5300.0, "run.servo_hz": 10000})
    fast = _job(**{"env.k": 5300.0, "run.servo_hz": 10000, "plant.current_bw_hz": 10000.0})
    assert not slow["stable"] and fast["stable"], (slow, fast)
    assert fast["tau_s"] < slow["tau_s"] and fast["latency_k"] > slow["latency_k"]


def test_impact_rate_hardness_is_below_k_and_grows_with_the_servo_rate():
    """A 0.1 m/s impact on a 1000 N/m wall at B = 0: the handle meets the surface at 0.1 m/s
    within 5 %; the mean force rate over the first 2 ms over that speed (rate-hardness) is
    below the ideal spring's K (+3 %: the force is sampled every 16 us) and higher at 10 kHz than
    at 1 kHz (the hold and the latency delay the first force); the static F/x at the end is K
    within 1 %."""
    r1 = _job(test="impact", **{"env.k": 1000.0, "run.servo_hz": 1000})
    r10 = _job(test="impact", **{"env.k": 1000.0, "run.servo_hz": 10000})
    for r in (r1, r10):
        assert r["contact"] and r["v_contact"] == pytest.approx(0.1, rel=0.05), r
        assert r["k_static"] == pytest.approx(1000.0, rel=0.01), r
    assert r1["rate_hardness"] < r10["rate_hardness"] < 1030.0, (r1, r10)
    assert r1["rate_hardness"] > 300.0                      # a real force rise was measured


@pytest.mark.parametrize("params,match", [
    ({"hand": "glove"}, r"hand: 'glove': one of light, spring, grip"),
    ({"test": "drop"}, r"test: 'drop': 'release' or 'impact'"),
    ({"test": "impact", "impact_mps": 2.0}, r"impact_mps: 2.0 out of range"),
])
def test_bad_job_parameters_are_refused(params: dict[str, object], match: str):
    with pytest.raises(ValueError, match=match):
        zwidth.check({"base": BASE, **params})
