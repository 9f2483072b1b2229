"""dsp-fw: C unit tests, PC-link fuzz, firmware kinematics against the numpy model of
docs/design/KINEMATICS.md (models/hapgate/golden/kinematics.py), and the PC link driven from
Python."""

from __future__ import annotations

import fcntl
import io
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hapgate.flows import regmap
from hapgate.golden import kinematics as kin
from hapgate.golden import pclink

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "dsp-fw"
BUILD = ROOT / "build" / "dsp-fw"
SUMMARY = re.compile(r"(\d+) passed, (\d+) failed")


def make(*targets: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """make in dsp-fw; serialised across pytest-xdist workers by a lock in the build dir."""
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return subprocess.run(["make", "-s", "-C", str(FW), f"BUILD={BUILD}", *targets],
                              check=False, capture_output=True, text=True, timeout=timeout)


def built(*targets: str) -> None:
    r = make(*targets)
    assert r.returncode == 0, r.stdout + r.stderr


def test_c_unit_tests() -> None:
    r = make("test")
    last = r.stdout.strip().splitlines()[-1]
    m = SUMMARY.fullmatch(last)
    assert m, r.stdout + r.stderr
    assert int(m[2]) == 0 and int(m[1]) >= 31, r.stdout
    assert r.returncode == 0


@pytest.mark.parametrize("group", ["servo_step_response", "servo_torque_clamp", "safety_nonfinite",
                                   "safety_fault_bit", "safety_fpga_fault", "safety_encoder_jump",
                                   "safety_stale", "link_bad_frames", "scene_antiwindup"])
def test_c_group(group: str) -> None:
    """The controller and safety tests one by one, so a failure names its path."""
    built(str(BUILD / "hg_tests"))
    r = subprocess.run([BUILD / "hg_tests", group], check=False, capture_output=True, text=True,
                       timeout=60)
    assert r.stdout.strip().splitlines()[-1] == "1 passed, 0 failed", r.stdout


def test_fuzz() -> None:
    r = make("fuzz", "FUZZ_FRAMES=300000", "FUZZ_SEED=7", timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "fuzz PASSED" in r.stdout
    frames = int(re.search(r"fuzz: (\d+) frames", r.stdout)[1])
    counts = dict(re.findall(r"(good|framing|crc|version|type|len) (\d+)", r.stdout))
    assert frames >= 300_000
    assert sum(int(v) for v in counts.values()) == frames
    assert all(int(counts[k]) > 1000 for k in counts), counts  # every class exercised


# ---- kinematics -------------------------------------------------------------------------

def workspace_q(n: int, seed: int) -> np.ndarray:
    """Poses inside the default workspace walls (alpha +-60, beta/gamma -60..85,
    beta+gamma 20..160 deg), away from every singular set."""
    rng = np.random.default_rng(seed)
    q = np.deg2rad(rng.uniform([-60, -60, -60], [60, 85, 85], size=(4 * n, 3)))
    s = q[:, 1] + q[:, 2]
    return q[(s > np.deg2rad(20)) & (s < np.deg2rad(160))][:n]


def kin_dump(flavour: str, q: np.ndarray, f: np.ndarray) -> dict[str, np.ndarray]:
    built("kin-dump")
    rows = "\n".join(",".join(f"{x:.17g}" for x in r) for r in np.hstack([q, f]))
    r = subprocess.run([BUILD / f"kin-dump-{flavour}"], input=rows + "\n", capture_output=True,
                       text=True, timeout=60, check=True)
    a = np.atleast_1d(np.genfromtxt(io.StringIO(r.stdout), delimiter=",", names=True))
    out = {name: a[name] for name in a.dtype.names}
    out["p"] = np.stack([a["x"], a["y"], a["z"]], -1)
    out["J"] = np.stack([a[f"j{i}{j}"] for i in range(3) for j in range(3)], -1).reshape(-1, 3, 3)
    out["tau"] = np.stack([a["ta"], a["tb"], a["tg"]], -1)
    out["qik"] = np.stack([a["ika"], a["ikb"], a["ikg"]], -1)
    return out


@pytest.fixture(scope="module")
def poses() -> tuple[np.ndarray, np.ndarray, dict, dict]:
    q = workspace_q(2000, seed=6)
    f = np.random.default_rng(7).uniform(-5, 5, size=q.shape)
    return q, f, kin_dump("d", q, f), kin_dump("f", q, f)


def test_fk_against_construction(poses) -> None:
    q, _, d, _ = poses
    ref = kin.fk_construct(q)
    assert np.abs(d["p"] - ref).max() < 1e-15 * 100           # C double vs the mechanism
    assert np.abs(kin.fk(q) - ref).max() < 1e-15 * 100        # numpy closed form too
    assert np.abs(ref).max() > 0.05                           # not a degenerate sample


def test_jacobian_central_differences(poses) -> None:
    q, _, d, _ = poses
    h = 1e-6
    num = np.stack([(kin.fk_construct(q + h * e) - kin.fk_construct(q - h * e)) / (2 * h)
                    for e in np.eye(3)], axis=-1)
    scale = np.abs(num).max(axis=(1, 2))
    assert (np.abs(d["J"] - num).max(axis=(1, 2)) / scale).max() < 1e-8
    assert (np.abs(kin.jacobian(q) - num).max(axis=(1, 2)) / scale).max() < 1e-8


def test_power_balance(poses) -> None:
    """tau . qdot = F . pdot, with pdot from the mechanism, not from J."""
    q, f, d, fl = poses
    qd = np.random.default_rng(8).uniform(-3, 3, size=q.shape)
    h = 1e-6
    pd = (kin.fk_construct(q + h * qd) - kin.fk_construct(q - h * qd)) / (2 * h)
    fp = np.sum(f * pd, axis=-1)
    scale = np.linalg.norm(f, axis=-1) * np.linalg.norm(pd, axis=-1)
    assert (np.abs(np.sum(d["tau"] * qd, axis=-1) - fp) / scale).max() < 1e-8
    assert (np.abs(np.sum(fl["tau"] * qd, axis=-1) - fp) / scale).max() < 2e-6


def test_ik_round_trip(poses) -> None:
    q, _, d, fl = poses
    assert d["ik_ok"].all() and fl["ik_ok"].all()
    assert np.abs(d["qik"] - q).max() < 1e-9                   # IK(FK(q)) = q, C double
    assert np.abs(fl["qik"] - q).max() < 1e-4                  # float: acos near 20 deg
    qn, ok = kin.ik(kin.fk(q))
    assert ok.all() and np.abs(qn - q).max() < 1e-9
    p = kin.fk_construct(q)
    assert np.abs(kin.fk(kin.ik(p)[0]) - p).max() < 1e-15 * 100  # FK(IK(p)) = p
    _, ok_far = kin.ik(np.array([[0, 0.11, 0], [0, -0.07, 0]]))
    assert not ok_far.any()


def test_float_against_double(poses) -> None:
    _, _, d, fl = poses

    def rel(a: np.ndarray, b: np.ndarray, ax: int | tuple[int, int]) -> np.ndarray:
        return np.abs(a - b).max(axis=ax) / np.abs(b).max(axis=ax)

    assert rel(fl["p"], d["p"], 1).max() < 1e-6
    assert rel(fl["J"], d["J"], (1, 2)).max() < 1e-6
    assert rel(fl["tau"], d["tau"], 1).max() < 1e-6


def test_checkpoint() -> None:
    """KINEMATICS.md: q = (0, 45, 45) deg -> p = (0, 70.7 mm, 0); F = (0, -1, 0) N needs
    tau = (0, 0.0354, 0.0354) N m; cond(J) = 1.41."""
    q = np.deg2rad([[0.0, 45.0, 45.0]])
    for flavour in ("d", "f"):
        out = kin_dump(flavour, q, np.array([[0.0, -1.0, 0.0]]))
        assert np.allclose(out["p"][0], [0, 0.0707, 0], atol=5e-5)
        assert np.allclose(out["tau"][0], [0, 0.0354, 0.0354], atol=5e-5)
        assert abs(np.linalg.cond(out["J"][0]) - 1.41) < 0.005
        assert out["guard"][0] == 1.0


def test_guard_against_model() -> None:
    """Fade near cos(alpha) = 0, sin(beta+gamma) = 0 and rho = 0, same as the numpy rule."""
    rng = np.random.default_rng(9)
    q = np.stack([rng.uniform(1.35, 1.53, 500), rng.uniform(-0.2, 1.5, 500),
                  rng.uniform(-0.2, 1.5, 500)], -1)
    q[:200, 0] = rng.uniform(-0.5, 0.5, 200)
    out = kin_dump("d", q, np.zeros_like(q))
    ref = kin.guard(q)
    assert np.abs(out["guard"] - ref).max() < 1e-9
    assert (ref == 0).sum() > 50 and ((ref > 0) & (ref < 1)).sum() > 50 and (ref == 1).sum() > 20


# ---- PC link from Python ----------------------------------------------------------------

def test_pclink_codec() -> None:
    assert pclink.crc16(b"123456789") == 0x29B1
    for n in (0, 1, 253, 254, 255, 600):
        data = bytes((i * 7 + 1) % 256 for i in range(n))
        enc = pclink.cobs_encode(data)
        assert 0 not in enc and pclink.cobs_decode(enc) == data


def test_pclink_against_firmware() -> None:
    built("link-pipe")
    p = pclink
    reqs = [p.encode(p.PING, 1), b"\x13\x37garbage\x00",
            p.encode(p.SET_SCENE, 2, p.set_scene(p.SCENE_WALL, (0, 0.07, 0), (0, -1, 0), 2000)),
            p.encode(p.SET_SCENE, 3, p.set_scene(p.SCENE_WALL, (0, 0.07, 0), (0, -1, 0), 4000)),
            p.encode(p.ENABLE, 4, b"\x01"), p.encode(p.ENABLE, 5, b"\x01", version=3),
            p.encode(p.GET_STATE, 6), p.encode(p.GET_STATS, 7)]
    r = subprocess.run([BUILD / "link-pipe"], input=b"".join(reqs), capture_output=True,
                       timeout=60, check=True)
    frames = p.split(r.stdout)
    assert [(fr.msg_type, fr.seq) for fr in frames] == [
        (p.PING | p.REPLY, 1), (p.SET_SCENE | p.REPLY, 2), (p.NAK, 3),
        (p.ENABLE | p.REPLY, 4), (p.GET_STATE | p.REPLY, 6), (p.GET_STATS | p.REPLY, 7)]
    fpga_id = regmap.load().by_name()["ID"].reset     # hal_sim's FPGA: the map built against
    assert p.parse_ping(frames[0].data) == (0x0100, fpga_id, 1000)
    assert frames[2].data == bytes([p.SET_SCENE, 1])
    st = p.parse_state(frames[4].data)
    assert np.allclose(st.p, [0, 0.0707107, 0], atol=1e-6)
    assert st.flags == 1 and st.err == 0 and st.scene == p.SCENE_WALL
    # the pose is 0.7 mm inside the 2000 N/m wall: F = (0, -1.41, 0) N
    assert np.allclose(st.f, [0, -2000 * (0.1 * np.sqrt(0.5) - 0.07), 0], atol=1e-3)
    stats = p.parse_stats(frames[5].data)
    assert stats == {"good": 6, "bad_framing": 1, "bad_crc": 0, "bad_version": 1,
                     "bad_type": 0, "bad_len": 0, "rejected": 1}
