"""The soc fidelity of the virtual device (run.fidelity = "soc": the Verilated SoC, the
firmware image on its soft CPU, in the closed loop of tb/native/device/device_harness.cpp built
with HG_SOC; tb/native/device/README.md "SoC fidelity").

One Verilator build of the SoC (cached under build/native/device_harness_soc-<hash>/) serves
every test here; the runs are short (the SoC simulates at ~0.03x real time).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.commands import device as device_cmd
from hapgate.device import runner, soc
from hapgate.device import scene as scene_mod
from hapgate.device.scene import SceneError

GRIP = ROOT / "scenes" / "grip.toml"
TAU_FS_NM = 0.48            # the firmware's torque full scale (dsp-fw/README.md: 8 A x 0.06 N m/A)


@pytest.fixture(scope="session")
def soc_exe() -> Any:
    """The soc build, once per session (runner.simulate finds it cached)."""
    return soc.build()


def _grip(fidelity: str, **over: Any) -> Any:
    return scene_mod.load(GRIP).override({"run.duration_s": 0.012, "run.fidelity": fidelity,
                                          **over})


@pytest.fixture(scope="session")
def grip_runs(soc_exe: Any) -> dict[str, Any]:
    """scenes/grip.toml (a rigid grip in the start pose, a 1000 N/m spring pulling on it), 12 ms
    of scene time, at rtl and at soc fidelity."""
    return {f: runner.simulate(_grip(f)) for f in ("rtl", "soc")}


def _budget(tau: np.ndarray, f: np.ndarray, k: float) -> float:
    """The torque difference the two builds of the firmware may show (N m): the same IEEE
    float operations on both (no FMA contraction: -ffp-contract=off on RV32, and the host's
    x86-64 baseline has no FMA; the SoC's float unit is IEEE-exact, tb/soc/test_fpu_cfu.py), so
    only the libm calls differ (picolibc's sinf/cosf/atan2f against glibc's). Take each
    trigonometric value off by up to eps = 4 ulp relative (2^-22, a generous bound for two
    libraries of < 2 ulp each). The endpoint p is a sum of three 0.05 m arms times products of
    two such values: |dp| <= 3 * 0.05 m * 2 eps; the spring's force k (p0 - p) then moves by
    k |dp|, and the torques J^T F (J: three 0.05 m arms, products of two values) by
    |J| |dF| + |tau| * 2 eps, with |J| <= 3 * 0.05 m."""
    eps = 2.0 ** -22
    dp = 3 * 0.05 * 2 * eps
    arm = 3 * 0.05
    return float(arm * k * dp + np.abs(tau).max() * 2 * eps + arm * np.abs(f).max() * 2 * eps)


def test_soc_matches_rtl_within_the_libm_budget(grip_runs: dict[str, Any]) -> None:
    """The same scene at rtl (native firmware) and soc fidelity (the image on the CPU): every
    enabled tick's torque commands within _budget (11 uN m here, under one of the firmware's
    torque codes, 0.48 N m / 32767 = 14.6 uN m), so a torque code differs by at most one and
    each DAC code (the gateware scales the torque code by the sine ROM, |sin| <= 8191, /32767)
    by at most 1 LSB. The pose is held still (a rigid grip) so that the two runs' different tick
    phases (the CPU's start-up moves the first tick by ~0.27 ms) see the same inputs."""
    a, b = (grip_runs[f].ticks for f in ("rtl", "soc"))
    ea, eb = a[a["drive"] == 1], b[b["drive"] == 1]
    assert ea.size >= 5 and eb.size >= 5, (ea.size, eb.size)
    n = min(ea.size, eb.size)
    ta, tb = ea["tau_fw"][-n:], eb["tau_fw"][-n:]
    assert np.abs(ta).max() > 0.05, "the grip scene renders no torque: nothing is compared"
    budget = _budget(ta, ea["f_fw"][-n:], 1000.0)
    assert budget < TAU_FS_NM / 32767       # under one torque code
    assert np.abs(ta - tb).max() <= budget, (np.abs(ta - tb).max(), budget)
    dtau, ddac, frames = soc.compare(grip_runs["rtl"], grip_runs["soc"])
    assert dtau == np.abs(ta - tb).max()
    assert frames > 100 and np.abs(grip_runs["rtl"].frames["dac"]).max() > 1000
    assert 0 <= ddac <= 1, ddac


def test_soc_summary_and_real_time_factor(grip_runs: dict[str, Any]) -> None:
    """The run's summary: the SoC's clock, every servo tick handled by the CPU (one tick
    record per handled interrupt), the handler within half a tick, the real-time factor."""
    raw = grip_runs["soc"]
    s = raw.summary
    assert int(s["clk_hz"]) == soc.CLK_HZ
    assert int(s["soc_isr_count"]) == raw.ticks.size > 15
    assert 0 < int(s["soc_isr_cycles_max"]) < soc.CLK_HZ // 1000 // 2
    assert int(s["fw_err"]) == 0
    rtf = float(s["sim_s"]) / float(s["wall_s"])
    print(f"soc fidelity: {float(s['sim_s']) * 1e3:.0f} ms of scene in {float(s['wall_s']):.2f} s "
          f"wall ({rtf:.4f}x real time), handler max {s['soc_isr_cycles_max']} cycles")


def test_cpu_stops_taking_interrupts_watchdog_zeroes_torque(soc_exe: Any) -> None:
    """Scene fault hang at soc fidelity: an upset clears the CPU's mstatus.MIE, the CPU stops
    taking the tick interrupt (no tick record after it), the watchdog key is no longer written,
    and the FPGA's watchdog zeroes every DAC channel within one DAC frame (16 us) and the load
    of its last channel after the expiry (the rtl fidelity's bound, test_closed_loop)."""
    sc = _grip("soc", **{"run.duration_s": 0.016,
                         "fault": [{"at_s": 0.003, "kind": "hang"}]})
    raw = runner.simulate(sc)
    tk = raw.ticks
    assert tk.size and tk["t"].max() < 0.003 + 1e-3 and (tk["drive"] == 1).any()
    ev = runner.events(sc, raw)
    assert len(ev) == 1 and math.isfinite(ev[0]["reaction_us"])
    wdog_s = int(raw.summary["wdog_us"]) * 1e-6
    assert 0.003 < ev[0]["cause_s"] <= 0.003 + 1e-3 + wdog_s
    bound_us = 16.0 + (5 * 96 + 11) / soc.CLK_HZ * 1e6
    assert 0 <= ev[0]["reaction_us"] <= bound_us, (ev[0], bound_us)
    loads = raw.loads
    t = loads["edge"] / raw.clk_hz - int(raw.summary["scene0_us"]) * 1e-6
    before = loads["code"][(t > 0.001) & (t < 0.003)]
    assert np.abs(before).max() > 1000          # it drove before the fault
    print(f"soc hang: watchdog expiry at {ev[0]['cause_s'] * 1e3:.3f} ms, zero torque "
          f"{ev[0]['reaction_us']:.2f} us later (bound {bound_us:.2f} us)")


@pytest.mark.parametrize("over, key", [
    ({"run.axes": [1]}, "run.axes"),
    ({"run.clk_hz": 6_000_000}, "run.clk_hz"),
    ({"fault": [{"at_s": 0.01, "kind": "watchdog"}]}, "fault[0].kind"),
    ({"firmware.test_limits": True}, "firmware.test_limits"),
    ({"run.position": "quadrature"}, "run.position"),
])
def test_soc_refusals_name_the_key(over: dict[str, Any], key: str) -> None:
    """What the soc fidelity cannot do is refused on load, the file and the key named (`hapgate
    scene run` exits 2 on a SceneError)."""
    with pytest.raises(SceneError, match=rf"grip\.toml: {key.replace('[', '.').replace(']', '.')}"):
        _grip("soc", **over)


def test_serve_soc_answers_info_on_the_uart_pins(soc_exe: Any) -> None:
    """`hapgate device serve --fidelity soc`: the PC's bytes shifted onto uart_rx and the
    replies decoded from uart_tx, bit by bit at 1 Mbaud: hapgate.host's INFO comes back with
    the SoC's FPGA and baud, and the firmware counted the frame as good."""
    from hapgate.host.api import Device

    sc = device_cmd.load_scene(str(GRIP), "soc")
    with device_cmd.Server(scene=sc, pace="free") as srv:
        dev = Device.open(srv.port, timeout=30.0)
        try:
            info = dev.info(timeout=30.0)
        finally:
            dev.close()
        said = srv.stop()
    assert info is not None
    assert "frames good" in said and "tx framing errors 0" in said, said
    good = int(said.split("frames good ")[1].split()[0])
    assert good >= 1, said
