"""Firmware co-simulation (tb/native/cosim/): dsp-fw against the Verilated top over the EMIF bus.

Each scenario runs once (module cache); every test re-checks the raw outputs with the golden
models (hapgate.golden.commutation's motor model, hapgate.golden.kinematics,
hapgate.golden.interp) instead of trusting
the harness's own verdict, and also requires that verdict.
"""

from __future__ import annotations

import subprocess
from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from hapgate.golden import configs
from hapgate.runners import cosim

CFG = configs.get("paper").top()
FRAME = CFG.comm.frame_clocks
BOUND = FRAME + CFG.comm.wr_cycles + 1   # rtl/top/README.md: zero torque within FRAME + WR + 1
MISSED, OVERRUN = 1 << 1, 5              # IRQ.MISSED; dsp-fw/README.md error code
STICKY = (1 << 12) | (1 << 13) | (1 << 14) | (1 << 15)   # STATUS WDOG, CFG_ERR, BUS_ERR, PROTO_ERR


@cache
def run(scenario: str, rate: int = 1000, ready: bool = False, seed: int = 1) -> cosim.CosimRun:
    return cosim.run(scenario, rate, cosim.BusTiming(use_ready=ready), seed=seed)


@cache
def checked(scenario: str, rate: int = 1000) -> cosim.Check:
    return cosim.check(run(scenario, rate))


def force_err(c: cosim.Check) -> np.ndarray:
    return np.linalg.norm(c.force - c.force_expected, axis=1)


def assert_torque_and_force(c: cosim.Check) -> None:
    assert c.torque_err.size > 1000
    worst = np.unravel_index(np.argmax(c.torque_err / c.torque_budget), c.torque_err.shape)
    assert np.all(c.torque_err <= c.torque_budget), (
        f"frame {worst[0]} motor {worst[1]}: |err| {c.torque_err[worst]:.2f} > "
        f"budget {c.torque_budget[worst]:.2f} command codes")
    e = force_err(c)
    assert np.all(e <= c.force_budget), f"force error {e.max():.4f} N exceeds its budget"


@pytest.mark.parametrize("rate", [1000, 10000])
def test_wall_normal_run(rate: int) -> None:
    r = run("wall", rate)
    assert r.ok, r.fails
    assert np.all(r.ticks["err"] == 0), "the firmware latched an error in a normal run"
    assert int(r.num("status")) & STICKY == 0 and int(r.num("irq")) & MISSED == 0
    # one ISR per servo tick for the whole run (none missed, none extra); the first tick comes one
    # period after the firmware's TICK_DIV write
    assert r.simulated_s * rate - 2 < r.num("ticks") <= r.simulated_s * rate
    assert len(r.ticks) == len(r.isr) == r.num("ticks")
    ticks = np.diff(r.isr["irq_edge"])
    assert np.all(ticks == CFG.clk_hz // rate)
    # the engine's enable: the tick before scene time 0 (the push start), not earlier; the firmware
    # drives from the next tick on
    drive = np.flatnonzero(r.ticks["drive"] == 1)
    assert -1.0 / rate <= r.num("enabled_t") < 0 and r.ticks["t"][drive[0]] == 0.0
    assert np.all(np.diff(drive) == 1)
    # the firmware's wall (env_*, from the scene through hapgate.golden.kinematics) is the plane
    # the harness's check builds with the plant's kinematics
    p0, n, _ = cosim.wall_plane(r.scene)
    assert np.allclose(r.vec("wall_p0"), p0, rtol=0, atol=1e-12)
    assert np.allclose(r.vec("wall_n"), n, rtol=0, atol=1e-12)
    c = checked("wall", rate)
    assert_torque_and_force(c)
    # the trajectory really penetrates, and the force follows k * depth out of the wall
    n, k = r.vec("wall_n"), r.num("wall_k")
    inside = c.force_expected @ n > 0
    assert c.depth.max() > 2e-3 and inside.sum() > 1000
    fn = c.force[inside] @ n
    # out of the wall wherever k*depth exceeds the quantisation budget (at a few um of depth the
    # torque command rounds to code 0 and the force is exactly 0, within that budget)
    assert np.all(fn[k * c.depth[inside] > c.force_budget[inside]] > 0)
    assert np.all(fn >= 0)
    assert np.allclose(fn, k * c.depth[inside], rtol=0, atol=c.force_budget[inside].max())
    strong = k * c.depth[inside] > 1.0
    cosang = fn[strong] / np.linalg.norm(c.force[inside][strong], axis=1)
    assert cosang.min() > 0.99
    # free space: no force beyond the quantisation budget
    free = ~inside
    assert free.sum() > 1000
    assert np.all(np.linalg.norm(c.force[free], axis=1) <= c.force_budget[free])


def test_bus_ready_mode_same_result() -> None:
    """Waiting for bus_ready instead of a fixed strobe drives the motors the same way."""
    a, b = run("wall", 10000), run("wall", 10000, ready=True)
    assert b.ok, b.fails
    assert_torque_and_force(cosim.check(b))
    # the snapshot is latched at the tick, whatever the access timing: identical commands
    assert len(a.isr) == len(b.isr)
    for col in ("code0", "code1", "code2"):
        assert np.array_equal(a.isr[col], b.isr[col])
    assert np.array_equal(a.ticks["err"], b.ticks["err"])


def reaction(r: cosim.CosimRun, channels: list[int]) -> int:
    got = cosim.reaction_clocks(r, channels)
    assert got == int(r.num("reaction_clocks"))   # the harness measured the same
    return got


def nonzero_before(r: cosim.CosimRun, channels: list[int]) -> bool:
    cause = r.num("cause_edge")
    ld = r.loads[(r.loads["edge"] < cause) & (r.loads["edge"] >= cause - FRAME)]
    return bool(np.any(ld["code"][np.isin(ld["ch"], channels)] != 0))


def all_zero_after(r: cosim.CosimRun, edge: float, channels: list[int]) -> bool:
    ld = r.loads[(r.loads["edge"] > edge) & np.isin(r.loads["ch"], channels)]
    return ld.size > 0 and bool(np.all(ld["code"] == 0))


def test_watchdog_not_petted() -> None:
    r = run("wdog")
    assert r.ok, r.fails
    assert r.num("dropped") > 0                    # key writes were lost from t_fault on
    cause = r.num("cause_edge")
    # expiry exactly WDOG_TIMEOUT (10 ms reset value) after the last key that reached the FPGA
    # (its strobe rose at last_key_edge; captured 3 edges after the fall, applied 1 later)
    timeout = 10_000 * CFG.clk_hz // 1_000_000
    assert abs(cause - r.num("last_key_edge") - timeout) <= 2
    ch = list(range(6))
    assert nonzero_before(r, ch)
    assert 0 <= reaction(r, ch) <= BOUND
    assert all_zero_after(r, cause + BOUND, ch)
    assert int(r.num("status")) & (1 << 12)       # STATUS.WDOG says why
    assert r.num("fw_err") == cosim.ERR_WATCHDOG  # ... and the firmware latched WATCHDOG
    assert_torque_and_force(checked("wdog"))       # normal until the expiry


def test_dsp_hang() -> None:
    r = run("hang")
    assert r.ok, r.fails
    ch = list(range(6))
    assert nonzero_before(r, ch)
    assert 0 <= reaction(r, ch) <= BOUND
    assert all_zero_after(r, r.num("cause_edge") + BOUND, ch)
    assert int(r.num("status")) & (1 << 12)
    # the resumed firmware sees SEQ jumped by ~10 ticks: OVERRUN, and writes zero torque
    last, codes = r.ticks[-1], r.isr[-1]
    assert last["err"] == OVERRUN and last["drive"] == 0
    assert codes["code0"] == codes["code1"] == codes["code2"] == 0


def test_a_cause_inside_a_frame_is_not_a_torque_error() -> None:
    """At 500 Hz the watchdog's expiry after the hang falls between a frame's loads: that frame's
    later channels are zeroed (the reaction, checked), its torque is no reconstruction error;
    every frame loaded wholly before the cause is still checked, by the harness and again here."""
    r = run("hang", 500)
    assert r.ok, r.fails
    cause = r.num("cause_edge")
    straddling = (r.frames["start"] < cause) & (r.frames["start"] + 6 * r.num("skew") > cause)
    assert np.any(straddling)        # the case this test is about happened
    ch = list(range(6))
    assert 0 <= reaction(r, ch) <= BOUND and all_zero_after(r, cause + BOUND, ch)
    assert_torque_and_force(cosim.check(r))


def test_encoder_dropout() -> None:
    r = run("dropout")
    assert r.ok, r.fails
    axis = 1
    ch = [2 * axis, 2 * axis + 1]
    assert r.num("cause_edge") > r.num("fault_cmd_edge")
    assert nonzero_before(r, ch)
    assert 0 <= reaction(r, ch) <= BOUND
    assert all_zero_after(r, r.num("cause_edge") + BOUND, ch)
    assert int(r.num("status")) & (1 << axis)              # STATUS.FAULT[1]
    assert r.num("fw_err") == cosim.ERR_AXIS_FAULT and r.num("fw_err_axis") == axis
    # after the firmware latched, every motor is at zero torque within a frame
    assert all_zero_after(r, r.num("latch_edge") + BOUND, list(range(6)))
    assert_torque_and_force(checked("dropout"))


def test_negative_control_commutation_offset() -> None:
    """A wrong commutation offset (11.25 deg electrical on motor 0) must be caught, by the harness
    and by the independent check: the checks can fail."""
    r = run("miscal")
    assert not r.ok and any("torque" in f for f in r.fails)
    c = checked("miscal")
    assert np.any(c.torque_err[:, 0] > c.torque_budget[:, 0])
    assert np.all(c.torque_err[:, 1:] <= c.torque_budget[:, 1:])


def test_a_wrong_firmware_wall_fails_the_force_check(tmp_path, monkeypatch) -> None:
    """The force check has power: a run configuration that gives the firmware a wall 10 % stiffer
    (env_k) than the scene's fails the harness's force check (its reference is the scene's wall,
    cosim_wall_at/cosim_wall_k) and the independent one, while the torques still match their
    commands (the firmware did what it was told)."""
    scene = tmp_path / "stiff.toml"
    scene.write_text("[run]\nduration_s = 0.0745\n")
    make = cosim.run_config
    monkeypatch.setattr(cosim, "run_config",
                        lambda sc: make(sc).replace("env_k = 2000.0\n", "env_k = 2200.0\n"))
    r = cosim.run(scene)
    assert not r.ok and "force within budget" in r.fails, r.fails
    c = cosim.check(r)
    assert np.all(c.torque_err <= c.torque_budget)
    assert np.any(force_err(c) > c.force_budget)


def test_bus_throughput_and_integrity() -> None:
    r = run("bus")
    assert r.ok and r.num("mismatches") == 0
    assert r.num("bus_reads") >= 200_000 and r.num("bus_writes") == 200_000
    assert int(r.num("status")) & ((1 << 14) | (1 << 15)) == 0   # no BUS_ERR / PROTO_ERR


def test_homing_accuracy() -> None:
    r = run("wall")
    err = cosim.home_error(r)
    assert np.all(np.abs(err) <= cosim.interp_budget_counts()), err


@pytest.mark.parametrize("seed", [2, 3])
def test_power_up_anywhere(seed: int) -> None:
    """Other power-up positions (uniform over the whole revolution): the normal run passes the
    harness and the independent torque/force checks, and the raw position (relative to
    power-up) would have been a large electrical angle away from the homed one on some axis, so
    commutating from it could not pass."""
    r = run("wall", 1000, seed=seed)
    assert r.ok, r.fails
    assert_torque_and_force(cosim.check(r))
    up = np.radians(r.vec("powerup_deg"))
    assert np.all((up >= 0) & (up < 2 * np.pi))
    # raw - homed = (2 pi - powerup) of shaft: in electrical degrees, wrapped to +-180
    d = np.degrees(np.angle(np.exp(1j * CFG.comm.pole_pairs * (2 * np.pi - up))))
    assert np.abs(d).max() > 30.0, d
    assert np.all(np.abs(cosim.home_error(r)) <= cosim.interp_budget_counts())


@pytest.mark.parametrize("setup, strobe, hold, why", [
    (1, 4, 2, "strobe must be >= 5"), (0, 5, 2, "recovery (setup + hold) must be >= 3"),
    (1, 5, 1, "recovery (setup + hold) must be >= 3")])
def test_bus_timing_below_the_minimums_is_refused(tmp_path, setup, strobe, hold, why) -> None:
    """rtl/bus/README.md: strobe >= 5 clocks (or ready), recovery >= 3. The shared bus master
    (tb/native/device/bus_hal.h) refuses one clock less of either before the first access:
    exit 2 and the reason; the minimums themselves run (test_bus_throughput_and_integrity)."""
    sc = replace(cosim.load("bus"), bus=cosim.BusTiming(setup, strobe, hold))
    p = _harness(tmp_path, cosim.run_config(sc))
    assert p.returncode == 2, p.stdout[-300:]
    assert f"setup={setup} strobe={strobe} hold={hold}" in p.stderr and why in p.stderr, p.stderr
    assert "result=" not in p.stdout


def _harness(tmp_path, text: str, name: str = "case") -> subprocess.CompletedProcess:
    cfg = tmp_path / f"{name}.run"
    cfg.write_text(text)
    return subprocess.run([str(cosim.build()), str(cfg), str(tmp_path)], capture_output=True,
                          text=True, timeout=60)


def test_every_scenario_is_a_scene_file() -> None:
    """The co-simulation's scenarios are the files of scenes/cosim/, each valid, with the fault
    and the checks the tests above rely on."""
    assert sorted(cosim.SCENARIOS) == sorted(f.stem for f in cosim.SCENES.glob("*.toml"))
    faults = {n: [f["kind"] for f in cosim.load(n).faults] for n in cosim.SCENARIOS}
    assert faults == {"wall": [], "wdog": ["watchdog"], "hang": ["hang"], "dropout": ["dropout"],
                      "miscal": [], "bus": []}
    assert cosim.load("miscal").get("firmware", "comm_err") == [32, 0, 0]
    assert cosim.load("dropout").faults[0]["axis"] == 1
    assert cosim.load("bus").get("run", "kind") == "bus"


@pytest.mark.parametrize("text, where", [
    ("[run]\nservo_hz = 1000\nrate = 2\n", "run.rate: unknown key"),
    ("[hand]\nfree_deg = [4.0, 46.0]\n", "hand.free_deg: expected a list of 3"),
    ("[walls]\nk = 1.0\n", "walls: unknown table"),
    ("[[fault]]\nat_s = 0.01\nkind = \"melt\"\n", "fault[0].kind: one of"),
    ("[[fault]]\nat_s = 0.01\nkind = \"hang\"\nwhen = 1\n", "fault[0].when: unknown key"),
    ("[run]\nduration_s = 0.05\n[[fault]]\nat_s = 0.06\nkind = \"hang\"\n", "fault[0].at_s"),
    ("[bus]\nuse_ready = 1\n", "bus.use_ready: expected bool"),
    ("[run]\nservo_hz = 333\n", "run.servo_hz: the firmware enables at the tick before"),
])
def test_a_malformed_scene_is_refused_naming_file_and_key(tmp_path, text, where) -> None:
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(cosim.CosimSceneError) as e:
        cosim.load(f)
    assert str(e.value).startswith(f"{f}: ") and where in str(e.value), str(e.value)


@pytest.mark.parametrize("line, why", [
    ("cosim_wall = 0.5", "unknown key cosim_wall"), ("mech_us = 16", "unknown key mech_us"),
    ("cosim_bus = 1 5 2", "cosim_bus: expected 4 values"),
    ("fault = 0.01 watchdog 0\nfault = 0.02 hang 0", "at most one fault")])
def test_the_harness_refuses_a_bad_run_configuration(tmp_path, line, why) -> None:
    """The harness reads its run configuration with the device harnesses' parser: an unknown key
    (or a model-fidelity one), a wrong count or a second fault is exit 2 naming the file and
    the key, before anything runs."""
    text = cosim.run_config(cosim.load("wall")) + line + "\n"
    p = _harness(tmp_path, text, "bad")
    assert p.returncode == 2, p.stdout[-300:]
    assert p.stderr.startswith(f"error: {tmp_path / 'bad.run'}: ") and why in p.stderr, p.stderr
    assert p.stdout == "" and not (tmp_path / "frames.csv").exists()


def test_the_harness_refuses_a_missing_run_configuration(tmp_path) -> None:
    missing = tmp_path / "none.run"
    p = subprocess.run([str(cosim.build()), str(missing), str(tmp_path)], capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 2 and f"error: {missing}: cannot read" in p.stderr, p.stderr
    assert p.stdout == ""


def test_the_command_refuses_a_malformed_scene_with_exit_2(tmp_path, capsys) -> None:
    """`hapgate cosim run|check`: a malformed scene is exit 2 naming the file and the key, before
    anything is built or run; the shipped scenes all check."""
    from hapgate.commands import cli

    bad = tmp_path / "bad.toml"
    bad.write_text("[wall]\nk = 1.0\nkk = 2\n")
    out = tmp_path / "out"
    assert cli.main(["cosim", "run", str(bad), "--out", str(out)]) == 2
    assert f"error: {bad}: wall.kk: unknown key" in capsys.readouterr().err
    assert not out.exists()
    assert cli.main(["cosim", "check", *map(str, sorted(cosim.SCENES.glob("*.toml")))]) == 0
    assert cli.main(["cosim", "check", str(cosim.SCENES / "wall.toml"), str(bad)]) == 2
